"""The reference defenders (HJ tubes + assignment MIP), the matching baseline and the HJ
attacker, on coarse tubes of the paper map."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import reachavoid_env
from policies import (
    HJAttacker,
    HJDefenderPolicy,
    MatchingDefenderPolicy,
    RandomAttacker,
    ShortestPathAttacker,
)
from reachavoid.rollout import run_episode


def first_decision(policy, scenario_name: str):
    env = reachavoid_env.parallel_env(scenario=scenario_name)
    env.reset(seed=0)
    policy.reset(env.unwrapped.scenario)
    actions = policy.act(env.unwrapped.game_state())
    return env, actions


def test_worked_example_one_defender_takes_both_attackers(coarse_tubes):
    """The paper's method (``margin_cells=0``) assigns both attackers to the defender."""
    vf11, vf21 = coarse_tubes
    reference = HJDefenderPolicy(vf11, vf21, margin_cells=0.0)
    _, actions = first_decision(reference, "paper_2v1")
    assert reference.nominal_captures == 2 == reference.guaranteed_captures
    assert sorted(reference.assignment) == [("defender_0", "attacker_0"),
                                            ("defender_0", "attacker_1")]
    assert actions["defender_0"].dtype == np.float32
    assert np.isclose(np.linalg.norm(actions["defender_0"]), 1.0, atol=1e-5)
    baseline = MatchingDefenderPolicy(vf11, margin_cells=0.0)
    first_decision(baseline, "paper_2v1")
    assert baseline.nominal_captures == 1 == baseline.guaranteed_captures
    assert len(baseline.assignment) == 1


def test_worked_example_is_not_certified(coarse_tubes):
    """The worked example's 2 vs 1 value is a few thousandths, inside the tube's error:
    the certified policy does not count (or play) the pair; the paper's count stays 2."""
    vf11, vf21 = coarse_tubes
    reference = HJDefenderPolicy(vf11, vf21)
    env, _ = first_decision(reference, "paper_2v1")
    state = env.unwrapped.game_state()
    value21 = vf21.value(np.concatenate([state.attacker_positions.reshape(-1),
                                         state.defender_positions[0]]))
    assert 0.0 < value21 <= reference.margin(vf21)
    assert reference.nominal_captures == 2
    assert reference.guaranteed_captures == len(reference.assignment) < 2


def _certified_games(policy, state, previous) -> int:
    """Check that every game the policy plays clears its tube's margin, or was played the
    step before and still has a value > 0; return how many are kept inside the band."""
    attackers, defenders = state.attacker_positions, state.defender_positions
    kept = set() if previous is None else {(j, mine) for j, mine in
                                           enumerate(previous.by_defender) if mine}
    in_band = 0
    for j, mine in enumerate(policy.last_assignment.by_defender):
        games = [(policy.vf11, np.concatenate([attackers[i], defenders[j]])) for i in mine]
        if len(mine) == 2:
            games.append((policy.vf21, np.concatenate([attackers[mine[0]], attackers[mine[1]],
                                                       defenders[j]])))
        for vf, game_state in games:
            value = float(vf.value(game_state))
            if value <= policy.margin(vf):
                assert (j, mine) in kept and value > 0.0, (j, mine, value)
                in_band += 1
    return in_band


def test_certified_assignment_keeps_taken_games(coarse_tubes):
    """Over a played 8v4 episode every assigned game is certified (above the margin when
    taken, > 0 while kept), the certified count never exceeds the paper's, and games that
    drift into the margin band are kept once taken (hysteresis) rather than dropped."""
    vf11, vf21 = coarse_tubes
    policy = HJDefenderPolicy(vf11, vf21)
    scenario = reachavoid_env.builtin_scenario("paper_2v1").with_players(8, 4)
    env = reachavoid_env.parallel_env(scenario=scenario)
    env.reset(seed=3)
    attackers = ShortestPathAttacker()
    attackers.reset(env.unwrapped.scenario)
    policy.reset(env.unwrapped.scenario)
    previous, kept_in_band = None, 0
    while env.agents:
        state = env.unwrapped.game_state()
        actions = {**attackers.act(state), **policy.act(state)}
        kept_in_band += _certified_games(policy, state, previous)
        assert policy.guaranteed_captures <= policy.nominal_captures
        previous = policy.last_assignment
        env.step({a: actions[a] for a in env.agents})
    assert kept_in_band > 0, "no game ever drifted into the band: the hysteresis is untested"


@pytest.mark.parametrize("idle", ["shadow", "stand"])
def test_unassigned_defenders(coarse_tubes, idle):
    vf11, vf21 = coarse_tubes
    policy = HJDefenderPolicy(vf11, vf21, idle=idle)
    env, actions = first_decision(policy, "paper_8v4")
    state = env.unwrapped.game_state()
    assigned = {d for d, _ in policy.assignment}
    for name in state.defender_names:
        norm = float(np.linalg.norm(actions[name]))
        if name in assigned or idle == "shadow":
            assert np.isclose(norm, 1.0, atol=1e-5), name
        else:
            assert norm == 0.0, name


def test_matching_unmatched_pursue_moves_everyone(coarse_tubes):
    vf11, _ = coarse_tubes
    policy = MatchingDefenderPolicy(vf11, unmatched="pursue")
    _, actions = first_decision(policy, "paper_8v4")
    assert all(np.isclose(np.linalg.norm(a), 1.0, atol=1e-5) for a in actions.values())


def test_tubes_for_another_game_are_refused(coarse_tubes):
    vf11, vf21 = coarse_tubes
    scenario = reachavoid_env.builtin_scenario("paper_2v1")
    faster = dataclasses.replace(scenario, defender_speed=2.0)
    with pytest.raises(ValueError, match="defender_speed"):
        HJDefenderPolicy(vf11, vf21).reset(faster)
    with pytest.raises(ValueError, match="1v1 and a 2v1"):
        HJDefenderPolicy(vf21, vf11)
    with pytest.raises(ValueError, match="idle"):
        HJDefenderPolicy(vf11, vf21, idle="wander")


def test_hj_attacker_heads_away_from_its_defender(coarse_tubes):
    vf11, _ = coarse_tubes
    attacker = HJAttacker(vf11)
    env = reachavoid_env.parallel_env(scenario="paper_2v1")
    env.reset(seed=0)
    attacker.reset(env.unwrapped.scenario)
    actions = attacker.act(env.unwrapped.game_state())
    assert set(actions) == {"attacker_0", "attacker_1"}
    for action in actions.values():
        assert np.isclose(np.linalg.norm(action), 1.0, atol=1e-5)


def test_guarantee_over_random_starts(coarse_tubes, record_property):
    """Algorithm 1's promise with the certificate: no attacker arrives that a guarantee
    ruled out, and captured-so-far plus guaranteed-from-now never falls. Even at these
    coarse CI grids (25^4, 13^6), where the paper's reading (``margin_cells=0``) breaks in
    about one episode in seven (BENCHMARKS.md), the certified count holds on these 18
    starts; one fall is tolerated (the control chatter at a kink measured at these grids),
    no broken promise is. The nominal count (the paper's rule) shows the MIP at work."""
    vf11, vf21 = coarse_tubes
    base = reachavoid_env.builtin_scenario("paper_2v1")
    attackers = {"shortest-path": ShortestPathAttacker, "random": lambda: RandomAttacker(0),
                 "hj": lambda: HJAttacker(vf11)}
    episodes = violations = promised = 0
    for m, n in ((4, 2), (6, 2), (8, 4)):
        env = reachavoid_env.parallel_env(scenario=base.with_players(m, n))
        for make in attackers.values():
            for seed in range(2):
                result = run_episode(env, make(), HJDefenderPolicy(vf11, vf21), seed=seed)
                episodes += 1
                violations += result.guarantee_violations > 0
                promised += result.nominal_guarantees[0]
                assert result.arrivals_beyond_promise == 0, (m, n, seed)
                assert result.guarantees[0] <= result.nominal_guarantees[0]
                assert result.captured_count + result.arrived_count <= m
    record_property("guarantee_violation_episodes", f"{violations}/{episodes}")
    print(f"guarantee violated in {violations} of {episodes} episodes at 25^4 / 13^6")
    assert promised >= episodes, "the MIP promised almost nothing: the test would be vacuous"
    assert violations <= 1

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
    vf11, vf21 = coarse_tubes
    reference = HJDefenderPolicy(vf11, vf21)
    _, actions = first_decision(reference, "paper_2v1")
    assert reference.nominal_captures == 2
    assert 0 <= reference.guaranteed_captures <= reference.nominal_captures
    assert sorted(reference.assignment) == [("defender_0", "attacker_0"),
                                            ("defender_0", "attacker_1")]
    assert actions["defender_0"].dtype == np.float32
    assert np.isclose(np.linalg.norm(actions["defender_0"]), 1.0, atol=1e-5)
    baseline = MatchingDefenderPolicy(vf11)
    first_decision(baseline, "paper_2v1")
    assert baseline.nominal_captures == 1 >= baseline.guaranteed_captures
    assert len(baseline.assignment) == 1


def test_paper_games_first_assignment(coarse_tubes):
    vf11, vf21 = coarse_tubes
    for name, (ours, baseline) in {"paper_6v2": (4, 2), "paper_8v4": (8, 4)}.items():
        reference = HJDefenderPolicy(vf11, vf21)
        first_decision(reference, name)
        matching = MatchingDefenderPolicy(vf11)
        first_decision(matching, name)
        assert reference.nominal_captures >= ours, name
        assert matching.nominal_captures <= baseline, name
        assert reference.nominal_captures > matching.nominal_captures, name
        assert reference.guaranteed_captures <= reference.nominal_captures, name
        per_defender = {}
        for defender, attacker in reference.assignment:
            per_defender.setdefault(defender, []).append(attacker)
        assert max(len(v) for v in per_defender.values()) <= 2


def test_reference_defenders_capture_both_attackers_of_paper_2v1(coarse_tubes):
    vf11, vf21 = coarse_tubes
    env = reachavoid_env.parallel_env(scenario="paper_2v1")
    result = run_episode(env, ShortestPathAttacker(), HJDefenderPolicy(vf11, vf21), seed=0)
    assert result.captured_count == 2
    assert result.nominal_guarantees[0] == 2 >= result.guarantees[0]
    assert result.guarantee_violations == 0


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
    """Algorithm 1's promise: captures reach the first guarantee, and captured-so-far plus
    guaranteed-from-now never falls. At these coarse CI grids (25^4, 13^6) numerical error
    breaks it in some episodes: count and report them (BENCHMARKS.md has the rates at both
    resolutions); a policy with a wrong sign or a broken MIP breaks it in most. The
    certified count (margins of half a cell) promises little at these grids; the nominal
    one (the paper's rule) shows the MIP at work."""
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
                assert result.guarantees[0] <= result.nominal_guarantees[0]
                assert result.captured_count + result.arrived_count <= m
    record_property("guarantee_violation_episodes", f"{violations}/{episodes}")
    print(f"guarantee violated in {violations} of {episodes} episodes at 25^4 / 13^6")
    assert promised >= episodes, "the MIP promised almost nothing: the test would be vacuous"
    assert violations <= episodes // 6

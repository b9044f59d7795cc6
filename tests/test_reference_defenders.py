"""The reference defenders (HJ tubes + assignment MIP), the matching baseline and the HJ
attacker, on coarse tubes of the paper map."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from lookups_reference import one_game_controls, still_winning
from lookups_reference import slack as game_slack

import reachavoid_env
from policies import (
    HJAttacker,
    HJDefenderPolicy,
    HJPairsAttacker,
    MatchingDefenderPolicy,
    RandomAttacker,
    ShortestPathAttacker,
)
from policies.certificate import Basis, Match, games_of, match_arrays, no_team_values, roles_of
from policies.steering import (
    ATTACKER_MOVES,
    HEDGE_STEPS,
    game_keepers,
    hedge_pairs,
    held_one_step,
    steer,
)
from policies.strategy import Program, Spare, Strategy
from policies.tube_states import pair_states
from reachavoid.rollout import run_episode
from reachavoid_env.overlay import EdgeKind
from solvers import open_space


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
    assert reference.overlay().kinds == (EdgeKind.PAIR, EdgeKind.PAIR)  # a 2 vs 1 game
    assert actions["defender_0"].dtype == np.float32
    assert np.isclose(np.linalg.norm(actions["defender_0"]), 1.0, atol=1e-5)
    baseline = MatchingDefenderPolicy(vf11, margin_cells=0.0)
    first_decision(baseline, "paper_2v1")
    assert baseline.nominal_captures == 1 == baseline.guaranteed_captures
    assert len(baseline.assignment) == 1
    assert [e.kind for e in baseline.overlay().kinded_edges] == [EdgeKind.ASSIGN]


def test_worked_example_is_not_certified(coarse_tubes):
    """The worked example's 2 vs 1 value is a few thousandths, inside the tube's error:
    the certified policy still plays the paper's assignment but guarantees nothing."""
    vf11, vf21 = coarse_tubes
    reference = HJDefenderPolicy(vf11, vf21)
    env, actions = first_decision(reference, "paper_2v1")
    state = env.unwrapped.game_state()
    value21 = vf21.value(np.concatenate([state.attacker_positions.reshape(-1),
                                         state.defender_positions[0]]))
    assert 0.0 < value21 <= reference.margin(vf21)
    assert reference.nominal_captures == 2 == len(reference.assignment)
    assert reference.guaranteed_captures == 0 and reference.certified_games == []
    # nothing certified, and the pair is played all the same: the plan sends the defender
    # after one of the pair, so it keeps the pair's optimal control (a pair that splits
    # beats the plan); the overlay draws the pair game, not a race
    assert reference.plan.targets[0] in (0, 1)
    overlay = reference.overlay()
    assert [(e.defender, e.kind) for e in overlay.kinded_edges] == [
        ("defender_0", EdgeKind.PAIR)] * 2
    assert overlay.lines == ("guaranteed: 0 of 2, program's count: 2",)
    paper = HJDefenderPolicy(vf11, vf21, idle="stand", margin_cells=0.0)
    _, played = first_decision(paper, "paper_2v1")
    np.testing.assert_array_equal(actions["defender_0"], played["defender_0"])


def test_a_game_yields_to_the_plan_for_another_attacker():
    """``game_keepers``: the defender of an uncertified game keeps the game's control only
    while the plan sends it after the game's attacker (one of its pair) and no certified
    game holds it; copy by copy."""
    singles = np.array([[6, 3], [7, 4], [8, 5]])
    doubles = np.array([[0, 1, 0], [2, 3, 1], [4, 5, 2]])
    targets = np.array([1, 0, 4, 6, 8, 8])
    busy = np.array([False, False, True, False, False, True])
    copies, keepers = game_keepers(np.column_stack([[0, 0, 0], singles]),
                                   np.column_stack([[0, 0, 0], doubles]),
                                   targets[None], busy[None])
    np.testing.assert_array_equal(keepers, [3, 0])
    np.testing.assert_array_equal(copies, [0, 0])
    # the same games in copy 1 beside a copy 0 where the plan chases no one
    copies, keepers = game_keepers(np.column_stack([[1, 1, 1], singles]),
                                   np.column_stack([[1, 1, 1], doubles]),
                                   np.stack([np.full(6, -1), targets]),
                                   np.stack([np.zeros(6, dtype=bool), busy]))
    np.testing.assert_array_equal(keepers, [3, 0])
    np.testing.assert_array_equal(copies, [1, 1])
    none = game_keepers(np.zeros((0, 3), dtype=np.int64), np.zeros((0, 4), dtype=np.int64),
                        targets[None], busy[None])
    assert all(len(part) == 0 for part in none)


def test_an_uncertified_pair_keeps_its_better_single_won(vf11):
    """``hedge_pairs``: the defender of an uncertified pair game keeps the pair's control
    while the better of its two 1 vs 1 values stays above ``HEDGE_STEPS`` steps, else
    plays that single's 1 vs 1 optimal control (the defender's gradient ascent); the
    better single is sticky within one step of value; copy by copy."""
    step = 2.5 * 0.005
    attackers = np.array([[[-0.5, 0.4], [0.2, -0.6]]] * 3)
    defenders = np.array([[[0.3, 0.2]]] * 3)
    doubles = np.array([[c, 0, 1, 0] for c in range(3)])
    values11 = np.empty((3, 2, 1))
    values11[0, :, 0] = (HEDGE_STEPS + 0.5) * step, 0.0          # first clears the floor
    values11[1, :, 0] = (HEDGE_STEPS - 0.5) * step, -step          # first at the floor
    values11[2, :, 0] = (HEDGE_STEPS - 0.5) * step, (HEDGE_STEPS - 1.0) * step
    hedges = [{}, {}, {0: 1}]                                      # copy 2 held the second
    pair = np.full((3, 1, 2), 7.0, dtype=np.float32)               # the pairs' controls
    actions = pair.copy()
    hedge_pairs(vf11, doubles, values11, hedges, attackers, defenders, step, actions)
    assert hedges == [{0: 0}, {0: 0}, {0: 1}]
    np.testing.assert_array_equal(actions[0], pair[0])
    for c, i in ((1, 0), (2, 1)):
        _, gradient = vf11.value_and_gradient(np.concatenate([attackers[c, i],
                                                              defenders[c, 0]]))
        ascent = gradient[2:] / np.linalg.norm(gradient[2:])
        np.testing.assert_allclose(actions[c, 0], ascent, atol=1e-6)
    # one step of value more and the other single takes over
    values11[2, 0, 0] = values11[2, 1, 0] + 1.5 * step
    hedge_pairs(vf11, doubles[2:], values11, hedges, attackers, defenders, step, actions)
    assert hedges[2] == {0: 0}
    before = actions.copy()
    hedge_pairs(vf11, doubles[:0], values11, hedges, attackers, defenders, step, actions)
    np.testing.assert_array_equal(actions, before)


def _check_certificate(policy, state, previous: list[Match]) -> int:
    """Every certified game is played, and either clears its tube's margin now or was
    certified the step before (less attackers that left) and still has a value > 0; every
    such game of the step before is still certified. An open-space game is one defender
    against one attacker that the tube does not certify now, and either passes the
    open-space condition at the certify margin now or was certified the step before and
    passes it at the keep margin. Returns how many tube games lie inside the margin
    band."""
    values11 = policy.vf11.value(pair_states(state.attacker_positions,
                                             state.defender_positions))
    certified = policy.certified_games
    assert set(certified) <= set(games_of(policy.last_assignment))
    tubes = policy.tubes
    space = policy._open
    if space is not None:
        one = state.attacker_positions[None], state.defender_positions[None]
        asked = (values11 <= 0.0) & state.active_attackers[:, None]
        wins = space.wins(*one, asked[None])
    held = None if space is None else space.held(
        [previous], *one, state.active_attackers[None], wins)[0]
    still = still_winning(previous, state, values11, tubes, held=held)
    assert set(still) <= set(certified)
    in_band = 0
    for game, slack in zip(certified, game_slack(tubes, certified, state, values11), strict=True):
        if game.basis is Basis.OPEN:
            assert len(game.defenders) == len(game.attackers) == 1, game
            (i,), (j,) = game.attackers, game.defenders
            now, kept = (open_space.defender_certifies(
                space.game_map, state.attacker_positions[[i]], state.defender_positions[[j]],
                space.speeds, margin, space.clearance)[0] for margin in (space.certify,
                                                                          space.keep))
            assert now or (kept and game in previous), game
            assert slack <= 0.0 or game in previous, game
        elif slack <= 0.0:
            assert game in still, game
            in_band += 1
    return in_band


@pytest.mark.parametrize("idle, seed", [("intercept", 32), ("shadow", 31)])
def test_certified_games_hold_their_invariants_in_play(coarse_tubes, idle, seed):
    """Over a played 8v4 episode the certificate holds its invariants (``_check_certificate``)
    and the certified count never exceeds the paper's, whatever the free defenders do."""
    vf11, vf21 = coarse_tubes
    policy = HJDefenderPolicy(vf11, vf21, idle=idle)
    scenario = reachavoid_env.builtin_scenario("paper_2v1").with_players(8, 4)
    env = reachavoid_env.parallel_env(scenario=scenario)
    env.reset(seed=seed)
    attackers = ShortestPathAttacker()
    attackers.reset(env.unwrapped.scenario)
    policy.reset(env.unwrapped.scenario)
    previous: list[Match] = []
    certified_steps = 0
    while env.agents:
        state = env.unwrapped.game_state()
        actions = {**attackers.act(state), **policy.act(state)}
        _check_certificate(policy, state, previous)
        assert policy.guaranteed_captures <= policy.nominal_captures
        certified_steps += bool(policy.certified_games)
        previous = policy.certified_games
        env.step({a: actions[a] for a in env.agents})
    assert certified_steps > 0, "nothing was ever certified: the invariants are untested"


def test_a_certified_game_is_kept_in_the_band_and_given_up_at_zero(coarse_tubes):
    """One defender, one attacker moved between decisions: a game in the margin band is
    played but not certified; once certified (clear of the margin) it stays certified in
    the band; at value <= 0 it is given up, and is not certified again from the band."""
    vf11, vf21 = coarse_tubes
    policy = HJDefenderPolicy(vf11, vf21, margin_cells=0.5)   # values here are <= R = 0.1
    scenario = reachavoid_env.builtin_scenario("paper_2v1").with_players(1, 1)
    env = reachavoid_env.parallel_env(scenario=scenario)
    defender = np.array([[0.3, -0.3]])
    xs = np.linspace(-0.9, 0.9, 61)
    grid = np.array([(x, y) for x in xs for y in xs
                     if not (-0.15 < x < 0.15 and (y < -0.25 or 0.25 < y < 0.65))
                     and np.hypot(x - 0.3, y + 0.3) > 0.2 and not (0.55 < x < 0.85
                                                                  and 0.05 < y < 0.35)])
    values = vf11.value(np.concatenate([grid, np.repeat(defender, len(grid), 0)], axis=1))
    margin = policy.margin(vf11)
    clear, band, lost = (grid[np.flatnonzero(mask)[0]] for mask in (
        values > 2 * margin, (values > 0.2 * margin) & (values < 0.8 * margin),
        values < -margin))

    def decide(attacker: np.ndarray) -> tuple[int, int]:
        env.reset(seed=0, options={"attackers": attacker[None], "defenders": defender})
        policy.act(env.unwrapped.game_state())
        return policy.guaranteed_captures, policy.nominal_captures

    policy.reset(env.unwrapped.scenario)
    assert decide(band) == (0, 1)
    assert decide(clear) == (1, 1)
    assert decide(band) == (1, 1)
    assert decide(lost) == (0, 0)
    assert decide(band) == (0, 1)


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


def test_strategy_takes_its_enums_or_their_names(coarse_tubes):
    vf11, vf21 = coarse_tubes
    assert Strategy("matching", 0.5, "pursue") == Strategy(Program.MATCHING, 0.5, Spare.PURSUE)
    assert HJDefenderPolicy(vf11, vf21, idle="stand").idle is Spare.STAND == "stand"
    assert MatchingDefenderPolicy(vf11, unmatched=Spare.PURSUE).strategy.spare is Spare.PURSUE
    with pytest.raises(ValueError, match="strategy.spare"):
        Strategy(spare="wander")
    with pytest.raises(ValueError, match="unmatched"):   # a spare the matching does not play
        MatchingDefenderPolicy(vf11, unmatched="intercept")


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
                promised += result.nominal_captures[0]
                assert result.arrivals_beyond_promise == 0, (m, n, seed)
                assert result.guarantees[0] <= result.nominal_captures[0]
                assert result.captured_count + result.arrived_count <= m
    record_property("guarantee_violation_episodes", f"{violations}/{episodes}")
    print(f"guarantee violated in {violations} of {episodes} episodes at 25^4 / 13^6")
    assert promised >= episodes, "the MIP promised almost nothing: the test would be vacuous"
    assert violations <= 1


def test_certified_game_takes_the_plan_only_as_far_as_its_value_allows(coarse_tubes):
    """A certified 1 vs 1 game's defender takes the proposed heading where the value
    clears the margin by more than a step's change or holds it one step on against every
    sampled attacker move, else a heading that keeps the value from falling to first
    order (or the optimal control where none does)."""
    vf11, vf21 = coarse_tubes
    scenario = reachavoid_env.builtin_scenario("paper_2v1").with_players(4, 2)
    env = reachavoid_env.parallel_env(scenario=scenario)
    policy = HJDefenderPolicy(vf11, vf21, margin_cells=0.1)  # a thin margin: both branches
    branches = set()
    for seed in range(40):
        env.reset(seed=seed)
        policy.reset(env.unwrapped.scenario)
        state = env.unwrapped.game_state()
        actions = np.array(list(policy.act(state).values()))
        games = [g for g in policy.certified_games if len(g.defenders) == len(g.attackers) == 1]
        if not games:
            continue
        i = np.array([g.attackers[0] for g in games])
        j = np.array([g.defenders[0] for g in games])
        away = np.zeros_like(state.defender_positions)
        gap = state.defender_positions[j] - state.attacker_positions[i]
        away[j] = gap / np.linalg.norm(gap, axis=1)[:, None]     # the worst proposal
        optimal = actions.copy()
        roles = roles_of(policy.last_assignment)                 # the games' optimal controls
        tables = policy.copies[0].decision.tables
        one_game_controls(state.attacker_positions, state.defender_positions, roles.singles,
                          roles.doubles, match_arrays(()), no_team_values(0), policy.margins,
                          tables.values11, tables.values21.copy(), *policy._tubes, optimal)
        steered = optimal.copy()
        margin = policy.tubes.margins.m11
        speeds = (state.attacker_speed, state.defender_speed)
        attackers, defenders = state.attacker_positions[i], state.defender_positions[j]
        turned, heading = steer(vf11, attackers, defenders, away[j], margin, speeds,
                                scenario.dt)
        steered[j[turned]] = heading[turned]
        value, gradient = vf11.value_and_gradient(
            pair_states(state.attacker_positions, state.defender_positions)[i, j])
        step = (state.attacker_speed + state.defender_speed) * scenario.dt
        for k in range(len(games)):
            u = steered[j[k]]
            held = held_one_step(vf11, attackers[k:k + 1], defenders[k:k + 1],
                                 away[j[k]][None], margin, speeds, scenario.dt)[0]
            if value[k] - margin > step or held:
                branches.add("clear")
                np.testing.assert_allclose(u, away[j[k]], atol=1e-6)
            else:
                grad_a, grad_d = gradient[k, :2], gradient[k, 2:]
                change = (state.defender_speed * grad_d @ u
                          - state.attacker_speed * np.linalg.norm(grad_a))
                branches.add("cone" if change >= -1e-6 else "optimal")
                assert change >= -1e-6 or np.allclose(u, optimal[j[k]], atol=1e-6)
    assert "clear" in branches and branches - {"clear"}


def test_one_step_check_takes_the_worst_attacker_move(coarse_tubes):
    """``held_one_step`` is the smallest value over the attacker's sampled moves, one
    step on, against the game's margin."""

    vf11, vf21 = coarse_tubes
    scenario = reachavoid_env.builtin_scenario("paper_2v1").with_players(3, 2)
    env = reachavoid_env.parallel_env(scenario=scenario)
    policy = HJDefenderPolicy(vf11, vf21)
    env.reset(seed=3)
    policy.reset(env.unwrapped.scenario)
    state = env.unwrapped.game_state()
    i, j = np.array([0, 1, 2, 0]), np.array([0, 0, 1, 1])
    headings = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.6, 0.8]])
    held = held_one_step(vf11, state.attacker_positions[i], state.defender_positions[j],
                         headings, policy.tubes.margins.m11,
                         (state.attacker_speed, state.defender_speed), scenario.dt)
    for k in range(len(i)):
        attackers = state.attacker_positions[i[k]] + ATTACKER_MOVES * (
            state.attacker_speed * scenario.dt)
        defender = state.defender_positions[j[k]] + headings[k] * (
            state.defender_speed * scenario.dt)
        worst = min(vf11.value(np.concatenate([a, defender])) for a in attackers)
        assert held[k] == (worst > policy.tubes.margins.m11)


def test_hj_pairs_attackers_that_lose_alone_play_the_pair_game(coarse_tubes):
    """At the paper's start both attackers lose their 1 vs 1 game against the one defender:
    each takes its own heading of the 2 vs 1 game, not the shortest path."""
    vf11, vf21 = coarse_tubes
    env = reachavoid_env.parallel_env(scenario="paper_2v1")
    env.reset(seed=0)
    state = env.unwrapped.game_state()
    (a0, a1), (d,) = state.attacker_positions, state.defender_positions
    assert np.all(vf11.value(np.array([[*a0, *d], [*a1, *d]])) > 0)
    attacker = HJPairsAttacker(vf11, vf21)
    attacker.reset(env.unwrapped.scenario)
    actions = attacker.act(state)
    expected = vf21.attacker_control(np.array([[*a0, *a1, *d], [*a1, *a0, *d]]), 0)
    np.testing.assert_allclose(actions["attacker_0"], expected[0], atol=1e-6)
    np.testing.assert_allclose(actions["attacker_1"], expected[1], atol=1e-6)
    path = ShortestPathAttacker()
    path.reset(env.unwrapped.scenario)
    assert not np.allclose(actions["attacker_0"], path.act(state)["attacker_0"], atol=1e-2)


def test_hj_pairs_attacker_that_wins_alone_runs_the_shortest_path(coarse_tubes):
    """An attacker that wins its 1 vs 1 game runs the shortest path, and its partner,
    left the only one that loses alone, has no pair to play: it runs the path too."""
    vf11, vf21 = coarse_tubes
    env = reachavoid_env.parallel_env(scenario="paper_2v1")
    env.reset(seed=0)
    state = dataclasses.replace(env.unwrapped.game_state(),
                                attacker_positions=np.array([[0.55, 0.35], [0.0, 0.8]]))
    a0, a1, d = *state.attacker_positions, state.defender_positions[0]
    wins_alone = vf11.value(np.array([[*a0, *d], [*a1, *d]])) <= 0
    assert wins_alone.tolist() == [True, False]
    attacker, path = HJPairsAttacker(vf11, vf21), ShortestPathAttacker()
    for policy in (attacker, path):
        policy.reset(env.unwrapped.scenario)
    actions, expected = attacker.act(state), path.act(state)
    for name in ("attacker_0", "attacker_1"):
        np.testing.assert_array_equal(actions[name], expected[name])
    with pytest.raises(ValueError, match="vf21: expected a 2v1 value function"):
        HJPairsAttacker(vf11, vf11)

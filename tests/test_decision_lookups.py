"""The defenders' batched lookups (``policies.lookups``) against the step-by-step
computation they replace (``policies.lookups_reference``): equal bit for bit, table by
table and action by action, over played 8v4 episodes."""

from __future__ import annotations

import lookups_reference as reference
import numpy as np
import pytest

import reachavoid_env
from policies import HJDefenderPolicy, RandomAttacker, ShortestPathAttacker, lookups
from policies import batch_defenders as engine_module
from policies.certificate import match_arrays, no_team_values
from policies.tube_states import pair_states


def step_by_step_defenders(vf11, vf21, margin):
    """``HJDefenderPolicy`` whose engine makes its tables step by step (its headings:
    ``step_by_step``)."""
    policy = HJDefenderPolicy(vf11, vf21, margin_cells=margin)
    policy.batch = reference.StepByStepDefenders(vf11, vf21, None, policy.strategy)
    return policy


def open_space_tables(policy, state, certified):
    """Open-space ``wins`` asked at every pair whose 1 vs 1 value is up to the margin
    (the policy asks a subset: where the program's tables and the new 1 vs 1 games read
    them; both lookups take the same table) and the ``held`` of the certified games with
    them (none where the policy has no open-space certificate)."""
    shape = len(state.attacker_positions), len(state.defender_positions)
    if policy._open is None:
        return np.zeros(shape, dtype=bool), np.zeros(len(certified), dtype=bool)
    values = policy.vf11.value(pair_states(state.attacker_positions,
                                           state.defender_positions))
    one = (state.attacker_positions[None], state.defender_positions[None])
    asked = (values <= policy.tubes.margins.m11) & state.active_attackers[:, None]
    wins = policy._open.wins(*one, asked[None])[0]
    return wins, policy._open.held([certified], *one, state.active_attackers[None],
                                   wins[None])[0]


def step_by_step(monkeypatch, vf11, vf21):
    """Route the policies' controls and slacks through the reference
    (``decision_controls``, copy by copy)."""
    monkeypatch.setattr(engine_module, "batch_decision_controls",
                        reference.step_by_step_controls(vf11, vf21))


def play(seed: int, attackers, decide) -> None:
    """A seeded 8v4 episode (600 steps at most), the defenders' actions from
    ``decide(scenario, step, state)``."""
    scenario = reachavoid_env.builtin_scenario("paper_2v1").with_players(8, 4)
    env = reachavoid_env.parallel_env(scenario=scenario, max_cycles=600)
    env.reset(seed=seed)
    attackers.reset(env.unwrapped.scenario)
    step = 0
    while env.agents:
        state = env.unwrapped.game_state()
        actions = {**attackers.act(state), **decide(env.unwrapped.scenario, step, state)}
        env.step({a: actions[a] for a in env.agents})
        step += 1


@pytest.mark.parametrize("seed, attackers, margin", [
    (3, ShortestPathAttacker(), 1.0), (4, RandomAttacker(seed=4), 1.0),
    (5, ShortestPathAttacker(), 0.0)])
def test_tables_and_headings_match_step_by_step(coarse_tubes, seed, attackers, margin):
    """Before every decision of the episode: ``decision_tables`` with the policy's
    certified games equals the reference; the headings of every defender against every
    attacker alone and against every pair, and the slacks of all these games, equal the
    reference's."""
    vf11, vf21 = coarse_tubes
    policy = HJDefenderPolicy(vf11, vf21, margin_cells=margin)
    tubes = lookups.TubeArrays.of(vf11), lookups.TubeArrays.of(vf21)
    kept_steps = opened = 0

    def decide(scenario, step, state):
        nonlocal kept_steps, opened
        if step == 0:
            policy.reset(scenario)
        certified = policy.certified_games if margin > 0 else []
        wins, held = open_space_tables(policy, state, certified)
        games = match_arrays(tuple(certified))
        ours = reference.one_game_tables(
            state.attacker_positions, state.defender_positions, state.active_attackers,
            games, no_team_values(len(certified)), held, wins, *policy._tubes)
        expected = reference.decision_tables(state, certified, policy.tubes, wins, held)
        reference.assert_same_tables(ours, expected)
        opened += bool(wins.any())
        kept_steps += bool(ours.kept.any())
        m, n = len(state.attacker_positions), len(state.defender_positions)
        every = np.arange(n)
        none1, none2 = np.empty((0, 2), np.int64), np.empty((0, 3), np.int64)
        groups = [(np.stack([np.full(n, i), every], axis=1), none2) for i in range(m)] + [
            (none1, np.stack([np.full(n, i), np.full(n, k), every], axis=1))
            for i in range(m) for k in range(i + 1, m)]
        one_each = [(j, j, i, i) for singles, _ in groups[:m] for i, j in singles]
        two_each = [(j, j, i, k) for _, doubles in groups[m:] for i, k, j in doubles]
        rows = np.array(one_each + two_each + [(0, 1, 0, 0)])     # and a team
        games = lookups.Matches(rows[:, :2], rows[:, 2:])
        team_values = np.where(rows[:, 0] != rows[:, 1], 0.25, np.nan)
        margins = np.array(policy.tubes.margins)
        for g, (singles, doubles) in enumerate(groups):    # each defender once per call
            mine, expected = (np.zeros((n, 2), np.float32) for _ in range(2))
            table, expected_table = ours.values21.copy(), ours.values21.copy()
            asked = games if g == 0 else lookups.Matches(*(part[:0] for part in games))
            slack = reference.one_game_controls(
                state.attacker_positions, state.defender_positions, singles, doubles, asked,
                team_values, margins, ours.values11, table, *tubes, mine)
            expected_slack = reference.decision_controls(
                state.attacker_positions, state.defender_positions, singles, doubles, asked,
                team_values, margins, ours.values11, expected_table, vf11, vf21, expected)
            assert np.array_equal(mine, expected), (step, singles, doubles)
            assert np.array_equal(slack, expected_slack, equal_nan=True), step
            assert np.array_equal(table, expected_table, equal_nan=True), step
        return policy.act(state)

    play(seed, attackers, decide)
    assert margin == 0 or kept_steps > 0, "no certified game was ever checked"
    assert margin == 0 or opened > 0, "no open-space win was ever read"


@pytest.mark.parametrize("seed, attackers, margin", [
    (7, ShortestPathAttacker(), 1.0), (8, RandomAttacker(seed=8), 1.0),
    (9, ShortestPathAttacker(), 0.0)])
def test_actions_match_step_by_step(coarse_tubes, monkeypatch, seed, attackers, margin):
    """Played side by side on the same states, the batched policy and the step-by-step
    one give bit-identical actions, assignments, certified games, capture counts and
    solver counts."""
    vf11, vf21 = coarse_tubes
    fast = HJDefenderPolicy(vf11, vf21, margin_cells=margin)
    slow = step_by_step_defenders(vf11, vf21, margin)
    batched = engine_module.batch_decision_controls

    def decide(scenario, step, state):
        if step == 0:
            fast.reset(scenario)
            slow.reset(scenario)
        ours = fast.act(state)
        with monkeypatch.context() as patch:
            step_by_step(patch, vf11, vf21)
            assert engine_module.batch_decision_controls is not batched
            theirs = slow.act(state)
        assert ours.keys() == theirs.keys()
        for name in ours:
            assert ours[name].dtype == theirs[name].dtype == np.float32
            assert np.array_equal(ours[name], theirs[name]), (step, name)
        assert fast.last_assignment == slow.last_assignment
        assert fast.certified_games == slow.certified_games
        assert (fast.guaranteed_captures, fast.nominal_captures) == (
            slow.guaranteed_captures, slow.nominal_captures)
        return ours

    play(seed, attackers, decide)
    counts = [(p.solver.solves, p.solver.reuses, p.solver.kept) for p in (fast, slow)]
    assert counts[0] == counts[1]

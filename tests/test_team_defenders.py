"""Defender teams (``hj-pairs``): the 1 vs 2 tube in the assignment, on the equal-speed map."""

from __future__ import annotations

import json

import lookups_reference as reference
import numpy as np
import pytest

import reachavoid_env
from policies import (
    HJAttacker,
    HJDefenderPolicy,
    HJPairsDefenderPolicy,
    ShortestPathAttacker,
)
from policies.certificate import match_arrays
from policies.registry import make_policy, resolve
from policies.tube_states import team_values
from reachavoid.cli import main
from reachavoid.rollout import run_episode
from reachavoid_env.overlay import EdgeKind
from solvers.hj import solve_1v1, solve_1v2, solve_2v1

SCENARIO = "paper_6v4_equal"


@pytest.fixture(scope="module")
def equal_tubes():
    """1 vs 1 (25^4), 2 vs 1 and 1 vs 2 (13^6) at equal speeds, solved without the cache."""
    sc = reachavoid_env.builtin_scenario(SCENARIO)
    vf11 = solve_1v1(sc.map, (sc.attacker_speed, sc.defender_speed), sc.capture_radius, 25,
                     cache=False, progress=False)
    vf21 = solve_2v1(sc.map, vf11, 13, cache=False, progress=False)
    vf12 = solve_1v2(sc.map, vf11, 13, cache=False, progress=False)
    return vf11, vf21, vf12


TEAM_START = (np.array([0.32, 0.19]), np.array([[0.93, 0.01], [0.38, 0.5]]))
"""Attacker, defenders: the attacker left of the target, one defender right of it and one
above the attacker (found by the dominance check below over random starts right of the
obstacles, then confirmed with the tubes and by play)."""


def _dominance_margins(attacker, defenders, game_map) -> tuple[np.ndarray, float]:
    """Equal speeds, open ground: the attacker reaches a point uncaptured when it is closer
    to it than every defender is to its capture disc. Per defender alone: the largest
    lead the attacker has at a target point (> 0: it loses alone); for the pair: the
    same lead against the nearer defender (< 0: the pair covers the target)."""
    (x0, y0), (x1, y1) = game_map.target[0].min, game_map.target[0].max
    gx, gy = np.meshgrid(np.linspace(x0, x1, 41), np.linspace(y0, y1, 41))
    points = np.stack([gx.ravel(), gy.ravel()], axis=1)
    attacker_time = np.linalg.norm(points - attacker, axis=1)
    defender_time = np.linalg.norm(points[None] - defenders[:, None], axis=-1) - 0.1
    alone = (defender_time - attacker_time).max(axis=1)
    return alone, float((defender_time.min(axis=0) - attacker_time).max())


def test_a_team_stops_an_attacker_neither_defender_stops_alone(equal_tubes):
    vf11, vf21, vf12 = equal_tubes
    a, defenders = TEAM_START
    sc = reachavoid_env.builtin_scenario(SCENARIO).with_starts(a[None], defenders)
    alone, together = _dominance_margins(a, defenders, sc.map)
    assert np.all(alone > 0) and together < 0
    assert np.all(vf11.value(np.concatenate([np.broadcast_to(a, (2, 2)), defenders], 1)) <= 0)
    assert vf12.value(np.concatenate([defenders.reshape(-1), a])[None])[0] > 0.02
    env = reachavoid_env.parallel_env(scenario=sc)
    env.reset(seed=0)
    state = env.unwrapped.game_state()
    paper = HJDefenderPolicy(vf11, vf21)
    paper.reset(sc)
    paper.act(state)
    assert paper.nominal_captures == 0 and paper.guaranteed_captures == 0
    certified = HJPairsDefenderPolicy(vf11, vf21, vf12)
    certified.reset(sc)
    certified.act(state)
    assert certified.nominal_captures == 1
    assert certified.last_assignment.shared == ((0, 0, 1),)
    clears = vf12.value(np.concatenate([defenders.reshape(-1), a])) > certified.margin(vf12)
    assert certified.guaranteed_captures == int(clears)
    teams = HJPairsDefenderPolicy(vf11, vf21, vf12, margin_cells=0.0)
    teams.reset(sc)
    actions = teams.act(state)
    assert teams.last_assignment.shared == ((0, 0, 1),)
    assert teams.nominal_captures == 1 == teams.guaranteed_captures
    for name in ("defender_0", "defender_1"):
        assert np.isclose(np.linalg.norm(actions[name]), 1.0, atol=1e-5)
    overlay = teams.overlay()
    assert set(overlay.edges) == {("defender_0", "attacker_0"), ("defender_1", "attacker_0")}
    assert overlay.kinds == (EdgeKind.TEAM, EdgeKind.TEAM)  # a 1 vs 2 game
    assert overlay.lines == ("guaranteed: 1 of 1, program's count: 1",)
    for attacker in (ShortestPathAttacker(), HJAttacker(vf11)):
        result = run_episode(env, attacker, HJPairsDefenderPolicy(vf11, vf21, vf12,
                                                                  margin_cells=0.0), seed=0)
        assert result.arrived_count == 0, type(attacker).__name__


def test_pairs_play_the_equal_speed_scenario(equal_tubes):
    vf11, vf21, vf12 = equal_tubes
    env = reachavoid_env.parallel_env(scenario=SCENARIO)
    teams = HJPairsDefenderPolicy(vf11, vf21, vf12)
    result = run_episode(env, ShortestPathAttacker(), teams, seed=0)
    assert result.captured_count + result.arrived_count <= 6
    assert teams.solver.solves >= 1
    paper = run_episode(env, ShortestPathAttacker(), HJDefenderPolicy(vf11, vf21), seed=0)
    assert result.guarantees[0] >= paper.guarantees[0]


def test_tubes_of_another_game_are_refused(equal_tubes):
    vf11, vf21, vf12 = equal_tubes
    with pytest.raises(ValueError, match="vf12"):
        HJPairsDefenderPolicy(vf11, vf21, vf21)
    with pytest.raises(ValueError, match="margin_cells"):
        HJPairsDefenderPolicy(vf11, vf21, vf12, margin_cells=-1.0)
    teams = HJPairsDefenderPolicy(vf11, vf21, vf12)
    with pytest.raises(ValueError, match="vf11"):
        teams.reset(reachavoid_env.builtin_scenario("paper_2v1"))  # defenders 1.5x faster


def test_registry_and_cli_offer_hj_pairs(capsys):
    assert resolve("defenders", "hj-pairs").build == HJPairsDefenderPolicy.for_scenario
    sc = reachavoid_env.builtin_scenario(SCENARIO)
    with pytest.raises(ValueError, match="unknown option"):
        make_policy("defenders", "hj-pairs", sc, grid3=5)
    assert main(["play", "--json", "--scenario", SCENARIO, "--defenders", "hj-pairs",
                 "--grid1", "9", "--grid2", "8"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["defenders"] == "hj-pairs" and report["captured_count"] >= 0


def test_solve_command_solves_the_1v2_game(tmp_path, capsys):
    plot = tmp_path / "team.png"
    assert main(["solve", "--scenario", SCENARIO, "--game", "1v2", "--grid", "8",
                 "--plot", str(plot)]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith("1v2 value 8x8x8x8x8x8") and plot.stat().st_size > 0
    assert main(["solve", "--scenario", "paper_2v1", "--game", "1v2", "--grid", "8",
                 "--plot", str(tmp_path / "x.png")]) == 2
    assert "2 defender" in capsys.readouterr().err


@pytest.mark.parametrize("attackers", [ShortestPathAttacker(), None])
def test_certified_teams_match_the_step_by_step_tables(equal_tubes, attackers):
    """Before every decision of the team start's episode (a margin of 0.1 cell, so the
    team is certified), ``decision_tables`` with the policy's certified games equals the
    step-by-step twin (whose team values come from ``vf12.value`` and the rule written
    out in ``lookups_reference``), and every certified team's slack, read with the tubes'
    margins, is the twin's. Against shortest-path and HJ attackers (``None``)."""
    vf11, vf21, vf12 = equal_tubes
    policy = HJPairsDefenderPolicy(vf11, vf21, vf12, margin_cells=0.1)
    a, defenders = TEAM_START
    env = reachavoid_env.parallel_env(scenario=reachavoid_env.builtin_scenario(
        SCENARIO).with_starts(a[None], defenders))
    env.reset(seed=0)
    attackers = attackers or HJAttacker(vf11)
    attackers.reset(env.unwrapped.scenario)
    policy.reset(env.unwrapped.scenario)
    team_steps = 0
    while env.agents:
        state = env.unwrapped.game_state()
        certified = policy.certified_games
        none = np.zeros((len(state.attacker_positions), len(state.defender_positions)), bool)
        games = match_arrays(tuple(certified))
        ours = reference.one_game_tables(
            state.attacker_positions, state.defender_positions, state.active_attackers,
            games, team_values(policy.vf12, state, games), np.zeros(len(certified), bool),
            none, *policy._tubes)
        expected = reference.decision_tables(state, certified, policy.tubes, none)
        reference.assert_same_tables(ours, expected)
        teams = [game for game in certified if len(game.defenders) == 2]
        if teams:
            team_steps += 1
            games = match_arrays(tuple(teams))
            slack = reference.one_game_controls(
                state.attacker_positions, state.defender_positions, np.empty((0, 2), np.int64),
                np.empty((0, 3), np.int64), games, team_values(policy.vf12, state, games),
                policy.margins, ours.values11, ours.values21.copy(),
                *policy._tubes, np.zeros((len(state.defender_positions), 2), np.float32))
            assert np.array_equal(slack, reference.slack(policy.tubes, teams, state,
                                                         ours.values11))
        actions = {**attackers.act(state), **policy.act(state)}
        env.step({a: actions[a] for a in env.agents})
    assert team_steps > 0, "no certified team was ever checked"

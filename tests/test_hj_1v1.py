"""The 1 vs 1 reach-avoid solve: theory on an open map, invariants, controls."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from reachavoid_env import Circle, GameMap, builtin_map
from solvers.hj import SolverSettings, solve_1v1
from solvers.open_space import disc_target_margins

VA, VD, R = 1.0, 1.5, 0.1


@pytest.fixture(scope="module")
def open_map_solve():
    """Disc target of radius 0.3 in the middle of a big obstacle-free domain."""
    game_map = GameMap((-2.0, 2.0, -2.0, 2.0), (Circle((0.0, 0.0), 0.3),))
    return game_map, solve_1v1(game_map, (VA, VD), R, 41, cache=False, progress=False)


def test_open_map_agrees_with_straight_line_and_apollonius_bounds(open_map_solve):
    """(a) The attacker reaches a target point along a straight line before the defender can
    come within the capture radius of any point of that segment: attacker wins.
    (b) The Apollonius disc (capture radius 0) misses the target: defender wins.
    States at least two grid cells (through Lipschitz bounds of both margins) from either
    condition's boundary; >= 99% agreement on each side."""
    _, vf = open_map_solve
    h = vf.grid.spacing[0]
    radius = 0.3
    rng = np.random.default_rng(0)
    count = 20000
    a = rng.uniform(-1.4, 1.4, (count, 2))
    d = rng.uniform(-1.4, 1.4, (count, 2))
    slack, miss = disc_target_margins(a, d, radius, (VA, VD), R)
    k = VA / VD
    # moving each player by 2h changes the time slack by <= 2h (1/vA + 1/vD) and the
    # disc's clearance by <= 2h (1 + k) / (1 - k)
    attacker_sure = slack > 2 * h * (1 / VA + 1 / VD)
    defender_sure = miss > 2 * h * (1 + k) / (1 - k)
    assert attacker_sure.sum() > 2000 and defender_sure.sum() > 200
    value = vf.value(np.concatenate([a, d], axis=1))
    assert np.mean(value[attacker_sure] <= 0) >= 0.99
    assert np.mean(value[defender_sure] > 0) >= 0.99


@pytest.fixture(scope="module")
def paper_solves(vf11):
    game_map = builtin_map("paper")
    solve = dict(grid_points=25, cache=False, progress=False)
    return {
        "base": vf11,   # the session's 25^4 tube: the paper's speeds and radius, (VA, VD), R
        "bigger_radius": solve_1v1(game_map, (VA, VD), 0.15, **solve),
        "faster_defender": solve_1v1(game_map, (VA, 1.7), R, **solve),
    }


def test_solve_converges_and_reports(paper_solves):
    solver = paper_solves["base"].solver
    settings = SolverSettings()
    assert solver["converged"] and solver["residual"] < settings.tolerance
    assert 0 < solver["iterations"] < settings.max_iterations
    assert solver["scheme"] == settings.scheme.name and solver["tolerance"] == settings.tolerance


def _node_states(vf):
    return vf.grid.mesh().reshape(-1, 4)


def test_target_states_win_and_captured_states_lose(paper_solves):
    vf = paper_solves["base"]
    states = _node_states(vf)
    a, d = states[:, :2], states[:, 2:]
    gap = np.linalg.norm(a - d, axis=1)
    value = vf.value(states)
    game_map = vf.game_map
    in_target = game_map.in_target(a) & (gap > R) & ~game_map.in_obstacle(d)
    captured = gap <= R
    assert in_target.sum() > 100 and captured.sum() > 100
    assert np.all(value[in_target] <= 0)
    assert np.all(value[captured] > 0)
    # strictly inside: a player touching an obstacle's boundary slides along it, not lost
    attacker_in_obstacle = game_map.obstacle_signed_distance(a) < 0
    assert attacker_in_obstacle.sum() > 100
    assert np.all(value[attacker_in_obstacle] > 0)


@pytest.mark.parametrize("stronger", ["bigger_radius", "faster_defender"])
def test_stronger_defender_never_grows_attacker_winning_set(paper_solves, stronger):
    base, other = paper_solves["base"].values, paper_solves[stronger].values
    assert np.sum(other <= 0) < np.sum(base <= 0)
    assert not np.any((other <= 0) & (base > 0))


def test_finer_grid_agrees_with_coarser_away_from_boundary(vf11):
    game_map = builtin_map("paper")
    coarse = vf11
    fine = solve_1v1(game_map, grid_points=37, cache=False, progress=False)
    rng = np.random.default_rng(1)
    points = rng.uniform(-1, 1, (40000, 2))
    points = points[~game_map.in_obstacle(points)]
    states = np.concatenate([points[:15000], points[-15000:]], axis=1)
    fine_value = fine.value(states)
    away = np.abs(fine_value) > 0.03
    assert away.mean() > 0.5
    agree = (coarse.value(states[away]) <= 0) == (fine_value[away] <= 0)
    assert agree.mean() >= 0.99


def test_paper_example_each_attacker_alone_loses(paper_solves):
    """Fig. 2 top left: the defender at (0.3, -0.3) beats either attacker alone."""
    states = np.array([[-0.5, 0.0, 0.3, -0.3], [0.0, 0.8, 0.3, -0.3]])
    assert np.all(paper_solves["base"].value(states) > 0)


def test_controls_are_unit_headings(open_map_solve):
    _, vf = open_map_solve
    # defender far behind: the attacker runs straight at the target (the origin)
    states = np.array([[1.0, 0.0, 1.9, 1.9], [0.0, -1.2, -1.9, 1.9], [-0.8, 0.8, 1.5, -1.9]])
    heading = vf.attacker_control(states)
    np.testing.assert_allclose(np.linalg.norm(heading, axis=1), 1.0, atol=1e-9)
    towards_target = -states[:, :2] / np.linalg.norm(states[:, :2], axis=1, keepdims=True)
    assert np.all(np.sum(heading * towards_target, axis=1) > 0.9)
    # defender between attacker and target, attacker far: the defender closes in
    guard = np.array([[1.2, 0.0, 0.5, 0.0], [0.0, 1.3, 0.0, 0.6]])
    assert np.all(vf.value(guard) > 0)
    d_heading = vf.defender_control(guard)
    np.testing.assert_allclose(np.linalg.norm(d_heading, axis=1), 1.0, atol=1e-9)
    to_attacker = guard[:, :2] - guard[:, 2:]
    to_attacker /= np.linalg.norm(to_attacker, axis=1, keepdims=True)
    assert np.all(np.sum(d_heading * to_attacker, axis=1) > 0.5)


def test_controls_vanish_where_gradient_vanishes():
    game_map = GameMap((-1.0, 1.0, -1.0, 1.0), (Circle((0.0, 0.0), 0.3),))
    vf = solve_1v1(game_map, grid_points=9, settings=SolverSettings.with_accuracy("low"),
                   cache=False, progress=False)
    flat = dataclasses.replace(vf, values=np.full(vf.grid.shape, 0.5, np.float32))
    state = np.array([[0.5, 0.5, -0.5, -0.5]])
    assert np.all(flat.attacker_control(state) == 0) and np.all(flat.defender_control(state) == 0)
    with pytest.raises(ValueError, match="attacker"):
        vf.attacker_control(state, attacker=1)
    with pytest.raises(ValueError, match="states"):
        vf.value(np.zeros((3, 6)))


def test_red_black_and_jacobi_reach_the_same_fixed_point():
    game_map = builtin_map("paper")
    high = SolverSettings.with_accuracy("high")
    red_black = solve_1v1(game_map, grid_points=21, settings=high, cache=False, progress=False)
    jacobi = solve_1v1(game_map, grid_points=21, settings=high.replace(iteration="jacobi"),
                       cache=False, progress=False)
    assert red_black.solver["iteration"] == "red_black"
    assert np.abs(red_black.values - jacobi.values).max() < 2e-3
    clear = np.abs(jacobi.values) > 2e-3
    assert np.array_equal(red_black.values[clear] <= 0, jacobi.values[clear] <= 0)

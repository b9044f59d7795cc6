"""The clipped start (``solvers.hj.start``): its sets, its kernels, and the same fixed point."""

from __future__ import annotations

import numpy as np
import pytest

from reachavoid_env import Box, GameMap, builtin_map
from reachavoid_env.scenario import builtin_names
from solvers.hj import SolverSettings, game_1v1, solve_1v1, solve_1v2, solve_2v1
from solvers.hj import start as start_module
from solvers.hj.grid import Grid
from solvers.hj.layout import layout_of
from solvers.hj.marcher import Marcher, map_problem
from solvers.hj.start import StartBound, clip_where, largest_where, node_sets, reachable_nodes

HIGH = SolverSettings.with_accuracy("high")
MAPS = sorted({name.split("_")[0] for name in builtin_names()})
POCKET = GameMap((-1.0, 1.0, -1.0, 1.0), (Box((0.5, 0.5), (0.8, 0.8)),),
                 (Box((-0.8, -0.8), (-0.2, -0.7)), Box((-0.8, -0.3), (-0.2, -0.2)),
                  Box((-0.8, -0.7), (-0.7, -0.3)), Box((-0.3, -0.7), (-0.2, -0.3))))
"""A walled-in pocket around (-0.5, -0.5): its nodes cannot reach the target."""


def _flood_reference(free: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Breadth-first search from the free target nodes through free 4-neighbours."""
    passable = free >= 0
    seen = passable & (target <= 0)
    queue = list(zip(*np.nonzero(seen), strict=True))
    while queue:
        i, j = queue.pop()
        for a, b in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)):
            if 0 <= a < free.shape[0] and 0 <= b < free.shape[1] and passable[a, b] \
                    and not seen[a, b]:
                seen[a, b] = True
                queue.append((a, b))
    return seen


def test_reachable_nodes_leave_out_a_walled_in_pocket():
    grid = Grid((-1.0, -1.0), (1.0, 1.0), (41, 41))
    from solvers.hj import geometry

    free = geometry.free_distance(POCKET, grid)
    target = geometry.target_distance(POCKET, grid)
    reached = reachable_nodes(free, target)
    np.testing.assert_array_equal(reached, _flood_reference(free, target))
    inside = grid.nearest_index(np.array([[-0.5, -0.5]]))[0]
    assert free[tuple(inside)] > 0 and not reached[tuple(inside)]
    assert reached[tuple(grid.nearest_index(np.array([[0.9, -0.9]]))[0])]
    rng = np.random.default_rng(3)
    for _ in range(20):
        free, target = rng.normal(0.3, 1.0, (13, 9)), rng.normal(1.0, 1.0, (13, 9))
        np.testing.assert_array_equal(reachable_nodes(free, target),
                                      _flood_reference(free, target))


def test_masked_kernels_match_numpy():
    rng = np.random.default_rng(0)
    values = rng.normal(size=(37, 23)).astype(np.float32)
    masks = [rng.random(37) < 0.5, rng.random(23) < 0.5, rng.random(37) < 0.2,
             rng.random(23) < 0.2]
    row_in, element_in, row_hit, element_hit = masks
    inside = row_in[:, None] & element_in[None, :]
    hit = inside & (row_hit[:, None] | element_hit[None, :])
    assert largest_where(values, *masks) == values[hit].max()
    nowhere = np.zeros(37, dtype=bool)
    assert largest_where(values, nowhere, element_in, row_hit, element_hit) == -np.inf
    clipped = values.copy()
    clip_where(clipped, row_in, element_in, np.float32(0.25))
    np.testing.assert_array_equal(clipped, np.where(inside, np.minimum(values, 0.25), values))


def test_sets_and_level_of_the_1v1_game():
    """The level is the capture radius; S holds the nodes whose attacker can reach the
    target (the pocket's are out), E those whose attacker is in it."""
    game = game_1v1((1.0, 1.5), 0.1)
    grid = Grid.for_players(POCKET.domain, 2, 21)
    marcher = Marcher.prepare(map_problem(game, POCKET, grid), SolverSettings())
    bound = StartBound.of(marcher, np.empty(marcher.layout.stored_shape, dtype=np.float32))
    assert bound is not None and bound.level == np.float32(0.1)
    sets = node_sets(marcher.problem, marcher.layout)
    attacker = marcher.problem.planar
    reach = reachable_nodes(attacker["free"]["A"], attacker["target"]["A"]).reshape(-1)
    np.testing.assert_array_equal(sets.row_inside, reach[marcher.layout.row_nodes[:, 0]])
    assert sets.element_inside.all() and not sets.element_arrived.any()
    other = Marcher.prepare(marcher.problem, SolverSettings(scheme="lax_friedrichs"))
    assert StartBound.of(other, np.empty(other.layout.stored_shape, dtype=np.float32)) is None


def _solves(game: str, game_map: GameMap, settings: SolverSettings):
    if game == "1v1":
        return solve_1v1(game_map, grid_points=21, settings=settings, cache=False,
                         progress=False)
    vf11 = solve_1v1(game_map, grid_points=21, settings=HIGH, cache=False, progress=False)
    solve = solve_2v1 if game == "2v1" else solve_1v2
    return solve(game_map, vf11, grid_points=9, settings=settings, cache=False,
                 progress=False)


def _assert_same_fixed_point(game: str, game_map: GameMap):
    cold = _solves(game, game_map, HIGH.replace(clip_start=False))
    clipped = _solves(game, game_map, HIGH)
    assert cold.solver["start"] == "cold" and clipped.solver["start"] == "cold, clipped"
    assert cold.solver["converged"] and clipped.solver["converged"]
    assert clipped.solver["iterations"] < cold.solver["iterations"]
    a, b = cold.full_values(), clipped.full_values()
    # the sign at every node, but where both values are float32 noise around zero
    settled = np.maximum(np.abs(a), np.abs(b)) > 1e-6
    np.testing.assert_array_equal((a <= 0)[settled], (b <= 0)[settled])
    assert np.abs(a - b).max() < 1e-3
    # the claim itself, node by node: the cold fixed point lies below the level on S
    game_decl = {"1v1": game_1v1}.get(game)
    if game_decl is not None:
        grid = cold.grid
        marcher = Marcher.prepare(map_problem(game_decl((1.0, 1.5), 0.1), game_map, grid),
                                  SolverSettings(exchange_symmetry=False))
        sets = node_sets(marcher.problem, marcher.layout)
        inside = sets.row_inside[:, None] & sets.element_inside[None, :]
        assert a.reshape(inside.shape)[inside].max() <= 0.1 + 1e-6


@pytest.mark.parametrize("name", MAPS)
@pytest.mark.parametrize("game", ["1v1", "2v1", "1v2"])
def test_clipped_start_reaches_the_cold_fixed_point_on_every_builtin_map(name, game):
    _assert_same_fixed_point(game, builtin_map(name))


def test_clipped_start_with_a_walled_in_pocket():
    _assert_same_fixed_point("1v1", POCKET)


def test_a_start_that_fails_the_check_starts_again_cold(monkeypatch):
    monkeypatch.setattr(start_module.StartBound, "holds", lambda self, values: False)
    game_map = builtin_map("paper")
    cold = solve_1v1(game_map, grid_points=15, settings=SolverSettings(clip_start=False),
                     cache=False, progress=False)
    redone = solve_1v1(game_map, grid_points=15, cache=False, progress=False)
    assert redone.solver["start"].startswith("cold (the clipped start was no supersolution")
    assert redone.solver["iterations"] == cold.solver["iterations"] + 1
    np.testing.assert_array_equal(redone.full_values(), cold.full_values())


def test_layout_with_symmetry_keeps_sets_symmetric():
    """Under exchange symmetry S and E are read per stored row: the same as the full
    grid's sets at each stored row's configuration."""
    from solvers.hj import game_2v1

    game_map = builtin_map("paper")
    game = game_2v1((1.0, 1.5), 0.1)
    grid = Grid.for_players(game_map.domain, 3, 9)
    extra = {"value_1v1": np.zeros((9, 9, 9, 9), dtype=np.float32)}
    problem = map_problem(game, game_map, grid, extra)
    stored = node_sets(problem, layout_of(grid, ((0, 1),)))
    full_layout = layout_of(grid)
    full = node_sets(problem, full_layout)
    assert stored is not None and full is not None and 0 < full.row_inside.mean() < 1
    rows = full_layout.row_nodes[:, 0] * 81 + full_layout.row_nodes[:, 1]
    canonical = layout_of(grid, ((0, 1),)).stored_of[rows]
    np.testing.assert_array_equal(full.row_inside, stored.row_inside[canonical])
    np.testing.assert_array_equal(full.row_arrived, stored.row_arrived[canonical])

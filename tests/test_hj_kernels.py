"""The generated numba iteration and the kernels equal their numpy references on small grids."""

from __future__ import annotations

import kernels_reference as reference
import numpy as np
import pytest

from solvers.hj import SolverSettings, game_1v1, game_2v1
from solvers.hj.game import Game, attacker, defender, distance, maximum, minimum, table
from solvers.hj.grid import Grid
from solvers.hj.layout import layout_of
from solvers.hj.marcher import Marcher, Problem, iteration_orders

SCHEMES = ("godunov", "lax_friedrichs", "eno2")


def game_1v2(speeds=(1.0, 1.5), radius=0.3) -> Game:
    """1 attacker against 2 exchangeable defenders (the paper's future work), declared here
    alone: the attacker wins by reaching the target uncaptured by either defender, or by
    winning the 1 vs 1 against one defender while the other is in an obstacle; it loses
    when captured by either or in an obstacle."""
    a, d1, d2 = attacker("A", speeds[0]), defender("D1", speeds[1]), defender("D2", speeds[1])
    gap1, gap2 = radius - distance(a, d1), radius - distance(a, d2)
    target = minimum(maximum(a.target, gap1, gap2),
                     maximum(d1.free, table("value_1v1", a, d2)),
                     maximum(d2.free, table("value_1v1", a, d1)))
    return Game("1v2", (a, d1, d2), target=target, avoid=maximum(gap1, gap2, -a.free),
                symmetries=(("D1", "D2"),), parameters={"capture_radius": radius})


def random_problem(game: Game, rng, shapes) -> Problem:
    """``game`` on a grid of the given planar shapes with random tables (players of equal
    shape share their plane and tables, as exchangeable players must)."""
    grid = Grid(tuple(-1.0 + 0.1 * (k % 2) for k in range(2 * len(shapes))),
                tuple(1.0 + 0.05 * (k % 2) for k in range(2 * len(shapes))),
                tuple(n for shape in shapes for n in shape))
    names = [p.name for p in game.players]
    by_shape = {s: (rng.normal(0.0, 0.5, s), rng.normal(0.4, 0.5, s)) for s in set(shapes)}
    planar = {"target": {n: by_shape[s][0] for n, s in zip(names, shapes, strict=True)},
              "free": {n: by_shape[s][1] for n, s in zip(names, shapes, strict=True)}}
    extra = {name: rng.normal(0.0, 0.5, shapes[p] + shapes[q])
             for name, (p, q) in game.tables().items()}
    return Problem(game=game, grid=grid, planar=planar, extra=extra)


def _players(game: Game) -> list[tuple[float, bool]]:
    return [(p.speed, p.role == "defender") for p in game.players]


def _kernel_iterate(problem, values, scheme, dt, symmetric=False, iteration="jacobi", chunks=5,
                  order=None):
    """One kernel sweep of full-shape ``values``; returns full-shape results and residual."""
    settings = SolverSettings(scheme=scheme, iteration=iteration, exchange_symmetry=symmetric)
    marcher = Marcher.prepare(problem, settings)
    layout = marcher.layout
    m = layout.row_length
    rows = values.reshape(-1, m)[_first_of_each_stored(layout)].astype(np.float32)
    out = rows if iteration == "red_black" else np.zeros_like(rows)
    order = order or iteration_orders(layout, settings)[0]
    residual = marcher.iterate(rows, out, order, dt, n_chunks=chunks)
    return layout.full(out), residual, marcher


def _first_of_each_stored(layout):
    """For each stored row, the full row it stands for (the canonical one)."""
    first = np.empty(layout.stored_rows, dtype=np.int64)
    first[layout.stored_of[::-1]] = np.arange(layout.stored_of.size)[::-1]
    return first


GAMES = {
    "1v1": (lambda: game_1v1((1.0, 1.5), 0.3), [(5, 4), (6, 7)]),
    "2v1": (lambda: game_2v1((1.0, 1.5), 0.3), [(4, 3), (4, 3), (5, 4)]),
    "1v2": (lambda: game_1v2(), [(4, 3), (4, 5), (4, 5)]),
}


@pytest.mark.parametrize("scheme", SCHEMES)
@pytest.mark.parametrize("name", sorted(GAMES))
def test_sweep_matches_reference(name, scheme):
    make, shapes = GAMES[name]
    game = make()
    rng = np.random.default_rng(len(name) + len(scheme))
    problem = random_problem(game, rng, shapes)
    target, avoid = problem.sets()
    values = rng.normal(0.0, 0.3, problem.grid.shape).astype(np.float32)
    assert np.mean(values > avoid) > 0.1 and np.mean(values < target) > 0.1
    dt = 0.02
    expected, expected_residual = reference.iterate(values, problem.grid.spacing,
                                                    _players(game), dt, scheme, target, avoid)
    got, residual, _ = _kernel_iterate(problem, values, scheme, dt)
    np.testing.assert_allclose(got, expected, rtol=0, atol=3e-6)
    assert residual == pytest.approx(expected_residual, abs=3e-6)


def test_declared_sets_match_the_paper_formulas():
    rng = np.random.default_rng(5)
    for game, shapes in ((game_1v1((1.0, 1.5), 0.3), [(5, 4), (6, 7)]),
                         (game_2v1((1.0, 1.5), 0.3), [(4, 3), (4, 3), (5, 4)])):
        problem = random_problem(game, rng, shapes)
        first, last = game.players[0].name, game.players[-1].name
        points = {p.name: problem.plane(p.name).mesh() for p in game.players}
        survive = problem.extra.get("value_1v1")
        expected = reference.paper_sets(problem.planar["target"][first],
                                        problem.planar["free"][first],
                                        problem.planar["free"][last], points[first],
                                        points[last], 0.3, survive)
        for got, want in zip(problem.sets(), expected, strict=True):
            np.testing.assert_allclose(got, want, atol=1e-12)


@pytest.mark.parametrize("scheme", SCHEMES)
def test_symmetric_storage_equals_full_sweep(scheme):
    rng = np.random.default_rng(3)
    game = game_2v1((1.0, 1.5), 0.3)
    problem = random_problem(game, rng, [(4, 5), (4, 5), (5, 3)])
    values = rng.normal(0.0, 0.3, problem.grid.shape).astype(np.float32)
    values = (values + values.transpose(2, 3, 0, 1, 4, 5)) / 2
    expected, _, _ = _kernel_iterate(problem, values, scheme, 0.02)
    got, _, marcher = _kernel_iterate(problem, values, scheme, 0.02, symmetric=True)
    assert marcher.layout.stored_rows == 20 * 21 // 2
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(got, got.transpose(2, 3, 0, 1, 4, 5))


def test_layout_stores_one_ordering_and_maps_every_row():
    grid = Grid.for_players((-1, 1, -1, 1), 3, (3, 4, 3, 4, 5, 5))
    layout = layout_of(grid, ((0, 1),))
    na = 12
    assert layout.stored_rows == na * (na + 1) // 2 and layout.stored_fraction < 0.55
    a1, a2 = np.divmod(np.arange(na * na), na)
    swapped = a2 * na + a1
    np.testing.assert_array_equal(layout.stored_of, layout.stored_of[swapped])
    assert np.all(layout.row_nodes[:, 0] >= layout.row_nodes[:, 1])
    assert len(set(layout.stored_of.tolist())) == layout.stored_rows
    for width in (1, 2):
        colours = layout.colours(width)
        assert set(colours.tolist()) == set(range(width + 1))


@pytest.mark.parametrize("scheme", ["godunov", "eno2"])
@pytest.mark.parametrize("name", ["1v1", "2v1"])
def test_gauss_seidel_planes_match_reference_and_ignore_threading(name, scheme):
    """In place, colour by colour: each plane sees the planes before it already updated."""
    make, shapes = GAMES[name]
    game = make()
    rng = np.random.default_rng(21)
    problem = random_problem(game, rng, shapes)
    target, avoid = problem.sets()
    values = rng.normal(0.0, 0.3, problem.grid.shape).astype(np.float32)
    settings = SolverSettings(scheme=scheme, exchange_symmetry=False)
    layout = Marcher.prepare(problem, settings).layout
    order = iteration_orders(layout, settings)[0]
    rows, planes, _ = order
    expected = values.astype(np.float64).reshape(layout.stored_rows, -1)
    for p in range(planes.size - 1):
        swept, _ = reference.iterate(expected.reshape(values.shape), problem.grid.spacing,
                                     _players(game), 0.02, scheme, target, avoid)
        mine = rows[planes[p]:planes[p + 1]]
        expected[mine] = swept.reshape(layout.stored_rows, -1)[mine]
    results = [_kernel_iterate(problem, values.copy(), scheme, 0.02, iteration="red_black",
                             chunks=chunks, order=order)[0] for chunks in (1, 4)]
    np.testing.assert_allclose(results[0], expected.reshape(values.shape), rtol=0, atol=3e-6)
    np.testing.assert_array_equal(results[0], results[1])
    jacobi, _, _ = _kernel_iterate(problem, values, scheme, 0.02)
    assert np.abs(jacobi - results[0]).max() > 1e-3


@pytest.mark.parametrize("name", sorted(GAMES))
def test_projection_of_huge_values_is_max_of_target_and_avoid(name):
    make, shapes = GAMES[name]
    problem = random_problem(make(), np.random.default_rng(11), shapes)
    target, avoid = problem.sets()
    marcher = Marcher.prepare(problem, SolverSettings())
    values = np.full(marcher.layout.stored_shape, 1e30, np.float32)
    marcher.project(values)
    np.testing.assert_allclose(marcher.layout.full(values), np.maximum(target, avoid),
                               atol=1e-6)


@pytest.mark.parametrize("count", [200, 5000])  # serial and parallel kernels
@pytest.mark.parametrize("shape", [(5, 4, 6, 3), (3, 4, 3, 5, 4, 3)])
def test_interpolation_matches_reference(shape, count):
    rng = np.random.default_rng(len(shape))
    lo = rng.uniform(-1.0, 0.0, len(shape))
    hi = lo + rng.uniform(0.5, 2.0, len(shape))
    grid = Grid(tuple(lo), tuple(hi), shape)
    values = rng.normal(size=shape).astype(np.float32)
    points = rng.uniform(lo - 0.2, hi + 0.2, (count, len(shape)))
    points[:10] = grid.mesh().reshape(-1, len(shape))[:10]
    spacing = np.asarray(grid.spacing)
    np.testing.assert_allclose(grid.interpolate(values, points),
                               reference.interpolate(values, lo, spacing, points), atol=1e-6)
    np.testing.assert_allclose(grid.interpolate_gradient(values, points),
                               reference.interpolate_gradient(values, lo, spacing, points),
                               atol=1e-5)
    nodes = grid.mesh().reshape(-1, len(shape))
    np.testing.assert_allclose(grid.interpolate(values, nodes), values.reshape(-1), atol=1e-6)
    value, gradient = grid.interpolate_with_gradient(values, points)
    np.testing.assert_array_equal(value, grid.interpolate(values, points))
    np.testing.assert_array_equal(gradient, grid.interpolate_gradient(values, points))


@pytest.mark.parametrize("count", [200, 5000])  # serial and parallel kernels
def test_interpolation_of_stored_rows_equals_the_whole_array(count):
    """Values held as the stored rows of a symmetric layout read as the whole array."""
    grid = Grid.for_players((-1, 1, -1, 1), 3, (3, 4, 3, 4, 5, 6))
    layout = layout_of(grid, ((0, 1),))
    rng = np.random.default_rng(count)
    stored = rng.normal(size=layout.stored_shape).astype(np.float32)
    whole = layout.full(stored)
    points = rng.uniform(-1.2, 1.2, (count, 6))
    np.testing.assert_array_equal(grid.interpolate(stored, points, layout.stored_of),
                                  grid.interpolate(whole, points))
    np.testing.assert_array_equal(grid.interpolate_gradient(stored, points, layout.stored_of),
                                  grid.interpolate_gradient(whole, points))
    value, gradient = grid.interpolate_with_gradient(stored, points, layout.stored_of)
    np.testing.assert_array_equal(value, grid.interpolate(whole, points))
    np.testing.assert_array_equal(gradient, grid.interpolate_gradient(whole, points))


def test_interpolation_is_exact_for_linear_functions():
    grid = Grid((-1.0, 0.0, -1.0, 0.0), (1.0, 2.0, 1.0, 1.0), (7, 5, 6, 4))
    slope = np.array([0.3, -0.2, 0.7, 0.1])
    values = (grid.mesh() @ slope).astype(np.float32)
    points = np.random.default_rng(0).uniform((-1, 0, -1, 0), (1, 2, 1, 1), (100, 4))
    np.testing.assert_allclose(grid.interpolate(values, points), points @ slope, atol=1e-5)
    np.testing.assert_allclose(grid.interpolate_gradient(values, points),
                               np.broadcast_to(slope, (100, 4)), atol=1e-5)


def test_grid_indices_and_coordinates():
    grid = Grid.for_players((-1.0, 1.0, 0.0, 2.0), 2, (5, 3, 9, 5))
    assert grid.spacing == (0.5, 1.0, 0.25, 0.5) and grid.size == 5 * 3 * 9 * 5
    np.testing.assert_allclose(grid.coordinates(2), np.linspace(-1.0, 1.0, 9))
    index = np.array([[0, 0, 0, 0], [4, 2, 8, 4], [1, 2, 3, 4]])
    points = grid.points(index)
    np.testing.assert_allclose(points[1], grid.hi)
    np.testing.assert_array_equal(grid.nearest_index(points + 0.1), index)
    np.testing.assert_array_equal(grid.nearest_index(np.full((1, 4), 9.0)), [[4, 2, 8, 4]])
    assert grid.sub((2, 3)) == Grid((-1.0, 0.0), (1.0, 2.0), (9, 5))
    with pytest.raises(ValueError, match="at least 3 nodes"):
        Grid((0.0,), (1.0,), (2,))
    with pytest.raises(ValueError, match="lo < hi"):
        Grid((0.0, 1.0), (1.0, 1.0), (3, 3))
    with pytest.raises(ValueError, match="grid_points"):
        Grid.for_players((-1, 1, -1, 1), 2, (5, 5))
    with pytest.raises(ValueError, match="C-contiguous float32"):
        grid.interpolate(np.zeros(grid.shape), points)


def test_rows_that_split_an_axis_are_refused():
    grid = Grid((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (3, 4, 5))
    rows = np.zeros((6, 10), dtype=np.float32)  # 10 elements: not whole trailing axes
    with pytest.raises(ValueError, match="trailing axes"):
        grid.interpolate(rows, np.zeros((1, 3)), np.arange(6, dtype=np.int64))

"""The numba kernels equal their numpy references on small random grids."""

from __future__ import annotations

import numpy as np
import pytest

from solvers.hj import kernels
from solvers.hj import kernels_reference as reference
from solvers.hj.grid import Grid

SPEEDS = (1.0, 1.5)
SCHEMES = {"godunov": kernels.GODUNOV, "lax_friedrichs": kernels.LAX_FRIEDRICHS}


class Tables:
    """Random planar tables of a game with attacker grid ``ashape`` and defender ``dshape``."""

    def __init__(self, rng, ashape, dshape, radius=0.3):
        self.ashape, self.dshape, self.radius = ashape, dshape, radius
        self.target = rng.normal(0.0, 0.5, ashape).astype(np.float32)
        self.attacker_free = rng.normal(0.4, 0.5, ashape).astype(np.float32)
        self.defender_free = rng.normal(0.5, 0.5, dshape).astype(np.float32)
        self.attacker_points = rng.uniform(-1, 1, ashape + (2,)).astype(np.float32)
        self.defender_points = rng.uniform(-1, 1, dshape + (2,)).astype(np.float32)
        self.survive = rng.normal(0.0, 0.5, ashape + dshape).astype(np.float32)

    def kernel_sets(self):
        a = self.attacker_points.reshape(-1, 2)
        d = self.defender_points.reshape(-1, 2)
        return (self.target.ravel(), self.attacker_free.ravel(), a[:, 0].copy(),
                a[:, 1].copy(), d[:, 0].copy(), d[:, 1].copy(), self.defender_free.ravel(),
                np.float32(self.radius))

    def kernel_survive(self):
        return self.survive.reshape(int(np.prod(self.ashape)), -1)

    def full_sets(self, n_attackers):
        return reference.game_sets(self.target, self.attacker_free, self.defender_free,
                                   self.attacker_points, self.defender_points, self.radius,
                                   self.survive if n_attackers == 2 else None)


def _kernel_sweep(values, spacing, dt, scheme, n_attackers, tables, rows=None, symmetric=False,
                  planes=None, in_place=False, chunks=5):
    """A Jacobi step (one plane, fresh output) or, ``in_place``, a Gauss-Seidel one."""
    shape = values.shape
    m = shape[-2] * shape[-1]
    v2 = values.reshape(-1, m)
    out = v2 if in_place else np.zeros_like(v2)
    if rows is None:
        rows = np.arange(v2.shape[0], dtype=np.int64)
    if planes is None:
        planes = np.array([0, rows.size], dtype=np.int64)
    inv_h = (1.0 / np.asarray(spacing)).astype(np.float32)
    residual = kernels.sweep(v2, out, rows, planes, False, n_attackers, shape[1], shape[0],
                             shape[-1], inv_h, np.asarray(SPEEDS, np.float32), np.float32(dt),
                             SCHEMES[scheme], symmetric, tables.kernel_sets(),
                             tables.kernel_survive(), chunks)
    return out, float(residual)


@pytest.mark.parametrize("scheme", sorted(SCHEMES))
@pytest.mark.parametrize("n_attackers", [1, 2])
def test_sweep_matches_reference(scheme, n_attackers):
    rng = np.random.default_rng(7 + n_attackers)
    attacker_shape, defender_shape = (5, 4), (6, 7)
    shape = attacker_shape * n_attackers + defender_shape
    spacing = tuple(rng.uniform(0.05, 0.2, len(shape)))
    values = rng.normal(0.0, 0.3, shape).astype(np.float32)
    tables = Tables(rng, attacker_shape, defender_shape)
    target, avoid = tables.full_sets(n_attackers)
    assert np.mean(values > avoid) > 0.2 and np.mean(values < target) > 0.2
    dt = 0.02
    expected, expected_residual = reference.sweep(values, spacing, SPEEDS, dt, scheme, target,
                                                  avoid)
    got, residual = _kernel_sweep(values, spacing, dt, scheme, n_attackers, tables)
    np.testing.assert_allclose(got.reshape(shape), expected, rtol=0, atol=2e-6)
    assert residual == pytest.approx(expected_residual, abs=2e-6)


@pytest.mark.parametrize("scheme", sorted(SCHEMES))
def test_symmetric_half_equals_full_sweep(scheme):
    rng = np.random.default_rng(3)
    attacker_shape, defender_shape = (4, 5), (5, 3)
    shape = attacker_shape * 2 + defender_shape
    values = rng.normal(0.0, 0.3, shape).astype(np.float32)
    values = (values + values.transpose(2, 3, 0, 1, 4, 5)) / 2
    tables = Tables(rng, attacker_shape, defender_shape)
    spacing = (0.1, 0.15) * 3
    expected, _ = _kernel_sweep(values, spacing, 0.02, scheme, 2, tables)
    na = 20
    rows = np.arange(na * na, dtype=np.int64)
    rows = rows[rows // na >= rows % na]
    got, _ = _kernel_sweep(values, spacing, 0.02, scheme, 2, tables, rows=rows, symmetric=True)
    kernels.mirror_rows(got, na)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-6)
    six = got.reshape(shape)
    np.testing.assert_array_equal(six, six.transpose(2, 3, 0, 1, 4, 5))


@pytest.mark.parametrize("n_attackers", [1, 2])
def test_gauss_seidel_planes_match_reference_and_ignore_threading(n_attackers):
    """In place, plane by plane: each plane sees the planes before it already updated."""
    rng = np.random.default_rng(21)
    attacker_shape, defender_shape = (4, 3), (5, 4)
    shape = attacker_shape * n_attackers + defender_shape
    spacing = (0.1, 0.12) * (n_attackers + 1)
    values = rng.normal(0.0, 0.3, shape).astype(np.float32)
    tables = Tables(rng, attacker_shape, defender_shape)
    target, avoid = tables.full_sets(n_attackers)
    index = np.indices(shape[:-2]).reshape(len(shape) - 2, -1)
    key = index[0::2].sum(axis=0) + index[1::2].sum(axis=0)
    rows = np.argsort(key, kind="stable").astype(np.int64)
    planes = np.concatenate([[0], np.flatnonzero(np.diff(key[rows])) + 1, [rows.size]])
    expected = values.astype(np.float64).reshape(rows.size, -1)
    for p in range(planes.size - 1):
        swept, _ = reference.sweep(expected.reshape(shape), spacing, SPEEDS, 0.02, "godunov",
                                   target, avoid)
        mine = rows[planes[p]:planes[p + 1]]
        expected[mine] = swept.reshape(rows.size, -1)[mine]
    results = []
    for chunks in (1, 4):
        got, _ = _kernel_sweep(values.copy(), spacing, 0.02, "godunov", n_attackers, tables,
                               rows=rows, planes=planes.astype(np.int64), in_place=True,
                               chunks=chunks)
        results.append(got)
    np.testing.assert_allclose(results[0], expected, rtol=0, atol=2e-6)
    np.testing.assert_array_equal(results[0], results[1])
    jacobi, _ = _kernel_sweep(values, spacing, 0.02, "godunov", n_attackers, tables)
    assert np.abs(jacobi - results[0]).max() > 1e-3


def test_initial_values_are_max_of_target_and_avoid():
    rng = np.random.default_rng(11)
    tables = Tables(rng, (3, 4), (4, 4))
    for n_attackers in (1, 2):
        target, avoid = tables.full_sets(n_attackers)
        rows = 12 ** n_attackers
        out = np.zeros((rows, 16), np.float32)
        kernels.initial_values(out, np.arange(rows, dtype=np.int64), n_attackers, 12,
                               tables.kernel_sets(), tables.kernel_survive())
        np.testing.assert_allclose(out.reshape(target.shape), np.maximum(target, avoid),
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

"""The solve loop shared by every game: march the reach-avoid update to convergence.

The infinite-horizon reach-avoid value is the fixed point of
``V <- max(min(V + dt * H(V), l), g)`` started from ``V = max(l, g)`` (cold) or from a
coarse grid's value plus a margin (warm, ``warm_start``), either clipped where a bound of
every fixed point is proved (``start``, ``settings.clip_start``). Every fixed point lies below
``max(l, g)`` and the update is monotone under the CFL bound, so from any start between
the largest fixed point and ``max(l, g)`` the iterates are squeezed onto the largest fixed
point, the one the cold start reaches. The loop stops when the largest change of ``V``
over one unit of game time, on the nodes next to the zero level set, falls below
``settings.tolerance`` (or after ``settings.max_iterations`` iterations).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from tqdm.auto import tqdm

from reachavoid_env.checks import available_memory
from solvers.hj.game import Game
from solvers.hj.grid import Grid
from solvers.hj.layout import Layout, stored_groups
from solvers.hj.marcher import Marcher, Problem, iteration_orders
from solvers.hj.settings import SolverSettings
from solvers.hj.value import ValueFunction


class InsufficientMemoryError(MemoryError):
    """The machine cannot hold the arrays a solve needs; the message names grid and need."""


@dataclass(frozen=True)
class SolveResult:
    """How a solve went. ``residual``: the last largest change of the value per unit game
    time near the zero level set (map units per second); ``game_time = iterations * dt``;
    ``start``: how the values started (``"cold"`` or ``"warm"``, ``", clipped"`` when
    ``start.StartBound`` clipped them); ``iterations`` counts every iteration."""

    iterations: int
    residual: float
    converged: bool
    seconds: float
    dt: float
    start: str = "cold"

    @property
    def game_time(self) -> float:
        return self.iterations * self.dt


def time_step(game: Game, grid: Grid, settings: SolverSettings) -> float:
    """The scheme's time step (seconds) at ``settings.cfl``."""
    h = grid.spacing
    players = [(p.speed, h[2 * k], h[2 * k + 1]) for k, p in enumerate(game.players)]
    return settings.scheme.time_step(players, settings.cfl)


def memory_needed(game: Game, grid: Grid, settings: SolverSettings) -> int:
    """Bytes a solve on ``grid`` holds at its peak: the stored float32 value rows (once for
    red-black Gauss-Seidel, twice for Jacobi), the pair tables (one ``(nodes, m)`` float32
    array per row player and table), the row layout while it is built, and 200 MiB for
    the interpreter with numpy and numba."""
    players = len(game.players)
    m = grid.shape[-2] * grid.shape[-1]
    row_counts = [grid.shape[2 * k] * grid.shape[2 * k + 1] for k in range(players - 1)]
    rows = stored = math.prod(row_counts)
    for group in stored_groups(game, settings.exchange_symmetry):
        n, k = row_counts[group[0]], len(group)
        stored = stored // n**k * math.comb(n + k - 1, k)
    arrays = 1 if settings.iteration == "red_black" else 2
    pair_tables = 4 * m * sum(row_counts) * (2 + len(game.tables()))
    layout = 8 * (8 * rows + 2 * stored)  # built from every row's node indices
    return arrays * 4 * stored * m + pair_tables + layout + (200 << 20)


def check_memory(game: Game, grid: Grid, settings: SolverSettings, label: str) -> None:
    """Raise ``InsufficientMemoryError`` when a solve on ``grid`` would not fit in memory."""
    need, have = memory_needed(game, grid, settings), available_memory()
    if need > have:
        dims = "x".join(str(n) for n in grid.shape)
        raise InsufficientMemoryError(
            f"{label} on a {dims} grid needs about {need / 2**30:.1f} GiB ({settings.iteration}"
            f" iteration, {'one' if settings.iteration == 'red_black' else 'two'} float32 "
            f"value arrays) but only {have / 2**30:.1f} GiB is available; use a coarser grid")


class Solved(NamedTuple):
    """A marched problem: the stored value rows (float32, ``layout.stored_shape``), their
    layout and how the solve went."""

    values: np.ndarray
    layout: Layout
    result: SolveResult


def solve(problem: Problem, settings: SolverSettings, progress: bool = True,
          label: str = "reach-avoid", warm_start: ValueFunction | None = None) -> Solved:
    """March ``problem`` to convergence (``Solved``).

    ``warm_start``: a converged solve of the same game on a coarser grid; the start is its
    interpolation plus ``settings.warm_margin`` (module docstring). With
    ``settings.clip_start`` the start is clipped by ``start.StartBound`` and checked after
    the first iteration (if that iteration raised a clipped node, the solve starts again
    unclipped). The caller checks the memory first (``check_memory``, as
    ``solve.solve_declared`` does). Nothing is written anywhere; an interrupt (Ctrl-C)
    between iterations propagates and frees the arrays.
    """
    marcher = Marcher.prepare(problem, settings)
    layout = marcher.layout
    dt = time_step(problem.game, problem.grid, settings)
    current = np.empty(layout.stored_shape, dtype=np.float32)
    from solvers.hj.start import StartBound  # numba: only when solving

    bound = StartBound.of(marcher, current) if settings.clip_start else None

    def begin(clipped: bool) -> str:
        if warm_start is None:
            current.fill(np.float32(1e30))
        else:
            _interpolate_start(warm_start, layout, settings.warm_margin, current)
        marcher.project(current)
        if clipped:
            bound.clip(current)
        return ("warm" if warm_start is not None else "cold") + (", clipped" if clipped else "")

    how = begin(bound is not None)
    spare = np.empty_like(current) if settings.iteration == "jacobi" else current
    orders = iteration_orders(layout, settings)
    first = residual = math.inf
    iterations = wasted = 0
    converged = False
    start = time.perf_counter()
    bar_format = "{desc}: {percentage:3.0f}%|{bar}| {elapsed}<{remaining}{postfix}"
    with tqdm(total=100, desc=label, disable=not progress, bar_format=bar_format) as bar:
        while iterations < settings.max_iterations:
            change = marcher.iterate(current, spare, orders[iterations % len(orders)], dt)
            current, spare = spare, current
            iterations += 1
            if iterations == 1 and bound is not None and not bound.holds(current):
                how = begin(False) + " (the clipped start was no supersolution)"
                bound, iterations, wasted = None, 0, 1
                continue
            residual = change / dt
            if iterations == 1:
                first = max(residual, settings.tolerance * 10)
            done = _progress(first, residual, settings.tolerance)
            if done > bar.n:
                bar.update(done - bar.n)
            bar.set_postfix_str(f"iter {iterations}, residual {residual:.2e}", refresh=False)
            if residual < settings.tolerance:
                converged = True
                break
    del spare
    result = SolveResult(iterations=iterations + wasted, residual=residual, converged=converged,
                         seconds=time.perf_counter() - start, dt=dt, start=how)
    return Solved(current, layout, result)


def _interpolate_start(coarse: ValueFunction, layout: Layout, margin: float,
                       out: np.ndarray) -> None:
    """``out`` = the coarse value at the fine nodes plus ``margin``, row by row: the coarse
    rows are first interpolated onto the fine plane, then combined across the row axes."""
    from solvers.hj import kernels

    fine, grid = layout.grid, coarse.grid
    if fine.lo != grid.lo or fine.hi != grid.hi:
        raise ValueError("warm_start: the coarse grid must span the same box")
    ndim = grid.ndim
    plane = np.kron(*(_linear_weights(grid.coordinates(a), fine.coordinates(a))
                      for a in (ndim - 2, ndim - 1)))
    up = np.asarray(coarse.values).reshape(coarse.layout.stored_shape) @ plane.T.astype(
        np.float32)
    row_axes = grid.sub(tuple(range(ndim - 2)))
    strides = np.array([math.prod(row_axes.shape[a + 1:]) for a in range(ndim - 2)],
                       dtype=np.int64)
    ny = layout.row_shape[:, 1]
    index = np.stack([layout.row_nodes // ny, layout.row_nodes % ny], axis=2)
    points = fine.sub(tuple(range(ndim - 2))).points(index.reshape(len(index), -1))
    kernels.interpolate_rows(up, coarse.layout.stored_of,
                             np.asarray(row_axes.shape, dtype=np.int64), strides,
                             np.asarray(row_axes.lo), np.asarray(row_axes.spacing),
                             np.ascontiguousarray(points), np.float32(margin), out)


def _linear_weights(coarse: np.ndarray, fine: np.ndarray) -> np.ndarray:
    """``(len(fine), len(coarse))`` weights of linear interpolation along one axis."""
    s = np.clip((fine - coarse[0]) / (coarse[1] - coarse[0]), 0, coarse.size - 1)
    lower = np.minimum(s.astype(np.int64), coarse.size - 2)
    weights = np.zeros((fine.size, coarse.size))
    weights[np.arange(fine.size), lower] = 1 - (s - lower)
    weights[np.arange(fine.size), lower + 1] += s - lower
    return weights


def _progress(first: float, residual: float, tolerance: float) -> int:
    """Percent of the way from the first residual down to the tolerance, on a log scale."""
    if residual <= tolerance:
        return 100
    fraction = math.log(first / residual) / math.log(first / tolerance)
    return int(100 * min(max(fraction, 0.0), 1.0))

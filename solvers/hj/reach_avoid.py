"""The solve loop shared by every game: march the reach-avoid update to convergence.

The infinite-horizon reach-avoid value is the fixed point of
``V <- max(min(V + dt * H(V), l), g)`` started from ``V = max(l, g)``. The scheme is monotone
under the CFL bound, so the iterates decrease monotonically towards it. The loop stops when
the largest change of ``V`` over one unit of game time, on the nodes next to the zero level
set, falls below ``settings.tolerance`` (or after ``settings.max_iterations`` sweeps).
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass

import numba
import numpy as np
from tqdm.auto import tqdm

from solvers.hj import kernels
from solvers.hj.grid import Grid
from solvers.hj.settings import SolverSettings


class InsufficientMemoryError(MemoryError):
    """The machine cannot hold the arrays a solve needs; the message names grid and need."""


@dataclass(frozen=True, eq=False)
class ReachAvoidProblem:
    """A game on a grid, as the kernels see it (``kernels`` module docstring).

    ``grid`` axes are ``(xA1, yA1[, xA2, yA2], xD, yD)`` (every attacker on the same planar
    grid). Planar float32 tables, flat in C order: ``target`` and ``attacker_free`` over the
    attacker grid ``(na,)``, ``defender_free`` over the defender grid ``(m,)`` (signed
    distances, map units, ``geometry``); ``survive`` ``(na, m)``: the 1 vs 1 value on the
    attacker x defender grid, required with two attackers. ``speeds`` is
    ``(attacker, defender)`` in map units per second, ``capture_radius`` in map units.
    """

    grid: Grid
    n_attackers: int
    speeds: tuple[float, float]
    capture_radius: float
    target: np.ndarray
    attacker_free: np.ndarray
    defender_free: np.ndarray
    survive: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.n_attackers not in (1, 2) or self.grid.ndim != 2 * self.n_attackers + 2:
            raise ValueError(f"problem: {self.n_attackers} attackers need a "
                             f"{2 * self.n_attackers + 2}-D grid, got {self.grid.ndim}-D")
        na, m = self.attacker_nodes, self.defender_nodes
        tables = {"target": (self.target, (na,)), "attacker_free": (self.attacker_free, (na,)),
                  "defender_free": (self.defender_free, (m,))}
        if self.n_attackers == 2:
            if self.survive is None:
                raise ValueError("problem.survive: required with two attackers")
            tables["survive"] = (self.survive, (na, m))
            if self.grid.sub((0, 1)) != self.grid.sub((2, 3)):
                raise ValueError("problem.grid: both attackers need the same planar grid")
        for name, (table, shape) in tables.items():
            if table.shape != shape or table.dtype != np.float32:
                raise ValueError(f"problem.{name}: expected float32 {shape}, got "
                                 f"{table.dtype} {table.shape}")

    @property
    def attacker_nodes(self) -> int:
        return self.grid.shape[0] * self.grid.shape[1]

    @property
    def defender_nodes(self) -> int:
        return self.grid.shape[-2] * self.grid.shape[-1]

    @property
    def rows(self) -> int:
        return self.attacker_nodes ** self.n_attackers

    def kernel_sets(self) -> tuple:
        """The ``sets`` tuple of ``kernels.sweep``."""
        attacker = self.grid.sub((0, 1)).mesh().reshape(-1, 2).astype(np.float32)
        ndim = self.grid.ndim
        defender = self.grid.sub((ndim - 2, ndim - 1)).mesh().reshape(-1, 2).astype(np.float32)
        return (self.target, self.attacker_free, np.ascontiguousarray(attacker[:, 0]),
                np.ascontiguousarray(attacker[:, 1]), np.ascontiguousarray(defender[:, 0]),
                np.ascontiguousarray(defender[:, 1]), self.defender_free,
                np.float32(self.capture_radius))


@dataclass(frozen=True)
class SolveResult:
    """How a solve went. ``residual``: the last largest change of the value per unit game
    time near the zero level set (map units per second); ``game_time = iterations * dt``."""

    iterations: int
    residual: float
    converged: bool
    seconds: float
    dt: float

    @property
    def game_time(self) -> float:
        return self.iterations * self.dt


def time_step(grid: Grid, n_attackers: int, speeds: tuple[float, float],
              settings: SolverSettings) -> float:
    """The largest monotone time step times ``settings.cfl`` (seconds)."""
    h = grid.spacing
    players = [(speeds[0], h[2 * i], h[2 * i + 1]) for i in range(n_attackers)]
    players.append((speeds[1], h[-2], h[-1]))
    if settings.scheme == "godunov":
        rate = sum(v * math.hypot(1 / hx, 1 / hy) for v, hx, hy in players)
    else:
        rate = sum(v * (1 / hx + 1 / hy) for v, hx, hy in players)
    return settings.cfl / rate


def memory_needed(grid: Grid, settings: SolverSettings) -> int:
    """Bytes a solve on ``grid`` holds at its peak: the float32 value arrays (one for
    red-black Gauss-Seidel, two for Jacobi), the ``(na, m)`` 1 vs 1 table (2 vs 1) and the
    row orders."""
    na = grid.shape[0] * grid.shape[1]
    m = grid.shape[-2] * grid.shape[-1]
    rows = grid.size // m
    arrays = 1 if settings.iteration == "red_black" else 2
    return arrays * 4 * grid.size + 4 * na * m + 40 * rows + (32 << 20)


def available_memory() -> int:
    """Bytes the kernel reports as available (``MemAvailable``), or total RAM if unknown."""
    try:
        with open("/proc/meminfo") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def check_memory(grid: Grid, settings: SolverSettings, label: str) -> None:
    """Raise ``InsufficientMemoryError`` when a solve on ``grid`` would not fit in memory."""
    need, have = memory_needed(grid, settings), available_memory()
    if need > have:
        dims = "x".join(str(n) for n in grid.shape)
        arrays = "one float32 value array" if settings.iteration == "red_black" else \
            "two float32 value arrays"
        raise InsufficientMemoryError(
            f"{label} on a {dims} grid needs about {need / 2**30:.1f} GiB ({arrays} of "
            f"{4 * grid.size / 2**30:.1f} GiB, {settings.iteration} iteration) but only "
            f"{have / 2**30:.1f} GiB is available; use a coarser grid")


def _stored_rows(problem: ReachAvoidProblem, symmetric: bool) -> np.ndarray:
    rows = np.arange(problem.rows, dtype=np.int64)
    if symmetric:
        na = problem.attacker_nodes
        rows = rows[rows // na >= rows % na]
    return rows


Order = tuple[np.ndarray, np.ndarray, bool]


def _sweep_orders(problem: ReachAvoidProblem, stored: np.ndarray,
                  settings: SolverSettings) -> list[Order]:
    """``(rows, planes, reverse)`` of successive sweeps (``kernels.sweep``).

    Jacobi: all rows in one plane. Red-black: the rows whose attacker node indices have an
    even sum, then the odd ones, and the other way round on the next sweep. Stencil
    neighbours differ by one in exactly one index, so they never share a colour; swapping
    the attackers keeps the sum, so the stored twin of a neighbour never does either.
    """
    if settings.iteration == "jacobi":
        return [(stored, np.array([0, stored.size], dtype=np.int64), False)]
    na, any_ = problem.attacker_nodes, problem.grid.shape[1]
    players = [stored % na] if problem.n_attackers == 1 else [stored // na, stored % na]
    odd = sum(a // any_ + a % any_ for a in players) % 2
    rows = np.concatenate([stored[odd == 0], stored[odd == 1]])
    planes = np.array([0, np.count_nonzero(odd == 0), stored.size], dtype=np.int64)
    return [(rows, planes, False), (rows, planes, True)]


def solve(problem: ReachAvoidProblem, settings: SolverSettings, progress: bool = True,
          label: str = "reach-avoid") -> tuple[np.ndarray, SolveResult]:
    """March ``problem`` to convergence; returns the value (float32, ``grid.shape``) and how.

    Nothing is written anywhere; an interrupt (Ctrl-C) between sweeps propagates and frees
    the arrays.
    """
    check_memory(problem.grid, settings, label)
    grid = problem.grid
    symmetric = settings.exchange_symmetry and problem.n_attackers == 2
    na, m = problem.attacker_nodes, problem.defender_nodes
    anx, any_ = grid.shape[0], grid.shape[1]
    dny = grid.shape[-1]
    dt = time_step(grid, problem.n_attackers, problem.speeds, settings)
    scheme = kernels.GODUNOV if settings.scheme == "godunov" else kernels.LAX_FRIEDRICHS
    inv_h = (1.0 / np.asarray(grid.spacing)).astype(np.float32)
    speeds = np.asarray(problem.speeds, dtype=np.float32)
    survive = problem.survive if problem.survive is not None else np.zeros((1, 1), np.float32)
    sets = problem.kernel_sets()
    n_chunks = 4 * numba.get_num_threads()

    jacobi = settings.iteration == "jacobi"
    current = np.empty((problem.rows, m), dtype=np.float32)
    spare = np.empty((problem.rows, m), dtype=np.float32) if jacobi else current
    stored = _stored_rows(problem, symmetric)
    orders = _sweep_orders(problem, stored, settings)
    kernels.initial_values(current, stored, problem.n_attackers, na, sets, survive)
    first = residual = math.inf
    iterations = 0
    converged = False
    start = time.perf_counter()
    bar_format = "{desc}: {percentage:3.0f}%|{bar}| {elapsed}<{remaining}{postfix}"
    with tqdm(total=100, desc=label, disable=not progress, bar_format=bar_format) as bar:
        while iterations < settings.max_iterations:
            rows, planes, reverse = orders[iterations % len(orders)]
            change = kernels.sweep(current, spare, rows, planes, reverse, problem.n_attackers,
                                   any_, anx, dny, inv_h, speeds, np.float32(dt), scheme,
                                   symmetric, sets, survive, n_chunks)
            current, spare = spare, current
            iterations += 1
            residual = float(change) / dt
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
    if symmetric:
        kernels.mirror_rows(current, na)
    result = SolveResult(iterations=iterations, residual=residual, converged=converged,
                         seconds=time.perf_counter() - start, dt=dt)
    return current.reshape(grid.shape), result


def _progress(first: float, residual: float, tolerance: float) -> int:
    """Percent of the way from the first residual down to the tolerance, on a log scale."""
    if residual <= tolerance:
        return 100
    fraction = math.log(first / residual) / math.log(first / tolerance)
    return int(100 * min(max(fraction, 0.0), 1.0))

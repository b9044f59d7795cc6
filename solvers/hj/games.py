"""The paper's 1 vs 1 and 2 vs 1 reach-avoid games (Section III B-C) and their solves.

1 vs 1, eq. (RA_11), axes ``(xA, yA, xD, yD)``:
- target ``R11``: the attacker is in the target and not captured, or the defender is in an
  obstacle: ``l = min(max(sT(a), R - |a - d|), sF(d))``;
- avoid ``A11``: captured, or the attacker is in an obstacle: ``g = max(R - |a - d|, -sF(a))``;
with ``sT`` the target's signed distance and ``sF`` the free-space signed distance
(``geometry``). The attacker wins where the value is <= 0.

2 vs 1, eqs. (RA_21) and (L), axes ``(xA1, yA1, xA2, yA2, xD, yD)``:
- target ``R21``: either attacker in the target uncaptured, or the defender in an obstacle:
  ``l = min(reach(a1, d), reach(a2, d), sF(d))`` with ``reach = max(sT(a), R - |a - d|)``;
- avoid ``A21 = L1 u L2``: one attacker is captured or in an obstacle and the other loses
  its remaining 1 vs 1 game: ``g = max(min(lost(a1, d), V11(a2, d)),
  min(lost(a2, d), V11(a1, d)))`` with ``lost = max(R - |a - d|, -sF(a))`` and ``V11`` the
  converged 1 vs 1 value (same speeds and radius), interpolated onto the 2 vs 1 grid once.
The attacker side (at least one attacker arrives) wins where the value is <= 0.

Both games are solved by the same loop and kernels (``reach_avoid``); only these tables
differ.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from reachavoid_env import GameMap, load_scenario
from solvers.hj import cache as value_cache
from solvers.hj import geometry
from solvers.hj.grid import Grid
from solvers.hj.reach_avoid import ReachAvoidProblem, SolveResult, check_memory, solve
from solvers.hj.settings import SOLVER_VERSION, SolverSettings
from solvers.hj.value import ValueFunction


def _planar_tables(game_map: GameMap, grid: Grid) -> dict[str, np.ndarray]:
    """``target`` and ``attacker_free`` over the attacker grid, ``defender_free`` over the
    defender grid, flat float32 (``ReachAvoidProblem``)."""
    attacker_grid, defender_grid = grid.sub((0, 1)), grid.sub((grid.ndim - 2, grid.ndim - 1))
    return {
        "target": geometry.target_distance(game_map, attacker_grid).reshape(-1),
        "attacker_free": geometry.free_distance(game_map, attacker_grid).reshape(-1),
        "defender_free": geometry.free_distance(game_map, defender_grid).reshape(-1),
    }


def problem_1v1(game_map: GameMap, speeds: tuple[float, float], capture_radius: float,
                grid: Grid) -> ReachAvoidProblem:
    """The 1 vs 1 game of eq. (RA_11) on ``grid`` (4-D)."""
    return ReachAvoidProblem(grid=grid, n_attackers=1, speeds=speeds,
                             capture_radius=capture_radius, **_planar_tables(game_map, grid))


def problem_2v1(game_map: GameMap, vf11: ValueFunction, grid: Grid) -> ReachAvoidProblem:
    """The 2 vs 1 game of eqs. (RA_21), (L) on ``grid`` (6-D), avoid set from ``vf11``."""
    pair_grid = grid.sub((0, 1, 4, 5))
    survive = vf11.value(pair_grid.mesh().reshape(-1, 4)).astype(np.float32)
    na = grid.shape[0] * grid.shape[1]
    return ReachAvoidProblem(grid=grid, n_attackers=2,
                             speeds=(vf11.attacker_speed, vf11.defender_speed),
                             capture_radius=vf11.capture_radius,
                             survive=survive.reshape(na, -1), **_planar_tables(game_map, grid))


def _solver_meta(settings: SolverSettings, result: SolveResult) -> dict[str, object]:
    return {
        "scheme": settings.scheme,
        "iteration": settings.iteration,
        "cfl": settings.cfl,
        "tolerance": settings.tolerance,
        "iterations": result.iterations,
        "residual": result.residual,
        "converged": result.converged,
        "seconds": round(result.seconds, 3),
        "dt": result.dt,
        "version": SOLVER_VERSION,
    }


def _key_parts(game: str, game_map: GameMap, speeds: tuple[float, float],
               capture_radius: float, grid: Grid, settings: SolverSettings) -> dict[str, object]:
    return {
        "game": game,
        "map": game_map.to_dict(),
        "speeds": list(speeds),
        "capture_radius": capture_radius,
        "grid": [list(grid.lo), list(grid.hi), list(grid.shape)],
        "settings": [settings.scheme, settings.iteration, settings.cfl, settings.tolerance,
                     settings.max_iterations],
        "version": SOLVER_VERSION,
    }


def solve_1v1(game_map: GameMap, speeds: tuple[float, float] = (1.0, 1.5),
              capture_radius: float = 0.1, grid_points: int | Sequence[int] = 45,
              settings: SolverSettings | None = None, cache: bool = True,
              progress: bool = True) -> ValueFunction:
    """Solve the 1 vs 1 game on ``game_map``; ``speeds = (attacker, defender)``.

    ``grid_points``: nodes per axis over the map's domain. With ``cache`` the result is
    looked up in, or stored to, the on-disk cache (``cache`` module).
    """
    settings = settings or SolverSettings()
    speeds = (float(speeds[0]), float(speeds[1]))
    if min(speeds) <= 0 or capture_radius <= 0:
        raise ValueError(f"speeds {speeds} and capture_radius {capture_radius} must be positive")
    grid = Grid.for_players(game_map.domain, 2, grid_points)
    check_memory(grid, settings, "1v1 HJ solve")

    def run() -> ValueFunction:
        problem = problem_1v1(game_map, speeds, float(capture_radius), grid)
        values, result = solve(problem, settings, progress=progress, label="1v1 HJ solve")
        return ValueFunction(values=values, grid=grid, game="1v1", attacker_speed=speeds[0],
                             defender_speed=speeds[1], capture_radius=float(capture_radius),
                             game_map=game_map, solver=_solver_meta(settings, result))

    if not cache:
        return run()
    parts = _key_parts("1v1", game_map, speeds, float(capture_radius), grid, settings)
    return value_cache.cached("1v1", grid.shape, parts, game_map, run)


def solve_2v1(game_map: GameMap, vf11: ValueFunction, grid_points: int | Sequence[int] = 30,
              settings: SolverSettings | None = None, cache: bool = True,
              progress: bool = True) -> ValueFunction:
    """Solve the 2 vs 1 game on ``game_map`` with the avoid set built from ``vf11``.

    Speeds and capture radius are those of ``vf11`` (a 1 vs 1 solve on the same map).
    The result is memory-mapped from its file when cached.
    """
    settings = settings or SolverSettings()
    if vf11.game != "1v1":
        raise ValueError(f"vf11: expected a 1v1 value function, got {vf11.game}")
    if vf11.game_map != game_map:
        raise ValueError("vf11: solved on another map than game_map")
    grid = Grid.for_players(game_map.domain, 3, grid_points)
    speeds = (vf11.attacker_speed, vf11.defender_speed)
    check_memory(grid, settings, "2v1 HJ solve")

    def run() -> ValueFunction:
        problem = problem_2v1(game_map, vf11, grid)
        values, result = solve(problem, settings, progress=progress, label="2v1 HJ solve")
        meta = _solver_meta(settings, result) | {"vf11_shape": list(vf11.grid.shape)}
        return ValueFunction(values=values, grid=grid, game="2v1", attacker_speed=speeds[0],
                             defender_speed=speeds[1], capture_radius=vf11.capture_radius,
                             game_map=game_map, solver=meta)

    if not cache:
        return run()
    parts = _key_parts("2v1", game_map, speeds, vf11.capture_radius, grid, settings)
    parts["vf11"] = [list(vf11.grid.shape), _digest(vf11.values)]
    return value_cache.cached("2v1", grid.shape, parts, game_map, run)


def _digest(values: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(values).data).hexdigest()[:20]


@dataclass(frozen=True)
class SolveReport:
    """What ``solve_game`` did: where the value went and how the solve went."""

    path: Path
    game: str
    shape: tuple[int, ...]
    iterations: int
    residual: float
    converged: bool
    seconds: float
    plot: Path | None = None

    def summary(self) -> str:
        text = (f"{self.game} value {'x'.join(map(str, self.shape))} -> {self.path}\n"
                f"iterations {self.iterations}, residual {self.residual:.2e} per unit game "
                f"time ({'converged' if self.converged else 'NOT converged'}), "
                f"solve {self.seconds:.1f} s")
        return text + (f"\nslices -> {self.plot}" if self.plot is not None else "")


def solve_game(scenario: str, game: str, grid_points: int | None = None,
               out: str | None = None, grid_points_1v1: int = 45, plot: str | None = None,
               progress: bool = True) -> SolveReport:
    """Solve a scenario's 1 vs 1 or 2 vs 1 game (the ``reachavoid solve`` command).

    ``scenario`` is a built-in name or a TOML file; speeds and capture radius come from it.
    ``grid_points`` defaults to the paper's grids: 45 (1 vs 1) and 30 (2 vs 1).
    The 2 vs 1 game uses the scenario's 1 vs 1 value at ``grid_points_1v1`` (cached).
    The value goes to the cache, and is also saved to ``out`` when given. ``plot``: a PNG
    of the value's slices at the scenario's fixed starts (``plot.scenario_panels``).
    """
    if game not in ("1v1", "2v1"):
        raise ValueError(f"game: expected '1v1' or '2v1', got {game!r}")
    if grid_points is None:
        grid_points = 45 if game == "1v1" else 30
    sc = load_scenario(scenario)
    if plot is not None and (sc.attackers is None or sc.defenders is None):
        raise ValueError(f"plot: scenario {sc.name!r} has random starts; the slices need "
                         "fixed ones")
    if game == "2v1":
        check_memory(Grid.for_players(sc.map.domain, 3, grid_points), SolverSettings(),
                     "2v1 HJ solve")
    speeds = (sc.attacker_speed, sc.defender_speed)
    started = time.perf_counter()
    vf = solve_1v1(sc.map, speeds, sc.capture_radius,
                   grid_points if game == "1v1" else grid_points_1v1, progress=progress)
    if game == "2v1":
        vf = solve_2v1(sc.map, vf, grid_points, progress=progress)
    path = vf.save(out) if out is not None else _cached_location(vf)
    if plot is not None:
        from solvers.hj.plot import scenario_panels, tube_figure

        tube_figure(scenario_panels(vf, sc.attackers, sc.defenders[0]), plot)
    return SolveReport(path=path, game=game, shape=vf.grid.shape,
                       iterations=int(vf.solver.get("iterations", 0)),
                       residual=float(vf.solver.get("residual", float("nan"))),
                       converged=bool(vf.solver.get("converged", False)),
                       seconds=time.perf_counter() - started,
                       plot=Path(plot) if plot is not None else None)


def _cached_location(vf: ValueFunction) -> Path:
    filename = getattr(vf.values, "filename", None)
    return Path(filename).parent if filename else Path("<memory>")


"""Solve any declared game on a map: tables, warm start, cache, value function.

``solve_declared`` is the one entry every game goes through (``games`` declares the
paper's): it builds the planar tables from the map and the lower games' tables from
their value functions, starts from the coarser grid's solve when warm starts are on, and
looks the result up in (or stores it to) the cache under a key of everything that
decides the values. A solve that runs (not one loaded from the cache) first prints one
line to standard error, terminal or not, when ``progress`` is on or its grid has at least
``LONG_SOLVE_NODES`` nodes (then always: the command line turns progress bars off when
standard error is not a terminal, and a log should still say why nothing happens for
minutes).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Mapping

import numpy as np

from reachavoid_env import GameMap
from solvers.hj import cache as value_cache
from solvers.hj.game import Game
from solvers.hj.grid import Grid
from solvers.hj.marcher import map_problem
from solvers.hj.reach_avoid import SolveResult, check_memory, solve
from solvers.hj.settings import SOLVER_VERSION, SolverSettings
from solvers.hj.value import ValueFunction, checksum


def _solver_meta(settings: SolverSettings, result: SolveResult,
                 warm: ValueFunction | None) -> dict[str, object]:
    return {
        "scheme": settings.scheme.name,
        "iteration": settings.iteration,
        "cfl": settings.cfl,
        "tolerance": settings.tolerance,
        "iterations": result.iterations,
        "residual": result.residual,
        "converged": result.converged,
        "seconds": round(result.seconds, 3),
        "dt": result.dt,
        "warm_start": None if warm is None else list(warm.grid.shape),
        "start": result.start,
        "version": SOLVER_VERSION,
    }


def lower_tables(game: Game, grid: Grid, lower: Mapping[str, ValueFunction]
                 ) -> dict[str, np.ndarray]:
    """Each extra table of ``game``: the lower game's value at the nodes of the two players
    it spans, float32 ``(nx_p, ny_p, nx_q, ny_q)``."""
    tables = {}
    for name, (p, q) in game.tables().items():
        if name not in lower:
            raise ValueError(f"lower: the {game.name} game reads the table {name!r}")
        sub = grid.sub((2 * p, 2 * p + 1, 2 * q, 2 * q + 1))
        values = lower[name].value(sub.mesh().reshape(-1, 4))
        tables[name] = values.astype(np.float32).reshape(sub.shape)
    return tables


def _key_parts(game: Game, game_map: GameMap, grid: Grid, settings: SolverSettings,
               lower: Mapping[str, ValueFunction]) -> dict[str, object]:
    return {
        "game": game.describe(),
        "map": game_map.to_dict(),
        "grid": [list(grid.lo), list(grid.hi), list(grid.shape)],
        "settings": list(settings.to_dict().values()),   # every field, in declared order
        "lower": {name: [list(vf.grid.shape), checksum(vf.values)]
                  for name, vf in sorted(lower.items())},
        "version": SOLVER_VERSION,
    }


LONG_SOLVE_NODES = 4_000_000
"""Grid nodes from which a solve is announced whatever ``progress`` says: the paper's 1 vs 1
grid (45^4, 4.1 million nodes) solves in about 16 s, its 2 vs 1 grid (30^6) in about 10
minutes (``benchmarks/results/hj_1v1.json``, ``hj_2v1.json``)."""


def solve_declared(game: Game, game_map: GameMap, grid: Grid,
                   settings: SolverSettings | None = None, cache: bool = True,
                   progress: bool = True,
                   lower: Mapping[str, ValueFunction] | None = None) -> ValueFunction:
    """Solve ``game`` on ``game_map`` over ``grid``; ``lower`` gives the value function of
    every extra table the game reads (``Game.tables``). With ``cache`` the result (and a
    warm start's coarse solve) is looked up in, or stored to, the on-disk cache."""
    settings = settings or SolverSettings()
    lower = dict(lower or {})
    label = f"{game.name} HJ solve"
    check_memory(game, grid, settings, label)

    def run() -> ValueFunction:
        warm = None
        coarse = settings.coarse_points(grid.shape)
        if coarse is not None:
            warm = solve_declared(game, game_map, Grid(grid.lo, grid.hi, coarse), settings,
                                  cache=cache, progress=progress, lower=lower)
        if progress or math.prod(grid.shape) >= LONG_SOLVE_NODES:
            print(f"{label} on a {'x'.join(map(str, grid.shape))} grid: "
                  + ("not in the cache, solving once (minutes at the paper's grids)"
                     if cache else "solving (not cached)"), file=sys.stderr, flush=True)
        problem = map_problem(game, game_map, grid, lower_tables(game, grid, lower))
        values, layout, result = solve(problem, settings, progress=progress, label=label,
                                       warm_start=warm)
        names = [p.name for p in game.players]
        symmetries = tuple(tuple(names[k] for k in g) for g in layout.groups)
        return ValueFunction(values=values if symmetries else values.reshape(grid.shape),
                             grid=grid, game=game.name, players=game.players,
                             game_map=game_map, parameters=dict(game.parameters),
                             symmetries=symmetries,
                             solver=_solver_meta(settings, result, warm))

    with value_cache.failures_named():
        if not cache:
            return run()
        return _cached(game, game_map, grid, settings, lower, run)


def _cached(game: Game, game_map: GameMap, grid: Grid, settings: SolverSettings,
            lower: Mapping[str, ValueFunction], run: Callable[[], ValueFunction]
            ) -> ValueFunction:
    """``run``'s value function, looked up in (or stored to) the cache."""
    parts = _key_parts(game, game_map, grid, settings, lower)
    description = game.describe()
    expected = {"game": game.name, "players": description["players"],
                "parameters": description["parameters"], "grid_min": list(grid.lo),
                "grid_max": list(grid.hi), "shape": list(grid.shape),
                "map": game_map.to_dict(), "scheme": settings.scheme.name}
    return value_cache.cached(game.name, grid.shape, parts, expected, game_map, run)

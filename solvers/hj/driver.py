"""``reachavoid solve``: solve a scenario's game, save it, plot its slices (a thin driver)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from reachavoid_env import load_scenario
from solvers.hj.games import game_2v1, solve_1v1, solve_2v1
from solvers.hj.grid import Grid
from solvers.hj.reach_avoid import check_memory
from solvers.hj.settings import SolverSettings
from solvers.hj.value import ValueFunction, refuse_foreign


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
    The value goes to the cache, and is also saved to ``out`` when given (refused, before
    any work, when ``out`` exists and is not a value directory: ``OutputPathError``).
    ``plot``: a PNG of the value's slices at the scenario's fixed starts
    (``plot.scenario_panels``).
    """
    if game not in ("1v1", "2v1"):
        raise ValueError(f"game: expected '1v1' or '2v1', got {game!r}")
    if grid_points is None:
        grid_points = 45 if game == "1v1" else 30
    if out is not None:
        refuse_foreign(Path(out))
    sc = load_scenario(scenario)
    if plot is not None and (sc.attackers is None or sc.defenders is None):
        raise ValueError(f"plot: scenario {sc.name!r} has random starts; the slices need "
                         "fixed ones")
    speeds = (sc.attacker_speed, sc.defender_speed)
    if game == "2v1":
        check_memory(game_2v1(speeds, sc.capture_radius),
                     Grid.for_players(sc.map.domain, 3, grid_points), SolverSettings(),
                     "2v1 HJ solve")
    started = time.perf_counter()
    vf = solve_1v1(sc.map, speeds, sc.capture_radius,
                   grid_points if game == "1v1" else grid_points_1v1, progress=progress)
    if game == "2v1":
        vf = solve_2v1(sc.map, vf, grid_points, progress=progress)
    path = vf.save(out) if out is not None else _cached_location(vf)
    if plot is not None:
        from solvers.hj.plot import scenario_panels, tube_figure

        tube_figure(scenario_panels(vf, sc.attackers, sc.defenders), plot)
    return SolveReport(path=path, game=game, shape=vf.grid.shape,
                       iterations=int(vf.solver.get("iterations", 0)),
                       residual=float(vf.solver.get("residual", float("nan"))),
                       converged=bool(vf.solver.get("converged", False)),
                       seconds=time.perf_counter() - started,
                       plot=Path(plot) if plot is not None else None)


def _cached_location(vf: ValueFunction) -> Path:
    filename = getattr(vf.values, "filename", None)
    return Path(filename).parent if filename else Path("<memory>")

"""The ``reachavoid solve`` driver: a scenario's game solved (cached), saved and plotted."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from solvers.hj.settings import PAPER_GRIDS

if TYPE_CHECKING:
    from reachavoid_env import Scenario
    from solvers.hj import ValueFunction

GAMES = ("1v1", "2v1", "1v2")
DEFAULT_GRID = {"1v1": PAPER_GRIDS.grid1, "2v1": PAPER_GRIDS.grid2, "1v2": PAPER_GRIDS.grid2}
"""The paper's grids (nodes per axis); the 1 vs 2 game takes the 2 vs 1 game's."""
PLAYERS = {"1v1": (1, 1), "2v1": (2, 1), "1v2": (1, 2)}
"""Attackers and defenders of each game."""


@dataclass(frozen=True)
class SolveReport:
    """What ``solve_scenario`` did: where the value went and how the solve went."""

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


def solve_scenario(scenario: str | Scenario, game: str, grid_points: int | None = None,
                   out: str | None = None, grid_points_1v1: int = PAPER_GRIDS.grid1,
                   plot: str | None = None, progress: bool = True) -> SolveReport:
    """Solve a scenario's 1 vs 1, 2 vs 1 or 1 vs 2 game.

    ``scenario`` is a built-in name, a TOML file or a loaded ``Scenario``; speeds and capture
    radius come from it.
    ``grid_points`` defaults to the paper's grids (``DEFAULT_GRID``). The 2 vs 1 and
    1 vs 2 games use the scenario's 1 vs 1 value at ``grid_points_1v1``. The value goes to
    the cache, and is also saved to ``out`` when given (refused before any work when
    ``out`` holds anything but a value directory: ``OutputPathError``). ``plot``: a PNG of
    the value's slices at the scenario's fixed starts (the paper's Fig. 2), which must hold
    as many attackers and defenders as the game has (checked before the solve).
    """
    from reachavoid_env import Scenario, load_scenario
    from solvers.hj import check_tubes_memory, solve_1v1, solve_1v2, solve_2v1
    from solvers.hj.value import refuse_foreign

    if game not in GAMES:
        raise ValueError(f"game: expected one of {', '.join(GAMES)}, got {game!r}")
    if out is not None:
        refuse_foreign(Path(out))
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    if plot is not None and (sc.attackers is None or sc.defenders is None):
        raise ValueError(f"plot: scenario {sc.name!r} has random starts; the slices need "
                         "fixed ones")
    if plot is not None:
        attackers, defenders = PLAYERS[game]
        if len(sc.attackers) < attackers or len(sc.defenders) < defenders:
            raise ValueError(f"plot: the {game} slices need {attackers} attacker and "
                             f"{defenders} defender start(s); scenario {sc.name!r} has "
                             f"{len(sc.attackers)} and {len(sc.defenders)}")
    grid_points = grid_points or DEFAULT_GRID[game]
    check_tubes_memory(sc.map, (sc.attacker_speed, sc.defender_speed), sc.capture_radius,
                       grid_points if game == "1v1" else grid_points_1v1,
                       None if game == "1v1" else grid_points)
    started = time.perf_counter()
    vf = solve_1v1(sc.map, (sc.attacker_speed, sc.defender_speed), sc.capture_radius,
                   grid_points if game == "1v1" else grid_points_1v1, progress=progress)
    if game != "1v1":
        solve_6d = solve_2v1 if game == "2v1" else solve_1v2
        vf = solve_6d(sc.map, vf, grid_points, progress=progress)
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

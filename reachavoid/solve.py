"""The ``reachavoid solve`` driver: a scenario's game solved (cached), saved and plotted;
or every tube that named defenders need on every map of a library, on a backend."""

from __future__ import annotations

import functools
import os
import time
import tracemalloc
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from tqdm import tqdm

from policies.registry import PolicySpec
from policies.tubes import loaded_tubes
from reachavoid.sweep import check_backend, run_tasks
from reachavoid_env import Scenario, load_scenario
from reachavoid_env.checks import FieldError
from solvers.hj import ValueFunction, check_tubes_memory, solve_1v1, solve_1v2, solve_2v1
from solvers.hj.cache import cache_dir
from solvers.hj.games import game_1v1, game_1v2, game_2v1
from solvers.hj.grid import Grid
from solvers.hj.reach_avoid import available_memory, memory_needed
from solvers.hj.settings import PAPER_GRIDS, SolverSettings
from solvers.hj.value import refuse_foreign

GAMES = ("1v1", "2v1", "1v2")
DEFAULT_GRID = {"1v1": PAPER_GRIDS.grid1, "2v1": PAPER_GRIDS.grid2, "1v2": PAPER_GRIDS.grid2}
"""The paper's grids (nodes per axis); the 1 vs 2 game takes the 2 vs 1 game's."""
PLAYERS = {"1v1": (1, 1), "2v1": (2, 1), "1v2": (1, 2)}
"""Attackers and defenders of each game."""
_SOLVE_6D = {"2v1": solve_2v1, "1v2": solve_1v2}


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

    ``scenario`` is a built-in name, a TOML file or a ``Scenario``; speeds and capture
    radius come from it.
    ``grid_points`` defaults to the paper's grids (``DEFAULT_GRID``). The 2 vs 1 and
    1 vs 2 games use the scenario's 1 vs 1 value at ``grid_points_1v1``. The value goes to
    the cache, and is also saved to ``out`` when given (refused before any work when
    ``out`` holds anything but a value directory: ``OutputPathError``). ``plot``: a PNG of
    the value's slices at the scenario's fixed starts (the paper's Fig. 2), which must hold
    as many attackers and defenders as the game has (checked before the solve).
    """
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
    if game in _SOLVE_6D:
        vf = _SOLVE_6D[game](sc.map, vf, grid_points, progress=progress)
    path = vf.save(out) if out is not None else _cached_location(vf)
    if plot is not None:
        from solvers.hj.plot import scenario_panels, tube_figure  # matplotlib: only to plot

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


# -- map libraries ----------------------------------------------------------------------------

@dataclass(frozen=True)
class TubeSolve:
    """One tube of a library solve: the map, the game, its grid (nodes per axis), the
    solve's seconds (``None``: the cache held it already), the peak of traced memory of the
    map's task (bytes: numpy and Python allocations while the map's tubes were loaded or
    solved, every game of the map together) and the tube's cache folder."""

    map: str
    game: str
    grid: int
    seconds: float | None
    peak_bytes: int
    path: Path


def map_tubes(specs: Sequence[PolicySpec], grid1: int, grid2: int,
              scenario: Scenario) -> list[TubeSolve]:
    """Load or solve every tube the defenders of ``specs`` need on ``scenario``'s map: the
    task of a library solve (building each policy fills the cache), reporting each tube."""
    folder = cache_dir()
    before = {p.name for p in folder.iterdir()} if folder.is_dir() else set()
    tracemalloc.start()
    try:
        for spec in specs:
            spec(scenario, seed=0, progress=False)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    rows = []
    for key, vf in loaded_tubes(scenario).items():
        if key.grid1 != grid1 or key.grid2 not in (0, grid2):
            continue
        path = _cached_location(vf)
        seconds = None if path.name in before else float(vf.solver.get("seconds", 0.0))
        rows.append(TubeSolve(scenario.name, vf.game, vf.grid.shape[0], seconds, peak, path))
    return sorted(rows, key=lambda row: GAMES.index(row.game))


def library_memory(scenarios: Sequence[Scenario], specs: Sequence[PolicySpec], grid1: int,
                   grid2: int) -> int:
    """Bytes one worker of a library solve needs at its peak: the largest solve among the
    games the defenders' options name (``grid1``: the 1 vs 1 game; ``grid2``: the 2 vs 1
    and 1 vs 2 games) over the maps (``solvers.hj.reach_avoid.memory_needed``)."""
    options = {name for spec in specs for name, _ in spec.options}
    need = 0
    for sc in scenarios:
        speeds = (sc.attacker_speed, sc.defender_speed)
        games = [(game_1v1(speeds, sc.capture_radius), 2, grid1)] if "grid1" in options else []
        if "grid2" in options:
            games += [(game_2v1(speeds, sc.capture_radius), 3, grid2),
                      (game_1v2(speeds, sc.capture_radius), 3, grid2)]
        for game, players, points in games:
            grid = Grid.for_players(sc.map.domain, players, points)
            need = max(need, memory_needed(game, grid, SolverSettings()))
    return need


def solve_library(scenarios: Sequence[Scenario], defenders: Sequence[str], grid1: int,
                  grid2: int, backend: str = "serial", workers: int | None = None,
                  address: str | None = None, progress: bool = False) -> list[TubeSolve]:
    """Load or solve every tube the named ``defenders`` need on every map of ``scenarios``
    (one task per map) on ``backend`` (``reachavoid.sweep.run_tasks``), and return one row
    per tube in map order. What the cache holds is loaded, not solved, so an interrupted
    library resumes where it stopped.

    Before any work, ``ValueError`` naming ``workers`` when that many concurrent solves (the
    CPU count by default; one serially; not checked on a remote Ray cluster) would not fit
    in the memory available.
    """
    grids = {"grid1": grid1, "grid2": grid2}
    chosen = [PolicySpec("defenders", name) for name in defenders]
    specs = tuple(PolicySpec.of("defenders", spec.source,
                                **{key: grid for key, grid in grids.items()
                                   if spec.choice.takes(key)}) for spec in chosen)
    unique = list({replace(sc, attackers=None, defenders=None): sc for sc in scenarios}.values())
    check_backend(backend)
    if address is None:
        count = 1 if backend == "serial" else (workers or os.cpu_count() or 1)
        need, have = library_memory(unique, specs, grid1, grid2), available_memory()
        if count * need > have:
            raise FieldError(f"workers: {count} concurrent solves need about "
                             f"{count * need / 2**30:.1f} GiB ({need / 2**30:.2f} GiB each) but "
                             f"{have / 2**30:.1f} GiB is available; use at most "
                             f"{max(1, have // max(need, 1))} workers or coarser grids",
                             "workers")
    rows: dict[str, list[TubeSolve]] = {}
    task = functools.partial(map_tubes, specs, grid1, grid2)
    with tqdm(total=len(unique), desc="tubes", unit="map", disable=not progress) as bar:
        for result in run_tasks(task, unique, backend, workers, address):
            if result:
                rows[result[0].map] = result
            bar.update(1)
    return [row for sc in unique for row in rows.get(sc.name, [])]

"""Benchmark suites: named, versioned sets of cells that every defender method plays on the
same seeds (``reachavoid bench --suite NAME``).

A suite is a TOML file: the built-ins live in ``reachavoid_env/suites/`` (``default``),
and any path works, so you can write your own::

    name = "mine"
    version = 1
    seed = 0                                   # episode k of a cell: seed + k
    attackers = ["shortest-path", "random"]    # every cell, unless it says otherwise

    [[cells]]
    scenario = "paper_2v1"                     # a built-in or a TOML path (beside this file)
    attackers = ["shortest-path"]
    episodes = 1                               # fixed starts, deterministic: one game

    [[cells]]
    scenario = "paper_2v1"
    players = "6v2"                            # random starts of 6 attackers, 2 defenders

A cell is one scenario (its fixed starts, or random starts of ``players`` on its map)
against one attacker policy; ``episodes`` fixes a cell's episode count, else the command's
``--episodes`` applies. ``run_suite`` plays every cell with every method
(``evaluation.compare``: summaries and paired differences against a baseline);
``plot_suite`` draws the capture rates with their intervals. ``library_suite`` makes a
suite of a map library (``reachavoid bench --scenario DIR``): a cell per map, and every
map's episodes of one attacker policy pooled as well (``SuiteResult.pooled``).
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from policies.registry import Factory, policy_specs
from reachavoid.evaluation import (
    CaptureSummary,
    Comparison,
    PairedDifference,
    compare,
    one_start,
    score,
)
from reachavoid.rollout import EpisodeResult
from reachavoid.sweep import Sweep, run_sweeps
from reachavoid_env import Scenario, ScenarioError, checks, load_scenario
from reachavoid_env.files import atomic_write
from reachavoid_env.scenario import read_toml


class SuiteError(ValueError):
    """A suite file is invalid; the message names the file and the field."""


def parse_players(text: Any, field: str) -> tuple[int, int]:
    """``"MvN"`` as ``(attackers, defenders)``, each in [1, 64]."""
    match = re.fullmatch(r"(\d+)v(\d+)", text) if isinstance(text, str) else None
    if match is None:
        raise ValueError(f"{field}: expected MvN such as 6v2, got {text!r}")
    return (checks.integer(int(match[1]), f"{field} attackers", 1, 64),
            checks.integer(int(match[2]), f"{field} defenders", 1, 64))


@dataclass(frozen=True)
class Cell:
    """One game against one attacker policy. ``game``: what it plays (a built-in's name, or
    ``"<name> random MvN"``); ``episodes``: fixed by the suite, or ``None`` for the
    command's count."""

    game: str
    scenario: Scenario
    attackers: str
    episodes: int | None = None

    @property
    def label(self) -> str:
        return f"{self.game} / {self.attackers}"


@dataclass(frozen=True)
class Suite:
    """A named, versioned list of cells; episode ``k`` of every cell uses seed
    ``seed + k``. ``pooled``: the cells are the maps of one library, and ``run_suite``
    pools each attacker policy's cells as well."""

    name: str
    version: int
    seed: int
    cells: tuple[Cell, ...]
    pooled: bool = False


def library_suite(name: str, scenarios: Sequence[Scenario], attackers: str, seed: int = 0,
                  players: tuple[int, int] | None = None) -> Suite:
    """A pooled suite of a map library: one cell per map (its label the map's name) with
    the map's own players, or random starts of ``players`` (attackers, defenders), against
    ``attackers``."""
    cells = []
    for scenario in scenarios:
        if players is not None:
            scenario = scenario.with_players(*players)
        cells.append(Cell(scenario.name, scenario, attackers))
    return Suite(name, 0, seed, tuple(cells), pooled=True)


def suite_names() -> list[str]:
    """Names of the built-in suites."""
    folder = resources.files("reachavoid_env") / "suites"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def load_suite(source: str | os.PathLike[str]) -> Suite:
    """A built-in suite by name, or a suite TOML file (``SuiteError`` naming the field)."""
    if Path(source).suffix != ".toml" and str(source) in suite_names():
        folder = resources.files("reachavoid_env") / "suites"
        text, where, base = (folder / f"{source}.toml").read_bytes(), str(source), None
    elif Path(source).is_file():
        text, where, base = Path(source).read_bytes(), str(source), Path(source).parent
    else:
        raise SuiteError(f"suite: no such file or built-in {str(source)!r} "
                         f"(built-ins: {', '.join(suite_names())})")
    data = read_toml(text, f"suite {where}", SuiteError)
    try:
        return _suite(data, base)
    except ValueError as err:
        raise SuiteError(f"suite {where}: {err}") from None


def _suite(data: dict[str, Any], base: Path | None) -> Suite:
    unknown = sorted(set(data) - {"name", "version", "description", "seed", "attackers",
                                  "cells"})
    if unknown:
        raise ValueError(f"unknown keys {unknown}")
    for key in ("name", "version", "cells"):
        if key not in data:
            raise ValueError(f"{key}: missing")
    if not isinstance(data["name"], str) or not data["name"]:
        raise ValueError(f"name: expected a non-empty string, got {data['name']!r}")
    version = checks.integer(data["version"], "version", 1)
    seed = checks.integer(data.get("seed", 0), "seed", 0, 2**63 - 1)
    if not isinstance(data["cells"], list) or not data["cells"]:
        raise ValueError("cells: expected a non-empty array of tables [[cells]]")
    everywhere = _attackers(data.get("attackers"), "attackers")
    cells = []
    for k, entry in enumerate(data["cells"]):
        cells.extend(_cells(entry, f"cells[{k}]", everywhere, base))
    labels = [cell.label for cell in cells]
    repeated = sorted({label for label in labels if labels.count(label) > 1})
    if repeated:
        raise ValueError(f"cells: {repeated} declared twice")
    return Suite(data["name"], version, seed, tuple(cells))


def _attackers(value: Any, field: str) -> list[str] | None:
    if value is None:
        return None
    if not isinstance(value, list) or not value or not all(isinstance(v, str) and v
                                                           for v in value):
        raise ValueError(f"{field}: expected a non-empty array of attacker specs, "
                         f"got {value!r}")
    return value


def _cells(entry: Any, field: str, everywhere: list[str] | None,
           base: Path | None) -> list[Cell]:
    if not isinstance(entry, dict):
        raise ValueError(f"{field}: expected a table")
    unknown = sorted(set(entry) - {"scenario", "players", "attackers", "episodes"})
    if unknown:
        raise ValueError(f"{field}: unknown keys {unknown}")
    source = entry.get("scenario")
    if not isinstance(source, str) or not source:
        raise ValueError(f"{field}.scenario: expected a built-in name or a TOML path, "
                         f"got {source!r}")
    path = Path(source)
    if base is not None and path.suffix == ".toml" and not path.is_absolute():
        path = base / path
    try:
        scenario = load_scenario(path if path.suffix == ".toml" else source)
    except (ScenarioError, OSError) as err:
        raise ValueError(f"{field}.scenario: {err}") from None
    label = Path(source).stem
    if "players" in entry:
        m, n = parse_players(entry["players"], f"{field}.players")
        scenario = scenario.with_players(m, n)
        label = f"{label} random {m}v{n}"
    attackers = _attackers(entry.get("attackers"), f"{field}.attackers") or everywhere
    if attackers is None:
        raise ValueError(f"{field}.attackers: missing (and no suite-wide attackers)")
    episodes = entry.get("episodes")
    if episodes is not None:
        checks.integer(episodes, f"{field}.episodes", 1, 10_000_000)
    return [Cell(label, scenario, a, episodes) for a in attackers]


@dataclass(frozen=True)
class CellResult:
    """A cell's comparison and its episodes' mean wall time per method (seconds of one
    episode's loop in a worker: what a run of more episodes costs per episode)."""

    cell: Cell
    comparison: Comparison
    seconds_per_episode: dict[str, float]

    @property
    def one_start(self) -> bool:
        """Several episodes, all from the same start (the scenario's fixed starts)."""
        return self.comparison.summaries[0].episodes > 1 and one_start(self.cell.scenario)


@dataclass(frozen=True)
class Pooled:
    """Every cell of one attacker policy as one sample (a pooled suite: the maps of a
    library, the same number of episodes on each): each method's summary and its paired
    differences from the baseline, seed by seed within each map."""

    attackers: str
    cells: int
    summaries: tuple[CaptureSummary, ...]
    differences: tuple[PairedDifference, ...]

    def to_dict(self) -> dict[str, Any]:
        return {"attackers": self.attackers, "cells": self.cells,
                "episodes": self.summaries[0].episodes,
                "methods": [s.to_dict() for s in self.summaries],
                "differences": [d.to_dict() for d in self.differences]}


@dataclass(frozen=True)
class SuiteResult:
    """What ``run_suite`` played: one result per cell, in the suite's order, and for a
    pooled suite one ``Pooled`` per attacker policy."""

    suite: Suite
    methods: tuple[str, ...]
    baseline: str
    cells: tuple[CellResult, ...]
    pooled: tuple[Pooled, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the suite, per cell the summaries and paired differences, and one
        row per episode (``rows``, each naming its cell)."""
        cells, rows = [], []
        for result in self.cells:
            comparison = result.comparison
            cells.append({
                "cell": result.cell.label, "scenario": comparison.scenario.name,
                "attackers": result.cell.attackers,
                "episodes": comparison.summaries[0].episodes, "one_start": result.one_start,
                "seconds_per_episode": result.seconds_per_episode,
                "methods": [s.to_dict() for s in comparison.summaries],
                "differences": [d.to_dict() for d in comparison.differences]})
            rows.extend({"cell": result.cell.label, **row} for row in comparison.rows)
        return {"suite": self.suite.name, "version": self.suite.version,
                "seed": self.suite.seed, "defenders": list(self.methods),
                "baseline": self.baseline, "cells": cells,
                "pooled": [p.to_dict() for p in self.pooled], "rows": rows}


def run_suite(suite: Suite, methods: Sequence[str | Factory], episodes: int,
              baseline: str, options: Mapping[str, Any] | None = None,
              names: Mapping[str, str] | None = None, backend: str = "serial",
              workers: int | None = None, address: str | None = None,
              progress: bool = True) -> SuiteResult:
    """Play every cell of ``suite`` with every defender method on the same seeds (all on
    one pool or Ray instance) and compare each method with ``baseline``.

    ``episodes``: per cell, unless the cell fixes its own. ``options`` go to each policy
    that takes them; one that no policy of the suite takes is a ``ValueError`` (named as
    ``names[option]`` when given).
    """
    checks.integer(episodes, "episodes", 1)
    attackers = list(dict.fromkeys(cell.attackers for cell in suite.cells))
    choices = [*(("defenders", m) for m in methods), *(("attackers", a) for a in attackers)]
    specs = dict(zip(choices, policy_specs(choices, options or {}, names), strict=True))
    sweeps = []
    for cell in suite.cells:
        seeds = tuple(range(suite.seed, suite.seed + (cell.episodes or episodes)))
        sweeps.append([Sweep(cell.scenario, specs["attackers", cell.attackers],
                             specs["defenders", m], seeds) for m in methods])
    played = run_sweeps([s for group in sweeps for s in group], backend, workers=workers,
                        address=address, progress=progress, description=suite.name)
    labels = [specs["defenders", m].label for m in methods]
    results = []
    outcomes = []
    for k, (cell, group) in enumerate(zip(suite.cells, sweeps, strict=True)):
        outcome = played[k * len(methods):(k + 1) * len(methods)]
        outcomes.append(outcome)
        seconds = {label: sum(r.seconds for r in episodes_) / len(episodes_)
                   for label, episodes_ in zip(labels, outcome, strict=True)}
        results.append(CellResult(cell, compare(cell.scenario, group, outcome, baseline),
                                  seconds))
    pooled = (tuple(_pool(suite.cells, outcomes, attacker, labels, baseline)
                    for attacker in attackers) if suite.pooled else ())
    return SuiteResult(suite, tuple(labels), baseline, tuple(results), pooled)


def _pool(cells: Sequence[Cell], outcomes: Sequence[Sequence[Sequence[EpisodeResult]]],
          attackers: str, labels: Sequence[str], baseline: str) -> Pooled:
    """``attackers``' cells as one sample: each method's episodes of every such cell, in
    the cells' order (so the paired differences pair the same map and seed)."""
    chosen = [outcome for cell, outcome in zip(cells, outcomes, strict=True)
              if cell.attackers == attackers]
    merged = [[r for outcome in chosen for r in outcome[k]] for k in range(len(labels))]
    return Pooled(attackers, len(chosen), *score(labels, merged, baseline))


def plot_suite(result: SuiteResult, path: str | os.PathLike[str]) -> None:
    """Capture rate per cell and method with its 95% interval, written as a PNG through
    ``atomic_write``: one panel per attacker policy, one row per game, a marker per
    method, the episode count at the right (7 inches wide, 200 dpi: for a paper)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    games = list(dict.fromkeys(c.cell.game for c in result.cells))
    attackers = list(dict.fromkeys(c.cell.attackers for c in result.cells))
    methods = result.methods
    figure, panels = plt.subplots(1, len(attackers), sharey=True, squeeze=False,
                                  figsize=(7.0, 1.1 + 0.16 * len(games) * (len(methods) + 1)),
                                  layout="constrained")
    spread = 0.7 / len(methods)
    for axes, attacker in zip(panels[0], attackers, strict=True):
        for cell in (c for c in result.cells if c.cell.attackers == attacker):
            row = len(games) - 1 - games.index(cell.cell.game)
            for k, summary in enumerate(cell.comparison.summaries):
                y = row + (len(methods) - 1) / 2 * spread - k * spread
                low, high = summary.capture_rate_ci
                axes.errorbar([summary.capture_rate], [y], fmt="osD^vP*X"[k % 8],
                              xerr=[[summary.capture_rate - low], [high - summary.capture_rate]],
                              color=f"C{k}", markersize=3.5, capsize=1.5, linewidth=0.9,
                              label=summary.label if row == len(games) - 1 else None)
            axes.text(1.08, row, f"n={cell.comparison.summaries[0].episodes}", fontsize=6,
                      color="0.4", va="center", ha="left")
        for boundary in range(len(games) - 1):
            axes.axhline(boundary + 0.5, color="0.88", linewidth=0.5)
        axes.set_title(f"{attacker} attackers", fontsize=8)
        axes.set_xlim(-0.03, 1.27)
        axes.set_xticks([0, 0.25, 0.5, 0.75, 1.0], ["0", "25", "50", "75", "100%"])
        axes.tick_params(labelsize=7)
    panels[0][0].set_yticks(range(len(games)), games[::-1], fontsize=7)
    panels[0][0].set_ylim(-0.6, len(games) - 0.4)
    figure.supxlabel("capture rate: attackers captured per episode, mean and 95% interval",
                     fontsize=8)
    handles, labels = panels[0][0].get_legend_handles_labels()
    figure.legend(handles, labels, loc="outside upper center", ncol=len(methods), fontsize=8,
                  frameon=False, title=(f"suite {result.suite.name} v{result.suite.version}"
                                       if result.suite.version else result.suite.name),
                  title_fontsize=8)
    with atomic_write(path, "wb") as handle:
        figure.savefig(handle, dpi=200, format="png")
    plt.close(figure)

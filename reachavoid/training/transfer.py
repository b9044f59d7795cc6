"""Every trained team against every defender (``reachavoid exploit --transfer``).

A best response is trained against one defender, yet it is an attacker like any other: the
team trained against ``hj`` may be the strongest attack known against ``paper`` too. With
``--transfer``, after the runs, every finished team of the folder (``OUT/E/seed-K``) plays
every named defender ``D`` other than ``E`` on the evaluation's fresh starts, and so does
``D``'s best scripted team (the cell the paired differences are taken against; it replays
the run's own scripted episodes). Each cell is kept in ``OUT/D/against/LABEL.json`` (labels
``E-seed-K`` and ``script``) with its per-start arrived fractions, written atomically; a cell
whose file exists is skipped, so the cells, like the runs, span commands.

``defender_entry`` adds to a defender's summary its ``transfers`` (per team: the arrival
rate and the paired gain over the script with its 95% interval), the ``strongest_team``
(the label of the highest arrival rate among its own runs, the script and the transfers)
and ``known_exploitability``: the largest gain over the script of any trained team, its
own or another defender's (an upper estimate: the most of several noisy figures).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from reachavoid.evaluation import arrival_fractions, mean_interval
from reachavoid.sweep import run_tasks
from reachavoid.training.exploit import EVALUATION_FIRST_SEED, Game, play, say
from reachavoid_env.files import write_json

SCRIPT = "script"
"""The label of the defender's best scripted team among its cells."""


@dataclass(frozen=True)
class Cell:
    """``team`` (``label``: ``E-seed-K`` or ``script``) against ``defender`` on ``episodes``
    evaluation starts; its file under ``out`` (the command's folder)."""

    game: Game
    defender: str
    label: str
    team: str
    episodes: int
    out: Path

    @property
    def path(self) -> Path:
        """``OUT/DEFENDER/against/LABEL.json``: the cell is finished when it exists."""
        return self.out / self.defender / "against" / f"{self.label}.json"


def trained_teams(out: Path) -> dict[str, tuple[str, str]]:
    """Every finished run's team in ``out``: label -> (the defender it was trained
    against, its policy spec), in folder order."""
    teams = {}
    for report in sorted(out.glob("*/seed-*/report.json")):
        model = report.parent / "train" / "model.zip"
        if model.is_file():
            teams[f"{report.parent.parent.name}-{report.parent.name}"] = (
                report.parent.parent.name, f"sb3:{model}")
    return teams


def play_cell(cell: Cell) -> dict[str, Any]:
    """Play ``cell`` and write its file (the task ``run_tasks`` runs); returns its content."""
    say(f"{cell.defender}: {cell.label} on {cell.episodes} fresh starts")
    fractions = arrival_fractions(play(cell.game, cell.defender, cell.team,
                                       EVALUATION_FIRST_SEED, cell.episodes))
    content = {"defender": cell.defender, "team": cell.team, "label": cell.label,
               "seeds": [EVALUATION_FIRST_SEED, EVALUATION_FIRST_SEED + cell.episodes - 1],
               "arrival_rate": float(fractions.mean()), "arrived": fractions.tolist()}
    cell.path.parent.mkdir(exist_ok=True)
    write_json(cell.path, content)
    return content


def transfer(game: Game, defenders: dict[str, str], episodes: int, out: Path,
             backend: str = "serial", workers: int | None = None,
             address: str | None = None) -> None:
    """Play every cell not finished in ``out``: for each defender (name -> its best scripted
    team), the script and every trained team of another defender."""
    teams = trained_teams(out)
    cells = [Cell(game, defender, label, team, episodes, out)
             for defender, script in defenders.items()
             for label, team in [(SCRIPT, script)] + [(label, spec) for label, (against, spec)
                                                      in teams.items() if against != defender]]
    for _ in run_tasks(play_cell, [cell for cell in cells if not cell.path.is_file()],
                       backend, workers, address):
        pass


def defender_entry(entry: dict[str, Any], defender: str, out: Path) -> dict[str, Any]:
    """``entry`` (``exploit.defender_summary``) with the defender's finished cells in
    ``out``: ``transfers``, ``strongest_team`` and ``known_exploitability`` (module
    docstring); unchanged where the script's cell is missing."""
    folder = out / defender / "against"
    if not (folder / f"{SCRIPT}.json").is_file():
        return entry
    script = json.loads((folder / f"{SCRIPT}.json").read_text())
    transfers = {}
    for path in sorted(folder.glob("*.json")):
        cell = json.loads(path.read_text())
        if cell["label"] == SCRIPT:
            continue
        gains = [a - b for a, b in zip(cell["arrived"], script["arrived"], strict=True)]
        interval = mean_interval(gains, -1.0, 1.0)
        transfers[cell["label"]] = {
            "arrival_rate": cell["arrival_rate"],
            "minus_script": {"arrival_rate": cell["arrival_rate"] - script["arrival_rate"],
                             "ci95": [interval.low, interval.high],
                             "method": interval.method}}
    own = {f"{defender}-seed-{run['seed']}": run for run in entry["runs"]}
    rates = {SCRIPT: script["arrival_rate"],
             **{label: run["learned"]["arrival_rate"] for label, run in own.items()},
             **{label: cell["arrival_rate"] for label, cell in transfers.items()}}
    gains = {**{label: run["exploitability"] for label, run in own.items()},
             **{label: cell["minus_script"] for label, cell in transfers.items()}}
    known = max(gains, key=lambda label: gains[label]["arrival_rate"])
    return {**entry, "transfers": transfers,
            "strongest_arrival_rate": max(rates.values()),
            "strongest_team": max(rates, key=rates.__getitem__),
            "known_exploitability": {"team": known, **gains[known]}}

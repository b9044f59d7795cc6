"""``benchmarks/attacker_study.py`` reads its variants' reports (a run with a report is not
run again) and writes one figure per variant, team and set of starts."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def write_report(folder: Path, arrived: dict[str, list[int]], first_seed: int = 0) -> None:
    """A stand-in recipe report: per-episode arrivals of one attacker per team on the starts
    from ``first_seed``."""
    folder.mkdir(parents=True)
    episodes = len(next(iter(arrived.values())))
    report = {"per_episode": {team: {"arrived": values, "attackers": 1}
                              for team, values in arrived.items()},
              "evaluation": {"seeds": [first_seed, first_seed + episodes - 1]},
              "training": {"agent_steps": 1000, "cpu_seconds": 60.0}}
    (folder / "report.json").write_text(json.dumps(report))


def test_the_study_reads_every_variant_and_its_confirmation(tmp_path):
    """Variant names with a hyphen keep it in every key; the paired differences are the
    learned team's arrivals minus the script's (played once, in ``scripted``) over the same
    starts."""
    rng = np.random.default_rng(0)
    for name, teams in (("base", ["learned"]), ("easy-starts", ["learned"]),
                        ("scripted", ["shortest-path", "hj", "hj-pairs"])):
        for folder, episodes, first in ((tmp_path / name, 8, 0),
                                        (tmp_path / name / "confirm", 12, 8)):
            write_report(folder, {team: rng.integers(0, 2, episodes).tolist()
                                  for team in teams}, first)
    out = tmp_path / "study.json"
    subprocess.run([sys.executable, str(ROOT / "benchmarks" / "attacker_study.py"),
                    "--scenario", "paper_1v1", "--variants", "base,easy-starts",
                    "--runs", str(tmp_path), "--episodes", "8", "--confirm", "12",
                    "--json", str(out)], check=True, capture_output=True, cwd=ROOT)
    figures = json.loads(out.read_text())["figures"]
    arrived = {team: np.asarray(e["arrived"])
               for name in ("easy-starts", "scripted")
               for team, e in json.loads((tmp_path / name / "confirm" / "report.json")
                                         .read_text())["per_episode"].items()}
    expected = 100 * float(np.mean(arrived["learned"] - arrived["shortest-path"]))
    assert figures["confirm_minus_shortest_path_points.easy-starts"][0] == round(expected, 2)
    for key in ("arrival_percent", "minus_shortest_path_points", "minus_hj_points",
                "minus_hj_pairs_points", "confirm_arrival_percent", "confirm_minus_hj_points",
                "confirm_minus_hj_pairs_points"):
        assert f"{key}.easy-starts" in figures and f"{key}.base" in figures
    assert "minus_base_points.easy-starts" in figures
    assert "confirm_minus_base_points.easy-starts" in figures
    assert "confirm_minus_base_points.base" not in figures
    assert len(figures["confirm_arrival_percent.shortest-path"]) == 3


def test_a_run_kept_from_other_starts_is_refused_in_one_line(tmp_path):
    """A scripted run kept from a call with another ``--episodes`` is not compared with."""
    write_report(tmp_path / "base", {"learned": [1, 0, 1, 0]})
    write_report(tmp_path / "scripted", {"shortest-path": [1, 0], "hj": [0, 1],
                                                    "hj-pairs": [1, 1]})
    finished = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "attacker_study.py"),
                               "--variants", "base", "--runs", str(tmp_path),
                               "--episodes", "4"], capture_output=True, text=True, cwd=ROOT)
    assert finished.returncode == 2
    assert "scripted: played the starts 0..1, not 0..3" in finished.stderr
    assert "Traceback" not in finished.stderr

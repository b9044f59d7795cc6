"""``benchmarks/recipe_record.py`` runs the team recipe and writes its report's figures as a
result record: arrival with its interval per team, the paired differences, the cost."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = "benchmarks/recipe_record.py"   # relative to ROOT, as the record's command shows
TINY = ["--defenders", "greedy", "--teams", "learned,shortest-path", "--timesteps", "192",
        "--copies", "1", "--n-steps", "16", "--batch-size", "48", "--episodes", "3",
        "--imitate-steps", "100", "--imitate-epochs", "1", "--dagger-rounds", "1",
        "--dagger-steps", "50", "--no-video"]


def test_the_record_holds_the_recipes_figures(tmp_path):
    out = tmp_path / "record.json"
    subprocess.run([sys.executable, SCRIPT, "--json", str(out), "--", *TINY,
                    "--out", str(tmp_path / "run")], check=True, capture_output=True, cwd=ROOT)
    record = json.loads(out.read_text())
    report = json.loads((tmp_path / "run" / "report.json").read_text())
    figures, evaluation = record["figures"], report["evaluation"]
    assert record["command"].startswith("python benchmarks/recipe_record.py --json")
    shortest = evaluation["shortest-path"]
    assert figures["arrival_percent.shortest_path"] == [
        round(100 * v, 2) for v in (shortest["arrival_rate"], *shortest["arrival_rate_ci95"])]
    difference = evaluation["learned_minus_shortest_path"]
    assert figures["learned_minus_shortest_path_points"][0] == round(
        100 * difference["arrival_rate"], 2)
    rounds = [report["imitation"], *report["imitation"]["dagger"]["rounds"]]
    assert figures["cloning_wall_s"] == pytest.approx(
        sum(r["collect_seconds"] + r["fit_seconds"] for r in rounds), abs=0.05)
    assert figures["ppo_steps"] == report["training"]["agent_steps"] == 192
    assert figures["training_cpu_min"] == round(
        (report["imitation"]["cpu_seconds"] + report["training"]["cpu_seconds"]) / 60, 1)
    assert set(record["units"]) == {key.split(".")[0] for key in figures}


def test_a_bad_recipe_argument_exits_2_in_one_line(tmp_path):
    finished = subprocess.run([sys.executable, SCRIPT, "--json", str(tmp_path / "r.json"),
                               "--", "--episodes", "0", "--out", str(tmp_path / "run")],
                              capture_output=True, text=True, cwd=ROOT)
    assert finished.returncode == 2
    assert "--episodes" in finished.stderr and "Traceback" not in finished.stderr
    assert not (tmp_path / "r.json").exists()

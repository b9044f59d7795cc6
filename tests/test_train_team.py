"""The shared-policy attacker team recipe (examples/train_attacker_team.py), end to end on a
tiny budget: it trains, writes every output, evaluates three teams on the same starts, and
``--evaluate-only`` reproduces the evaluation of the saved model."""

from __future__ import annotations

import csv
import json

import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("supersuit")

from checks import example  # noqa: E402

TINY = ["--grid1", "11", "--grid2", "7", "--timesteps", "192", "--copies", "1",
        "--n-steps", "16", "--batch-size", "48", "--episodes", "3", "--video-every", "20"]


def test_recipe_trains_evaluates_and_records(tmp_path):
    recipe = example("train_attacker_team")
    report = recipe.main([*TINY, "--out", str(tmp_path)])

    assert report["defenders"] == "hj" and report["grids"] == [11, 7]
    assert report["training"]["agent_steps"] >= 192
    assert report["training"]["game_steps"] == (
        report["training"]["agent_steps"] // 6 * report["action_repeat"])
    evaluation = report["evaluation"]
    for team in ("learned", "shortest-path", "random"):
        summary = evaluation[team]
        assert summary["episodes"] == 3
        assert 0.0 <= summary["arrival_rate"] <= 1.0
        low, high = summary["arrival_rate_ci95"]
        assert 0.0 <= low <= summary["arrival_rate"] <= high <= 1.0
        assert 0.0 <= summary["mean_captured"] <= 6.0
        assert summary["mean_arrived"] + summary["mean_captured"] <= 6.0
    difference = evaluation["learned_minus_shortest_path"]
    assert difference["arrival_rate"] == pytest.approx(
        evaluation["learned"]["arrival_rate"] - evaluation["shortest-path"]["arrival_rate"])

    assert json.loads((tmp_path / "report.json").read_text()) == json.loads(
        json.dumps(report))
    with open(tmp_path / "curve.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [int(row["timesteps"]) for row in rows] == [96, 192]
    for row in rows:
        if int(row["attacker_episodes"]):
            rates = [float(row[key]) for key in ("arrived_rate", "captured_rate",
                                                 "timeout_rate")]
            assert sum(rates) == pytest.approx(1.0)
    assert (tmp_path / "curve.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert report["video"]["frames"] > 1 and (tmp_path / "learned.mp4").stat().st_size > 0

    again = recipe.main([*TINY, "--out", str(tmp_path / "again"), "--teams", "learned",
                         "--no-video", "--evaluate-only", str(tmp_path / "model.zip")])
    assert again["evaluation"]["learned"] == evaluation["learned"]
    assert "training" not in again


def test_bad_arguments_exit_2(tmp_path, capsys):
    recipe = example("train_attacker_team")
    for argv in (["--evaluate-only", str(tmp_path / "missing.zip")], ["--teams", "learnt"],
                 ["--episodes", "0"]):
        with pytest.raises(SystemExit) as stopped:
            recipe.main([*argv, "--out", str(tmp_path)])
        assert stopped.value.code == 2
    assert "--teams: unknown team 'learnt'" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []

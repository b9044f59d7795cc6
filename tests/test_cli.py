"""The reachavoid command: play with --json, summaries, videos, one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys

import imageio.v3 as iio
import pytest

from reachavoid_env import builtin_scenario, save_scenario
from reachavoid_env.cli import ATTACKER_POLICIES, DEFENDER_POLICIES, main

JSON_KEYS = ["scenario", "defenders", "attackers", "seed", "steps", "captured", "arrived",
             "captured_count", "arrived_count", "seconds", "game_time", "video"]


def play_json(capsys, *args: str) -> dict:
    assert main(["play", "--json", *args]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    return json.loads(out)


def test_play_json(capsys):
    report = play_json(capsys, "--scenario", "paper_6v2", "--seed", "2")
    assert list(report) == JSON_KEYS
    assert report["scenario"] == "paper_6v2" and report["seed"] == 2
    assert (report["attackers"], report["defenders"]) == ("straight", "greedy")
    assert report["captured_count"] == len(report["captured"])
    assert report["arrived_count"] == len(report["arrived"])
    assert set(report["captured"]) | set(report["arrived"]) <= {f"attacker_{i}"
                                                                for i in range(6)}
    assert report["steps"] >= 1 and report["video"] is None


@pytest.mark.parametrize("attackers", list(ATTACKER_POLICIES))
@pytest.mark.parametrize("defenders", list(DEFENDER_POLICIES))
def test_every_policy_choice_plays(capsys, attackers, defenders):
    report = play_json(capsys, "--scenario", "paper_2v1", "--attackers", attackers,
                       "--defenders", defenders)
    assert (report["attackers"], report["defenders"]) == (attackers, defenders)


def test_seeded_random_play_repeats(capsys):
    args = ("--scenario", "paper_6v2", "--attackers", "random", "--seed", "7")
    first, again = play_json(capsys, *args), play_json(capsys, *args)
    first.pop("seconds"), again.pop("seconds")
    assert first == again


def test_scenario_file_and_human_summary(tmp_path, capsys):
    path = tmp_path / "mine.toml"
    save_scenario(builtin_scenario("paper_2v1"), path)
    assert main(["play", "--scenario", str(path), "--defenders", "idle"]) == 0
    out, _ = capsys.readouterr()
    assert out.startswith("paper_2v1 (seed 0): idle defenders vs straight attackers")
    assert "arrived  2: attacker_0, attacker_1" in out


def test_play_writes_a_video(tmp_path, capsys):
    path = tmp_path / "out.mp4"
    report = play_json(capsys, "--scenario", "paper_2v1", "--video", str(path), "--every", "4",
                       "--width", "320")
    frames = iio.imread(path)
    assert report["video"] == str(path)
    assert len(frames) == len(range(0, report["steps"], 4)) + 1
    assert frames.shape[2] == 320


def write(tmp_path, text: str) -> str:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize(("args", "message"), [
    (["play", "--scenario", "paper_9v9"], "no such file or built-in 'paper_9v9'"),
    (["play", "--scenario", "missing.toml"], "no such file or built-in 'missing.toml'"),
    (["play", "--video", "out.avi"], "must end in one of .mp4, .gif"),
    (["play", "--video", "no/such/folder/out.mp4"], "does not exist"),
    (["play", "--attackers", "teleport"], "invalid choice: 'teleport'"),
    (["play", "--seed", "x"], "invalid int value: 'x'"),
    (["play", "--video", "a.mp4", "--every", "0"], "--every: must be a positive integer"),
    ([], "required: COMMAND"),
    (["fly"], "invalid choice: 'fly'"),
])
def test_bad_arguments_give_one_line_and_status_2(capsys, tmp_path, monkeypatch, args,
                                                  message):
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1 and message in err and err.startswith("reachavoid")
    assert not (tmp_path / "a.mp4").exists()


@pytest.mark.parametrize(("text", "message"), [
    ("[map\ndomain = 1", "malformed TOML"),
    ("[map]\ndomain = [0, 1, 0, 1]\n", "map.target: missing"),
    ("""[map]
domain = [-1.0, 1.0, -1.0, 1.0]
target = { type = "box", min = [0.6, 0.1], max = [0.8, 0.3] }
obstacles = [{ type = "box", min = [-0.1, -1.0], max = [0.1, -0.3] }]
[players]
attackers = [[0.0, -0.5]]
defenders = [[0.5, 0.5]]
""", "players.attackers[0]: (0, -0.5) lies inside obstacle 0"),
])
def test_bad_scenario_files(capsys, tmp_path, text, message):
    assert main(["play", "--scenario", write(tmp_path, text)]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and message in err


def test_help_exits_zero(capsys):
    assert main(["play", "--help"]) == 0
    out, _ = capsys.readouterr()
    assert "--attackers {straight,random}" in out and "greedy: chase" in out


def test_console_process_reports_errors_without_traceback(tmp_path):
    bad = subprocess.run([sys.executable, "-m", "reachavoid_env.cli", "play", "--scenario",
                          write(tmp_path, "[map")], capture_output=True, text=True)
    assert bad.returncode == 2
    assert "malformed TOML" in bad.stderr and "Traceback" not in bad.stderr
    good = subprocess.run([sys.executable, "-m", "reachavoid_env.cli", "play", "--json"],
                          capture_output=True, text=True)
    assert good.returncode == 0 and json.loads(good.stdout)["scenario"] == "paper_6v2"

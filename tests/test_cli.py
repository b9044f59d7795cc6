"""The reachavoid command: play with --json, summaries, videos, one-line errors, number
ranges, signals (Ctrl-C, SIGTERM, SIGHUP) and a closed pipe."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import imageio.v3 as iio
import imageio_ffmpeg
import numpy as np
import pytest
from checks import BENCH, ENV, SIMPLE, SIMPLE_2V1, command, fails_cleanly

from policies.registry import ATTACKERS, DEFENDERS, PolicySpec
from reachavoid.cli import main
from reachavoid_env import builtin_scenario, save_scenario

JSON_KEYS = ["scenario", "defenders", "attackers", "seed", "steps", "captured", "arrived",
             "captured_count", "arrived_count", "seconds", "game_time", "video"]
COARSE = ("--grid1", "21", "--grid2", "11")


def play_json(capsys, *args: str) -> dict:
    assert main(["play", "--json", *args]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    return json.loads(out)


def test_play_json(capsys):
    report = play_json(capsys, "--scenario", "paper_6v2", "--seed", "2", *SIMPLE)
    assert list(report) == JSON_KEYS
    assert report["scenario"] == "paper_6v2" and report["seed"] == 2
    assert (report["attackers"], report["defenders"]) == ("straight", "greedy")
    assert report["captured_count"] == len(report["captured"])
    assert report["arrived_count"] == len(report["arrived"])
    assert set(report["captured"]) | set(report["arrived"]) <= {f"attacker_{i}"
                                                                for i in range(6)}
    assert report["steps"] >= 1 and report["video"] is None


@pytest.mark.parametrize("attackers", list(ATTACKERS))
@pytest.mark.parametrize("defenders", list(DEFENDERS))
def test_every_policy_choice_plays(capsys, attackers, defenders):
    chosen = [PolicySpec("attackers", attackers).choice, PolicySpec("defenders", defenders).choice]
    grids = [arg for flag, value in zip(COARSE[::2], COARSE[1::2], strict=True)
             if any(choice.takes(flag[2:]) for choice in chosen) for arg in (flag, value)]
    report = play_json(capsys, "--scenario", "paper_2v1", "--attackers", attackers,
                       "--defenders", defenders, *grids)
    assert (report["attackers"], report["defenders"]) == (attackers, defenders)
    if defenders in ("hj", "hj-pairs", "paper", "matching"):
        promised = {"hj": 2, "hj-pairs": 2, "paper": 2, "matching": 1}[defenders]
        assert report["nominal_captures_initial"] == promised
        assert report["guaranteed_captures_initial"] <= promised
    else:
        assert "guaranteed_captures_initial" not in report


def test_seeded_random_play_repeats(capsys):
    args = ("--scenario", "paper_6v2", "--attackers", "random", "--defenders", "greedy",
            "--seed", "7")
    first, again = play_json(capsys, *args), play_json(capsys, *args)
    first.pop("seconds"), again.pop("seconds")
    assert first == again


def test_scenario_file_and_human_summary(tmp_path, capsys):
    path = tmp_path / "mine.toml"
    save_scenario(builtin_scenario("paper_2v1"), path)
    assert main(["play", "--scenario", str(path), "--defenders", "idle", "--attackers",
                 "straight"]) == 0
    out, _ = capsys.readouterr()
    assert out.startswith("paper_2v1: idle defenders vs straight attackers, seed 0")
    assert "arrived  2: attacker_0, attacker_1" in out


def test_play_writes_a_video(tmp_path, capsys):
    path = tmp_path / "out.mp4"
    report = play_json(capsys, "--scenario", "paper_2v1", "--video", str(path), "--every", "4",
                       "--width", "320", *SIMPLE)
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
    (["play", "--attackers", "teleport"], "--attackers: unknown policy 'teleport'"),
    (["play", "--seed", "x"], "invalid int value: 'x'"),
    (["play", "--video", "a.mp4", "--every", "0"], "--every: must be an integer in [1, 1000000]"),
    (["play", "--video", "a.mp4", "--realtime", "--fps", "10"], "--realtime: sets the fps"),
    (["play", "--video", "a.gif", "--realtime", "--every", "1"],
     "--realtime: --every 1 with 5 ms steps needs 200 fps, above this format's 50; use --every 4"),
    (["play", "--preview", "a.jpg"], "--preview: 'a.jpg' must end in .png"),
    (["play", "--preview", "a.png", "--video", "a.mp4"], "--preview: draws the first frame"),
    (["validate"], "the following arguments are required: FILE"),
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
    fails_cleanly(capsys, ["play", "--scenario", write(tmp_path, text)], message)


@pytest.mark.parametrize("command", ["play", "solve"])
def test_unreadable_scenario_file_is_status_2(capsys, tmp_path, monkeypatch, command):
    path = write(tmp_path, "")

    def refuse(self):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(type(tmp_path), "read_bytes", refuse)
    assert main([command, "--scenario", path]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"scenario: cannot read {path!r}: Permission denied" in err


def test_solve_2v1_fills_the_cache_of_its_grid1(tmp_path, new_cache, capsys):
    """``solve --grid1`` sets the 1 vs 1 tube under a 2 vs 1 game, as ``play --grid1``."""
    cache = new_cache(tmp_path / "cache")
    assert main(["solve", "--game", "2v1", "--grid", "8", "--grid1", "8"]) == 0
    solved = {tuple(path.name.split("-")[:2]) for path in cache.glob("*.vf")}
    assert solved == {("1v1", "8"), ("2v1", "8")}
    assert main(["solve", "--game", "1v1", "--grid1", "8"]) == 0
    assert "1v1 value 8x8x8x8" in capsys.readouterr().out


def test_help_exits_zero(capsys):
    assert main(["play", "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())  # help text wraps with the terminal
    assert "--attackers NAME|pkg.module:factory" in out and "greedy: chase" in out
    assert "--grid1 N" in out


def test_console_process_reports_errors_without_traceback(tmp_path):
    bad = subprocess.run([sys.executable, "-m", "reachavoid.cli", "play", "--scenario",
                          write(tmp_path, "[map")], capture_output=True, text=True)
    assert bad.returncode == 2
    assert "malformed TOML" in bad.stderr and "Traceback" not in bad.stderr
    good = subprocess.run([sys.executable, "-m", "reachavoid.cli", "play", "--json",
                           *SIMPLE], capture_output=True, text=True)
    assert good.returncode == 0 and json.loads(good.stdout)["scenario"] == "paper_6v2"


def test_bench_compares_methods_on_the_same_starts(tmp_path, capsys):
    path = tmp_path / "episodes.csv"
    args = ["bench", "--config", "3v1", "--episodes", "3", "--seed", "5", "--defenders",
            "hj,matching,greedy", "--attackers", "shortest-path", "--csv", str(path), *COARSE]
    assert main([*args, "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    [cell] = report["cells"]
    assert [m["label"] for m in cell["methods"]] == ["hj", "matching", "greedy"]
    for method in cell["methods"]:
        low, high = method["capture_rate_ci"]
        assert 0.0 <= low <= method["capture_rate"] <= high <= 1.0
        assert method["episodes"] == 3 and method["attackers"] == 3
    assert cell["methods"][0]["guaranteed_initial"] is not None
    assert cell["methods"][2]["guaranteed_initial"] is None
    assert report["baseline"] == "hj"
    assert [(d["label"], d["baseline"]) for d in cell["differences"]] == [
        ("matching", "hj"), ("greedy", "hj")]
    by_method = {m: {r["seed"]: r for r in report["rows"] if r["defenders"] == m}
                 for m in ("hj", "greedy")}
    assert sorted(by_method["hj"]) == sorted(by_method["greedy"]) == [5, 6, 7]
    paired = [(by_method["greedy"][k]["captured_count"] - by_method["hj"][k]["captured_count"])
              / 3 for k in (5, 6, 7)]
    assert cell["differences"][1]["difference"] == pytest.approx(sum(paired) / 3)
    rows = path.read_text().splitlines()
    assert len(rows) == 1 + 9 and rows[0].startswith("cell,defenders,attackers,scenario,seed")
    assert main(args) == 2   # the file exists: replaced only with --force
    assert "pass --force" in capsys.readouterr().err
    assert main([*args, "--force"]) == 0
    table = capsys.readouterr().out
    assert "capture rate [95% CI]" in table and "greedy - hj: capture rate" in table


@pytest.mark.parametrize(("args", "message"), [
    (["bench", "--config", "six"], "--config: expected MvN"),
    (["bench", "--defenders", "hj,nobody"], "--defenders: unknown policy 'nobody'"),
    (["bench", "--defenders", "greedy", "--grid1", "25"],
     "--grid1: no chosen policy takes it (greedy, shortest-path)"),
    (["play", "--defenders", "greedy", "--attackers", "straight", "--margin-cells", "1"],
     "--margin-cells: no chosen policy takes it (straight, greedy)"),
    (["play", "--margin-cells", "11"], "--margin-cells: must be in [0, 10]"),
    (["bench", "--defenders", "nowhere_module_xyz:Mine"],
     "--defenders: cannot import 'nowhere_module_xyz'"),
    (["bench", "--defenders", "json:nothing_here"], "--defenders: module 'json' has no"),
    (["bench", "--baseline", "greedy"], "--baseline: 'greedy' is not among --defenders"),
    (["bench", "--suite", "default", "--config", "2v1"], "--config: not with --suite"),
    (["bench", "--suite", "nosuchsuite"], "suite: no such file or built-in 'nosuchsuite'"),
    (["bench", "--episodes", "0"], "--episodes: must be an integer in [1, 10000000]"),
    (["play", "--grid2", "2"], "--grid2: must be an integer in [5, 101]"),
])
def test_bench_and_grid_errors(capsys, args, message):
    fails_cleanly(capsys, args, message)


def test_paper_command_writes_table_and_figure(tmp_path, capsys):
    out = tmp_path / "paper"
    assert main(["paper", "--out", str(out), "--no-video", *COARSE]) == 0
    printed = capsys.readouterr().out
    table = json.loads((out / "table.json").read_text())
    assert list(table) == ["paper_2v1", "paper_6v2", "paper_8v4"]
    assert table["paper_2v1"]["reported"] == {"paper": 2, "matching": 1}
    for row in table.values():
        assert row["paper"]["captured_count"] >= row["paper"]["guaranteed_captures_initial"] - 1
    assert (out / "tubes.png").stat().st_size > 10_000
    assert "2v1" in printed and "baseline" in printed


def test_validate_good_and_bad_files(tmp_path, capsys):
    good = tmp_path / "good.toml"
    save_scenario(builtin_scenario("paper_6v2"), good)
    assert main(["validate", str(good), "paper_2v1"]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    assert out.splitlines() == [
        f"{good}: ok (paper_6v2: 6 attackers, 2 defenders, given starts)",
        "paper_2v1: ok (paper_2v1: 2 attackers, 1 defenders, given starts)"]
    outside = write(tmp_path, '[map]\ndomain = [0, 1, 0, 1]\n'
                              'target = { type = "box", min = [0.6, 0.1], max = [0.8, 1.3] }\n')
    malformed = tmp_path / "malformed.toml"
    malformed.write_text("[map\n")
    assert main(["validate", str(good), outside, str(malformed), str(tmp_path / "no.toml")]) == 2
    out, err = capsys.readouterr()
    assert out.splitlines() == [f"{good}: ok (paper_6v2: 6 attackers, 2 defenders, given starts)"]
    lines = err.splitlines()
    assert len(lines) == 3
    assert lines[0].startswith(f"reachavoid validate: error: {outside}: map.target: extends "
                               "outside the domain")
    assert lines[1].startswith(f"reachavoid validate: error: {malformed}: malformed TOML")
    assert "no such file" in lines[2]


def test_validate_checks_every_map_of_a_library_folder(tmp_path, capsys):
    library = tmp_path / "library"
    library.mkdir()
    for name in ("paper_2v1", "paper_6v2"):
        save_scenario(builtin_scenario(name), library / f"{name}.toml")
    assert main(["validate", str(library)]) == 0
    out, err = capsys.readouterr()
    assert err == "" and out.splitlines() == [
        f"{library}: paper_2v1: ok (paper_2v1: 2 attackers, 1 defenders, given starts)",
        f"{library}: paper_6v2: ok (paper_6v2: 6 attackers, 2 defenders, given starts)"]


def test_preview_writes_the_first_frame_without_playing(tmp_path, capsys):
    preview, video = tmp_path / "first.png", tmp_path / "episode.gif"
    assert main(["play", "--scenario", "paper_6v2", *SIMPLE, "--width", "320",
                 "--preview", str(preview)]) == 0
    out, _ = capsys.readouterr()
    assert out.splitlines()[1] == f"  first frame: {preview} (320x416)"  # legend: 4 rows
    assert sorted(tmp_path.iterdir()) == [preview]  # nothing else: no episode played
    play_json(capsys, "--scenario", "paper_6v2", *SIMPLE, "--width", "320", "--video", str(video))
    drawn, first = iio.imread(preview), iio.imread(video)[0]
    assert drawn.shape == first.shape
    assert np.abs(drawn.astype(int) - first).mean() < 1.0  # the GIF's palette rounding


def test_realtime_video_lasts_the_game_time(tmp_path, capsys):
    path = tmp_path / "realtime.mp4"
    report = play_json(capsys, "--scenario", "paper_2v1", *SIMPLE, "--width", "320",
                       "--video", str(path), "--realtime")
    frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(path))
    fps = 50.0  # 5 ms steps, a frame every 4 steps
    assert frames == len(range(0, report["steps"], 4)) + 1
    # the last frame shows the end of the game at its time in the video (to one frame)
    assert abs((seconds - 1 / fps) - report["game_time"]) <= 1 / fps
    assert main(["play", "--scenario", "paper_2v1", *SIMPLE, "--video", str(path),
                 "--realtime", "--force"]) == 0
    assert "at 50 fps, real time)" in capsys.readouterr()[0]


@pytest.mark.parametrize(("signum", "status", "word"), [
    (signal.SIGTERM, 143, "terminated"), (signal.SIGHUP, 129, "hung up")])
def test_sigterm_leaves_no_partial_video(tmp_path, signum, status, word):
    env = dict(os.environ, SDL_VIDEODRIVER="dummy")
    process = subprocess.Popen([sys.executable, "-m", "reachavoid.cli", "play", "--scenario",
                                "paper_6v2", "--attackers", "random", "--defenders", "idle",
                                "--video", str(tmp_path / "long.mp4")], env=env,
                               stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not any(tmp_path.glob(".long.*")) and time.monotonic() < deadline:
        time.sleep(0.05)
    process.send_signal(signum)
    _, err = process.communicate(timeout=60)
    assert process.returncode == status and word in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("args", "message"), [
    (["play", "--seed", "-1"], "--seed: must be an integer in [0,"),
    (["bench", "--seed", "-1"], "--seed: must be an integer in [0,"),
    (["play", "--video", "a.mp4", "--fps", "inf"], "--fps: must be in [0.1, 240]"),
    (["play", "--video", "a.mp4", "--fps", "1e-300"], "--fps: must be in [0.1, 240]"),
    (["play", "--video", "a.mp4", "--width", "100000000"], "--width: must be an integer in"),
    (["play", "--grid1", "100000"], "--grid1: must be an integer in [5, 201]"),
    (["solve", "--game", "2v1", "--grid", "1000"], "--grid: must be an integer in [5, 101]"),
])
def test_numbers_out_of_range(capsys, tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    fails_cleanly(capsys, args, message)
    assert list(tmp_path.iterdir()) == []


def test_play_checks_every_tube_before_solving(cache_in_tmp, capsys):
    fails_cleanly(capsys, ["play", "--scenario", "paper_2v1", "--grid1", "15", "--grid2",
                           "101"], "2v1 HJ solve on a 101x101x101x101x101x101 grid")
    assert list(cache_in_tmp.glob("*.vf")) == []


def test_ctrl_c_while_importing_is_one_line():
    # "started" once the command's own import begins (inside main), seconds before it ends
    code = ("import sys; from reachavoid.__main__ import main\n"
            "def hook(event, args):\n"
            "    if event == 'import' and args[0] == 'reachavoid.cli':\n"
            "        print('started', flush=True)\n"
            "sys.addaudithook(hook)\n"
            f"sys.exit(main({['play', *SIMPLE_2V1]!r}))")
    process = subprocess.Popen([sys.executable, "-c", code], env=ENV, text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert process.stdout.readline() == "started\n"
    process.send_signal(signal.SIGINT)   # the command's libraries take seconds to load
    out, err = process.communicate(timeout=60)
    assert process.returncode == 130 and err == "reachavoid: interrupted\n", err


def test_a_closed_pipe_ends_quietly():
    process = command("play", *SIMPLE_2V1, stdout=subprocess.PIPE)
    process.stdout.close()
    _, err = process.communicate(timeout=120)
    assert process.returncode == 141 and err == "", err


def test_ctrl_c_to_a_process_pool_leaves_no_warnings():
    process = command(*BENCH[:-6], "--episodes", "20000", "--defenders", "greedy",
                       "--attackers", "straight", "--backend", "process", "--workers", "2",
                       start_new_session=True, stdout=subprocess.DEVNULL)
    time.sleep(12)
    os.killpg(process.pid, signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130 and err == "reachavoid bench: interrupted\n", err

"""Nothing lost, nothing silently wrong: what a hostile user tries (issue "Nothing lost").

Full-disk and read-only cases mount a small tmpfs (root only; skipped elsewhere).
"""

from __future__ import annotations

import os
import pickle
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import reachavoid_env
from reachavoid.cli import main
from reachavoid_env import ScenarioError, builtin_scenario, load_scenario, save_scenario

SIMPLE = ("--attackers", "straight", "--defenders", "greedy")


def fails_cleanly(capsys, args: list[str], message: str, status: int = 2) -> None:
    assert main(args) == status
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and message in err, err


@pytest.fixture
def small_mount(tmp_path):
    """A 256 KiB tmpfs at ``tmp_path / "disk"`` (and a read-only one at ``.../ro``)."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    disk, readonly = tmp_path / "disk", tmp_path / "ro"
    disk.mkdir(), readonly.mkdir()
    mounted = []
    for folder, options in ((disk, "size=256k"), (readonly, "size=64k,ro")):
        if subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(folder)],
                          capture_output=True).returncode != 0:
            for done in mounted:
                subprocess.run(["umount", str(done)], check=False)
            pytest.skip("cannot mount a tmpfs here")
        mounted.append(folder)
    yield disk, readonly
    for folder in mounted:
        subprocess.run(["umount", "-l", str(folder)], check=False)


# 1. solve --out never deletes what it did not write

def test_solve_out_refuses_a_folder_of_other_files(tmp_path, capsys):
    notes = tmp_path / "notes.txt"
    notes.write_text("hi")
    fails_cleanly(capsys, ["solve", "--scenario", "paper_2v1", "--grid", "9", "--out",
                           str(tmp_path)], "exists and is not a value directory")
    assert notes.read_text() == "hi"


# 2. a full disk is an error, and the partial video is removed

def test_full_disk_video_is_an_error_and_leaves_nothing(small_mount, capsys):
    disk, _ = small_mount
    (disk / "filler").write_bytes(b"x" * (200 * 1024))
    assert main(["play", "--scenario", "paper_2v1", *SIMPLE, "--video",
                 str(disk / "x.mp4")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "x.mp4" in err
    assert sorted(p.name for p in disk.iterdir()) == ["filler"]


# 3. polygons with repeated vertices are normalised, and still guard their inside

def test_polygon_repeated_vertices_are_dropped():
    ring = reachavoid_env.Polygon(((0.0, 0.0), (1.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.0, 0.0)))
    assert ring.vertices == ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0))
    inside = np.array([0.2, 0.2])
    assert ring.contains(inside) and np.isfinite(ring.signed_distance(inside))


def test_attacker_inside_a_closed_ring_polygon_is_refused(tmp_path):
    text = (Path(reachavoid_env.__file__).parent / "scenarios" / "paper_2v1.toml").read_text()
    text = text.replace('  { type = "box", min = [-0.1, 0.3], max = [0.1, 0.6] },',
                        '  { type = "polygon", vertices = [[-0.6, -0.1], [-0.4, -0.1], '
                        '[-0.4, 0.1], [-0.6, 0.1], [-0.6, -0.1]] },')
    path = tmp_path / "ring.toml"
    path.write_text(text)
    with pytest.raises(ScenarioError, match=r"players.attackers\[0\].*inside obstacle 1"):
        load_scenario(path)


@pytest.mark.parametrize(("vertices", "message"), [
    ([[0, 0], [1, 0], [2, 0]], "zero area"),
    ([[0, 0], [1, 0], [1, 1], [0, 1], [1, 0.5], [0.5, 0]], "self-intersecting"),
    ([[0, 0], [2, 0], [1, 0], [1, 1]], "self-intersecting"),
])
def test_degenerate_polygons_are_refused_by_name(vertices, message):
    with pytest.raises(reachavoid_env.ShapeError, match=rf"obstacles\[2\]: .*{message}"):
        reachavoid_env.scenario.shape_from_dict({"type": "polygon", "vertices": vertices},
                                                "obstacles[2]")


# 5. SIGTERM is Ctrl-C: a message, status 143, no partial file

@pytest.mark.parametrize(("signum", "status", "word"), [
    (signal.SIGTERM, 143, "terminated"), (signal.SIGHUP, 129, "hung up")])   # issue 21 #14
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


# 6. unwritable outputs are found before the work

def test_outputs_are_checked_before_any_work(tmp_path, capsys, monkeypatch):
    fails_cleanly(capsys, ["bench", "--config", "2v1", "--episodes", "1", "--defenders",
                           "greedy", "--csv", str(tmp_path / "nodir" / "x.csv")],
                  "--csv: folder")
    fails_cleanly(capsys, ["solve", "--plot", str(tmp_path / "nodir" / "x.png")],
                  "--plot: folder")
    a_file = tmp_path / "file"
    a_file.write_text("")
    fails_cleanly(capsys, ["paper", "--out", str(a_file)], "exists and is not a folder")
    fails_cleanly(capsys, ["play", *SIMPLE, "--video", str(tmp_path)], "must end in")
    monkeypatch.setenv("REACHAVOID_CACHE_DIR", str(a_file))
    fails_cleanly(capsys, ["play", *SIMPLE], "is not a folder")


def test_read_only_folder_is_refused_before_the_work(small_mount, capsys):
    _, readonly = small_mount
    fails_cleanly(capsys, ["play", *SIMPLE, "--video", str(readonly / "x.mp4")],
                  "is not writable")
    fails_cleanly(capsys, ["paper", "--out", str(readonly / "results")],
                  "is not a writable folder")


# 7. every number has a range

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


def scenario_text(old: str = "", new: str = "") -> str:
    """The built-in paper_2v1 file with ``old`` replaced by ``new``."""
    text = (Path(reachavoid_env.__file__).parent / "scenarios" / "paper_2v1.toml").read_text()
    return text.replace(old, new) if old else text


@pytest.mark.parametrize(("old", "new", "message"), [
    ("dt = 0.005", "dt = 1e7", "sim.dt: must be in (0, 1]"),
    ("dt = 0.005", "dt = 0.005\nplayer_radius = 1e-10", "sim.dt: 0.005 s at speed 1.5 needs"),
    ("domain = [-1.0, 1.0, -1.0, 1.0]", "domain = [-1e6, 1e6, -1.0, 1.0]",
     "map.domain[0]: must be in [-10000, 10000]"),
    ("max_steps = 1000", "max_steps = 1e9", "sim.max_steps: expected an integer"),
])
def test_scenario_numbers_out_of_range(capsys, tmp_path, old, new, message):
    path = tmp_path / "s.toml"
    path.write_text(scenario_text(old, new))
    fails_cleanly(capsys, ["play", "--scenario", str(path), *SIMPLE], message)


def test_non_utf8_scenario(capsys, tmp_path):
    path = tmp_path / "latin.toml"
    path.write_bytes(scenario_text().encode() + "# caf\xe9\n".encode("latin-1"))
    fails_cleanly(capsys, ["play", "--scenario", str(path), *SIMPLE], "not UTF-8 text")


# 8. no silent no-ops in the env

def test_step_before_reset_is_an_error():
    env = reachavoid_env.parallel_env(scenario="paper_2v1")
    with pytest.raises(RuntimeError, match="call reset"):
        env.step({})


def test_unpickled_env_must_be_reset():
    env = reachavoid_env.parallel_env(scenario="paper_2v1")
    env.reset(seed=0)
    env.step({agent: np.zeros(2, np.float32) for agent in env.agents})
    copy = pickle.loads(pickle.dumps(env))
    with pytest.raises(RuntimeError, match="unpickled env is not reset"):
        copy.step({agent: np.zeros(2, np.float32) for agent in env.agents})


def test_reset_options_are_checked():
    env = reachavoid_env.parallel_env(scenario="paper_2v1")
    with pytest.raises(ValueError, match=r"options\['starts'\] is not an option"):
        env.reset(options={"starts": [[0.0, 0.0]]})
    with pytest.raises(TypeError, match="options must be a dict"):
        env.reset(options=[1])
    env.reset(options={"options": 1})


def test_huge_actions_are_scaled_not_lost():
    scenario = builtin_scenario("paper_1v1")
    env = reachavoid_env.parallel_env(scenario=scenario)
    env.reset(seed=0)
    before = env.unwrapped.game_state().attacker_positions[0].copy()
    env.step({"attacker_0": np.array([1e200, 1e200]), "defender_0": np.zeros(2)})
    moved = env.unwrapped.game_state().attacker_positions[0] - before
    expected = scenario.attacker_speed * scenario.dt
    assert np.linalg.norm(moved) == pytest.approx(expected, rel=1e-6)
    assert moved[0] == pytest.approx(moved[1])


def test_saved_scenario_round_trips_paper_table(tmp_path):
    path = tmp_path / "p.toml"
    save_scenario(builtin_scenario("paper_6v2"), path)
    assert dict(load_scenario(path).paper_captures) == {"paper": 6, "matching": 4}

"""Nothing lost, round two (issue 21): code from shared folders, outputs that replace what
they point at, the one overwrite rule, cache entries of any kind, signals.

Cases that need root (a chown to another user, a device node, a tmpfs) run in a private
mount namespace (``unshare``) or on nodes of their own, and are skipped where the machine
refuses.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import stat
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

import reachavoid_env
from reachavoid.cli import main
from reachavoid_env import Polygon, ScenarioError, load_scenario
from reachavoid_env.files import atomic_write, private_folder
from reachavoid_env.shapes import MAX_POLYGON_VERTICES, ShapeError, _edges_meet, _first_crossing
from reachavoid_env.video import RecordEpisode
from solvers.hj import codegen, solve_1v1
from solvers.hj.cache import CacheLocationError
from solvers.hj.settings import SolverSettings
from solvers.hj.value import ValueFunctionError, load_value_function

SIMPLE = ("--scenario", "paper_2v1", "--attackers", "straight", "--defenders", "greedy")
BENCH = ("bench", "--scenario", "paper_2v1", "--config", "2v1", "--episodes", "2",
         "--defenders", "greedy", "--attackers", "straight")
LOW = SolverSettings.with_accuracy("low")
MAP = reachavoid_env.builtin_map("paper")
ENV = dict(os.environ, SDL_VIDEODRIVER="dummy", SDL_AUDIODRIVER="dummy")
ROOT = Path(__file__).resolve().parents[1]


def fails_cleanly(capsys, args: list[str], message: str, status: int = 2) -> str:
    assert main(args) == status
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and message in err, err
    return err


def needs_root() -> None:
    if os.geteuid() != 0:
        pytest.skip("needs root")


@pytest.fixture
def cache_in_tmp(tmp_path, monkeypatch):
    monkeypatch.setenv("REACHAVOID_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


# 1. generated code comes only from a folder of this user's

def test_kernel_folder_is_private_and_in_the_cache(cache_in_tmp):
    folder = codegen.kernel_dir()
    assert folder == cache_in_tmp / "kernels"
    for part in (cache_in_tmp, folder):
        status = part.lstat()
        assert stat.S_ISDIR(status.st_mode) and status.st_uid == os.geteuid()
        assert stat.S_IMODE(status.st_mode) == 0o700


def test_kernels_never_come_from_a_folder_another_user_made(tmp_path, monkeypatch, capsys):
    needs_root()
    shared = tmp_path / "shared"
    shared.mkdir(mode=0o777)
    shared.chmod(0o777)
    os.chown(shared, 65534, 65534)   # "nobody" made it first
    monkeypatch.setenv("REACHAVOID_CACHE_DIR", str(shared / "cache"))
    with pytest.raises(CacheLocationError, match=r"REACHAVOID_CACHE_DIR"):
        codegen.kernel_dir()
    fails_cleanly(capsys, ["play", *SIMPLE], "$REACHAVOID_CACHE_DIR")
    assert list(shared.iterdir()) == []


@pytest.mark.parametrize("kind", ["link", "open", "foreign"])
def test_an_unsafe_kernel_folder_is_refused(cache_in_tmp, tmp_path, kind):
    cache_in_tmp.mkdir(mode=0o700)
    kernels = cache_in_tmp / "kernels"
    if kind == "link":
        (tmp_path / "elsewhere").mkdir(mode=0o700)
        kernels.symlink_to(tmp_path / "elsewhere")
    else:
        kernels.mkdir(mode=0o700)
        if kind == "open":
            kernels.chmod(0o777)
        else:
            needs_root()
            os.chown(kernels, 65534, 65534)
    with pytest.raises(CacheLocationError, match="REACHAVOID_CACHE_DIR"):
        codegen._write_once("reachavoid_kernel_test", "x = 1\n")
    assert not (tmp_path / "elsewhere" / "reachavoid_kernel_test.py").exists()


def test_no_shared_fallback_when_home_is_unusable(tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("REACHAVOID_CACHE_DIR")
    monkeypatch.setenv("HOME", "/proc/nonexistent")
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    with pytest.raises(CacheLocationError, match="REACHAVOID_CACHE_DIR"):
        codegen.kernel_dir()
    fails_cleanly(capsys, ["play", *SIMPLE], "$REACHAVOID_CACHE_DIR")
    assert list(tmp_path.iterdir()) == []


def test_private_folder_checks_the_folders_it_creates(tmp_path):
    made = private_folder(tmp_path / "a" / "b")
    assert stat.S_IMODE((tmp_path / "a").stat().st_mode) == 0o700 and made.is_dir()
    (tmp_path / "open").mkdir()
    (tmp_path / "open").chmod(0o777)
    with pytest.raises(ValueError, match="others can write"):
        private_folder(tmp_path / "open" / "kernels")


# 2. a write lands on what the path names

def test_csv_through_a_link_writes_its_target(tmp_path, capsys):
    target, link = tmp_path / "real.csv", tmp_path / "link.csv"
    link.symlink_to(target)
    assert main([*BENCH, "--csv", str(link)]) == 0
    assert link.is_symlink() and target.read_text().startswith("cell,defenders,")


def test_video_through_a_dangling_link_writes_its_target(tmp_path, capsys):
    target, link = tmp_path / "real.mp4", tmp_path / "link.mp4"
    link.symlink_to(target)
    assert main(["play", *SIMPLE, "--video", str(link)]) == 0
    assert link.is_symlink() and target.stat().st_size > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.mp4", "real.mp4"]


def test_replacing_a_file_keeps_its_mode(tmp_path, capsys):
    path = tmp_path / "private.csv"
    path.write_text("old")
    path.chmod(0o600)
    assert main([*BENCH, "--csv", str(path), "--force"]) == 0
    assert stat.S_IMODE(path.stat().st_mode) == 0o600 and path.read_text() != "old"


def test_a_fifo_is_written_not_replaced(tmp_path, capsys):
    fifo = tmp_path / "rows.csv"
    os.mkfifo(fifo)
    received = []
    reader = threading.Thread(target=lambda: received.append(fifo.read_text()))
    reader.start()
    assert main([*BENCH, "--csv", str(fifo)]) == 0
    reader.join(timeout=60)
    assert stat.S_ISFIFO(fifo.lstat().st_mode) and received[0].startswith("cell,defenders,")


def test_a_character_device_is_written_not_replaced(tmp_path, capsys):
    needs_root()
    null = tmp_path / "null"
    os.mknod(null, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    try:
        null.write_text("probe")
    except OSError:
        pytest.skip("device nodes cannot be opened here (nodev)")
    assert main([*BENCH, "--csv", str(null)]) == 0
    assert stat.S_ISCHR(null.lstat().st_mode)
    with atomic_write(null) as handle:
        handle.write("again")
    assert stat.S_ISCHR(null.lstat().st_mode)


def test_dash_is_standard_output_for_csv(capsys):
    assert main([*BENCH, "--csv", "-"]) == 0
    out, err = capsys.readouterr()
    assert out.startswith("cell,defenders,") and out.count("\n") == 3   # header + 2 episodes
    assert "capture rate" in err
    fails_cleanly(capsys, ["play", *SIMPLE, "--video", "-"], "must end in")


def test_dev_stdout_is_written_when_it_is_a_pipe():
    process = _command(*BENCH, "--csv", "/dev/stdout", stdout=subprocess.PIPE)
    out, err = process.communicate(timeout=120)
    assert process.returncode == 0 and out.startswith("cell,defenders,"), err


# 3. braces in a path are characters

@pytest.mark.parametrize("name", ["a{1}.mp4", "b{x}.mp4", "c{.mp4", "d{episode}.mp4"])
def test_braces_in_video_paths_are_kept(tmp_path, capsys, name):
    path = tmp_path / name
    assert main(["play", *SIMPLE, "--video", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["video"] == str(path)
    assert [p.name for p in tmp_path.iterdir()] == [name]


def test_per_episode_videos_are_opt_in(tmp_path):
    env = reachavoid_env.parallel_env(scenario="paper_2v1", render_mode="rgb_array")
    with pytest.raises(ValueError, match="episode"):
        RecordEpisode(env, tmp_path / "run.gif", per_episode=True)
    assert RecordEpisode(env, tmp_path / "r{episode}.gif").episode_path(3) == str(
        tmp_path / "r{episode}.gif")


# 4. and 5. a cache entry of any kind is repaired; an edited meta.json never crashes

@pytest.mark.parametrize("kind", ["dangling link", "link", "file"])
def test_cache_entries_that_are_not_folders_are_repaired(cache_in_tmp, tmp_path, kind):
    vf = solve_1v1(MAP, grid_points=9, settings=LOW, progress=False)
    entry = Path(vf.values.filename).parent
    shutil.rmtree(entry)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "keep.txt").write_text("mine")
    if kind == "file":
        entry.write_text("junk")
    else:
        entry.symlink_to(elsewhere if kind == "link" else tmp_path / "missing")
    for _ in range(2):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            again = solve_1v1(MAP, grid_points=9, settings=LOW, progress=False)
        assert again.values.shape == vf.values.shape
    assert entry.is_dir() and not entry.is_symlink() and len(caught) == 0
    assert (elsewhere / "keep.txt").read_text() == "mine"


@pytest.mark.parametrize("edit", ["huge shape", "deep", "solver list", "not an object"])
def test_an_edited_meta_json_is_stale_not_a_crash(cache_in_tmp, edit):
    vf = solve_1v1(MAP, grid_points=9, settings=LOW, progress=False)
    meta_path = Path(vf.values.filename).parent / "meta.json"
    meta = json.loads(meta_path.read_text())
    if edit == "huge shape":
        meta["shape"] = [2000, 2000, 2000, 2000]
        meta["stored_shape"] = [2000, 2000, 2000, 2000]
        text = json.dumps(meta)
    elif edit == "solver list":
        meta["solver"] = [1]
        text = json.dumps(meta)
    else:
        text = "[" * 200_000 if edit == "deep" else "3"
    meta_path.write_text(text)
    with pytest.raises(ValueFunctionError):
        load_value_function(meta_path.parent)
    with pytest.warns(RuntimeWarning, match="solving again"):
        again = solve_1v1(MAP, grid_points=9, settings=LOW, progress=False)
    np.testing.assert_array_equal(again.values, vf.values)


def test_meta_shape_is_checked_against_the_file_before_use(tmp_path):
    vf = solve_1v1(MAP, grid_points=9, settings=LOW, cache=False, progress=False)
    path = vf.save(tmp_path / "one.vf")
    meta = json.loads((path / "meta.json").read_text())
    meta["shape"] = [2000, 2000, 2000, 2000, 3, 3]
    (path / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(ValueFunctionError, match="shape"):
        load_value_function(path)


# 6. every tube's memory is checked before any solve

def test_play_checks_every_tube_before_solving(cache_in_tmp, capsys):
    fails_cleanly(capsys, ["play", "--scenario", "paper_2v1", "--grid1", "15", "--grid2",
                           "101"], "2v1 HJ solve on a 101x101x101x101x101x101 grid")
    assert list(cache_in_tmp.glob("*.vf")) == []


# 7. deeply nested TOML; 15. a byte-order mark

def test_deeply_nested_toml_is_one_line(tmp_path, capsys):
    path = tmp_path / "deep.toml"
    path.write_text("x = " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(ScenarioError, match="nested too deeply"):
        load_scenario(path)
    fails_cleanly(capsys, ["play", "--scenario", str(path)], "nested too deeply")


def test_a_byte_order_mark_is_accepted(tmp_path):
    text = (ROOT / "reachavoid_env" / "scenarios" / "paper_2v1.toml").read_bytes()
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + text)
    assert load_scenario(path).num_attackers == 2


# 8. polygons: a vertex cap and a check that agrees with the pairwise one

def test_polygon_vertex_cap():
    angles = np.linspace(0.0, 2.0 * np.pi, MAX_POLYGON_VERTICES, endpoint=False)
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    assert len(Polygon(tuple(map(tuple, ring))).vertices) == MAX_POLYGON_VERTICES
    more = np.vstack([ring, [[0.5, 0.0]]])
    with pytest.raises(ShapeError, match=f"at most {MAX_POLYGON_VERTICES}"):
        Polygon(tuple(map(tuple, more)))


def test_vectorised_crossing_check_matches_the_pairwise_one():
    def pairwise(v):
        n = len(v)
        return next(((i, j) for i in range(n) for j in range(i + 1, n)
                     if _edges_meet(v[i], v[(i + 1) % n], v[j], v[(j + 1) % n],
                                    j == i + 1 or (i == 0 and j == n - 1))), None)

    rng = np.random.default_rng(0)
    checked = 0
    for _ in range(2000):
        v = rng.integers(0, 4, size=(rng.integers(3, 9), 2)).astype(float)
        if np.any(np.all(v == np.roll(v, -1, axis=0), axis=1)):
            continue
        assert (pairwise(v) is None) == (_first_crossing(v) is None), v.tolist()
        checked += 1
    assert checked > 1000


# 9. the cache is checked before the work

def test_a_cache_under_a_file_is_refused_before_work(tmp_path, monkeypatch, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("REACHAVOID_CACHE_DIR", str(blocker / "cache"))
    fails_cleanly(capsys, ["play", *SIMPLE], "$REACHAVOID_CACHE_DIR")


def _in_namespace(script: str, tmp_path: Path) -> subprocess.CompletedProcess:
    """Run ``script`` (bash) as root in a private mount namespace, or skip."""
    needs_root()
    if subprocess.run(["unshare", "-m", "true"], capture_output=True).returncode != 0:
        pytest.skip("no private mount namespace here")
    return subprocess.run(["unshare", "-m", "bash", "-ec", script], capture_output=True,
                          text=True, env=ENV, cwd=tmp_path, timeout=300)


def test_read_only_cache_solve_out_still_works(tmp_path):
    cache = tmp_path / "cache"
    kernels = Path(os.environ["REACHAVOID_CACHE_DIR"]) / "kernels"
    run = (f"{sys.executable} -m reachavoid solve --scenario paper_2v1 --grid 9")
    result = _in_namespace(f"""
        mount --make-rprivate /
        mkdir -p {cache} && mount -t tmpfs -o size=64m tmpfs {cache} && chmod 700 {cache}
        {'cp -a ' + str(kernels) + ' ' + str(cache) if kernels.is_dir() else 'true'}
        export REACHAVOID_CACHE_DIR={cache} PYTHONPATH={ROOT}
        {run}
        mount -o remount,ro {cache}
        {run} --out {tmp_path / 'out'}
        echo "status $?"
        {run} --grid 11 --out {tmp_path / 'out11'}
    """, tmp_path)
    assert result.returncode == 0, result.stderr
    assert "is not writable" in result.stderr and "Traceback" not in result.stderr
    assert (tmp_path / "out" / "meta.json").is_file()
    assert (tmp_path / "out11" / "meta.json").is_file()


def test_full_disk_names_the_destination(tmp_path):
    disk = tmp_path / "disk"
    code = ("import sys; from solvers.hj import solve_1v1; import reachavoid_env as r;"
            "vf = solve_1v1(r.builtin_map('paper'), grid_points=15, cache=False,"
            " progress=False)\n"
            "try: vf.save(sys.argv[1])\n"
            "except OSError as err: print(err.filename, err.strerror)\n"
            "from reachavoid_env.files import atomic_write\n"
            "try:\n"
            "    with atomic_write(sys.argv[1] + '.csv') as f: f.write('x' * 10**6)\n"
            "except OSError as err: print(err.filename, err.strerror)")
    result = _in_namespace(f"""
        mount --make-rprivate /
        mkdir -p {disk} && mount -t tmpfs -o size=64k tmpfs {disk}
        PYTHONPATH={ROOT} {sys.executable} -c "{code}" {disk / 'big.vf'}
        ls -A {disk}
    """, tmp_path)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith(str(disk / "big.vf"))
    assert lines[1].startswith(str(disk / "big.vf.csv")) and lines[2:] == []


# 11. pool size

def test_pool_size_is_capped_by_episodes_and_memory(monkeypatch):
    from reachavoid import sweep

    assert sweep.pool_size(4096, 1) == 1
    monkeypatch.setattr(sweep, "available_memory", lambda: 5 * sweep.WORKER_BYTES + 1)
    assert sweep.pool_size(4096, 100) == 5
    assert sweep.pool_size(None, 100) <= 5


# 12. one overwrite rule

def test_existing_outputs_are_replaced_only_with_force(tmp_path, capsys):
    video = tmp_path / "mine.mp4"
    video.write_bytes(b"precious")
    fails_cleanly(capsys, ["play", *SIMPLE, "--video", str(video)], "pass --force")
    assert video.read_bytes() == b"precious"
    assert main(["play", *SIMPLE, "--video", str(video), "--force"]) == 0
    assert video.read_bytes() != b"precious"


def test_paper_out_refuses_to_replace_a_users_table(tmp_path, capsys):
    (tmp_path / "table.json").write_text("my notes")
    fails_cleanly(capsys, ["paper", "--out", str(tmp_path), "--no-video"], "table.json")
    assert [p.name for p in tmp_path.iterdir()] == ["table.json"]


# 13. solve --out . and too-long names

def test_solve_out_dot_in_an_empty_folder(tmp_path, monkeypatch, capsys):
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    assert main(["solve", "--scenario", "paper_2v1", "--grid", "9", "--out", "."]) == 0
    assert sorted(p.name for p in work.iterdir()) == ["meta.json", "value.npy"]
    assert load_value_function(work).grid.shape == (9, 9, 9, 9)


def test_too_long_names_are_refused_before_work(tmp_path, capsys):
    name = "v" * 240
    fails_cleanly(capsys, ["play", *SIMPLE, "--video", str(tmp_path / f"{name}.mp4")],
                  "too long")
    fails_cleanly(capsys, ["solve", "--grid", "9", "--out", str(tmp_path / name)],
                  "too long")
    assert list(tmp_path.iterdir()) == []


# 14. signals and pipes

def _command(*args: str, **popen) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "reachavoid", *args], env=ENV,
                            stderr=subprocess.PIPE, text=True, **popen)


# (SIGHUP during a video: tests/test_failures.py, test_sigterm_leaves_no_partial_video)


def test_ctrl_c_while_importing_is_one_line():
    # "started" once the command's own import begins (inside main), seconds before it ends
    code = ("import sys; from reachavoid.__main__ import main\n"
            "def hook(event, args):\n"
            "    if event == 'import' and args[0] == 'reachavoid.cli':\n"
            "        print('started', flush=True)\n"
            "sys.addaudithook(hook)\n"
            f"sys.exit(main({['play', *SIMPLE]!r}))")
    process = subprocess.Popen([sys.executable, "-c", code], env=ENV, text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert process.stdout.readline() == "started\n"
    process.send_signal(signal.SIGINT)   # the command's libraries take seconds to load
    out, err = process.communicate(timeout=60)
    assert process.returncode == 130 and err == "reachavoid: interrupted\n", err


def test_a_closed_pipe_ends_quietly():
    process = _command("play", *SIMPLE, stdout=subprocess.PIPE)
    process.stdout.close()
    _, err = process.communicate(timeout=120)
    assert process.returncode == 141 and err == "", err


def test_ctrl_c_to_a_process_pool_leaves_no_warnings():
    process = _command(*BENCH[:-6], "--episodes", "20000", "--defenders", "greedy",
                       "--attackers", "straight", "--backend", "process", "--workers", "2",
                       start_new_session=True, stdout=subprocess.DEVNULL)
    time.sleep(12)
    os.killpg(process.pid, signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130 and err == "reachavoid bench: interrupted\n", err


# 15. actions and render before reset

def test_actions_are_refused_clearly():
    env = reachavoid_env.parallel_env(scenario="paper_2v1", render_mode="rgb_array")
    with pytest.raises(RuntimeError, match="render: call reset"):
        env.render()
    env.reset(seed=0)
    for actions in (None, [np.zeros(2)] * 3):
        with pytest.raises(TypeError, match="actions must be a dict"):
            env.step(actions)
    with pytest.raises(ValueError, match="complex"):
        env.step({agent: np.array([1 + 1j, 0.0]) for agent in env.agents})


# numba's cache of compiled (pickled) code is a folder of ours, or refused

def test_a_numba_cache_others_can_write_is_refused(tmp_path, cache_in_tmp, monkeypatch, capsys):
    shared = tmp_path / "numba"
    shared.mkdir()
    shared.chmod(0o777)
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(shared))
    fails_cleanly(capsys, ["solve", "--scenario", "paper_2v1", "--grid", "9"],
                  "$NUMBA_CACHE_DIR")
    assert list(shared.iterdir()) == []


def test_a_numba_cache_another_user_owns_is_refused(tmp_path):
    needs_root()
    shared = tmp_path / "nc"
    shared.mkdir(mode=0o700)
    os.chown(shared, 65534, 65534)
    result = subprocess.run(
        [sys.executable, "-m", "reachavoid", "solve", "--scenario", "paper_2v1", "--grid", "9"],
        capture_output=True, text=True, timeout=300, cwd=tmp_path,
        env=dict(ENV, NUMBA_CACHE_DIR=str(shared), PYTHONPATH=str(ROOT),
                 REACHAVOID_CACHE_DIR=str(tmp_path / "cache")))
    assert result.returncode == 2 and "$NUMBA_CACHE_DIR" in result.stderr, result.stderr
    assert result.stderr.count("\n") == 1 and list(shared.iterdir()) == []


def test_a_numba_config_file_cannot_point_the_cache_elsewhere(tmp_path):
    shared = tmp_path / "numba"
    shared.mkdir()
    shared.chmod(0o777)
    (tmp_path / ".numba_config.yaml").write_text(f"cache_dir: {shared}\n")
    result = subprocess.run([sys.executable, "-c", "import policies.lookups"],
                            capture_output=True, text=True, timeout=300, cwd=tmp_path,
                            env=dict(ENV, PYTHONPATH=str(ROOT)))
    assert result.returncode != 0 and "CacheLocationError" in result.stderr
    assert list(shared.iterdir()) == []


# the overwrite rule holds until the end: what appears meanwhile is kept

@pytest.mark.parametrize("flag", ["--csv", "--json", "--plot"])
def test_a_bench_output_that_appears_while_running_is_kept(tmp_path, monkeypatch, capsys,
                                                           flag):
    import reachavoid.commands as commands

    path = tmp_path / ("out.png" if flag == "--plot" else "out.txt")

    def meanwhile(*args, **kwargs):
        path.write_text("written by hand meanwhile")
        return run_suite(*args, **kwargs)

    run_suite = commands.run_suite
    monkeypatch.setattr(commands, "run_suite", meanwhile)
    err = fails_cleanly(capsys, [*BENCH, flag, str(path)], "appeared", status=1)
    assert str(path) in err and path.read_text() == "written by hand meanwhile"
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


@pytest.mark.parametrize("flag", ["--video", "--preview"])
def test_a_play_output_that_appears_while_running_is_kept(tmp_path, monkeypatch, capsys, flag):
    import reachavoid.play as play

    path = tmp_path / ("out.png" if flag == "--preview" else "out.gif")
    name = "first_frame" if flag == "--preview" else "run_episode"
    original = getattr(play, name)

    def meanwhile(*args, **kwargs):
        path.write_text("written by hand meanwhile")
        return original(*args, **kwargs)

    monkeypatch.setattr(play, name, meanwhile)
    fails_cleanly(capsys, ["play", *SIMPLE, flag, str(path)], "appeared", status=1)
    assert path.read_text() == "written by hand meanwhile"
    assert [p.name for p in tmp_path.iterdir()] == [path.name]
    path.unlink()
    monkeypatch.undo()
    assert main(["play", *SIMPLE, flag, str(path)]) == 0 and path.stat().st_size > 100


@pytest.mark.parametrize("outputs", [("--csv", "same.out", "--json", "same.out"),
                                     ("--plot", "s.png", "--json", "s.png"),
                                     ("--csv", "-", "--json")])
def test_two_outputs_on_one_path_are_refused_before_work(tmp_path, monkeypatch, capsys,
                                                         outputs):
    monkeypatch.chdir(tmp_path)
    fails_cleanly(capsys, [*BENCH, *outputs], "give each output its own file")
    assert list(tmp_path.iterdir()) == []


def test_a_failed_write_to_a_device_names_it(capsys):
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full here")
    err = fails_cleanly(capsys, [*BENCH, "--csv", "/dev/full"], "No space left", status=1)
    assert "/dev/full" in err


@pytest.mark.parametrize("action", [["0.5", "0"], [True, False], np.array([True, False]),
                                    np.array(["0.5", "0"]), "05", [1, "0"]])
def test_actions_are_real_two_vectors_only(action):
    env = reachavoid_env.parallel_env(scenario="paper_2v1")
    env.reset(seed=0)
    actions = {agent: np.zeros(2) for agent in env.agents}
    actions["attacker_0"] = action
    with pytest.raises(ValueError, match="action for attacker_0: expected a 2-vector of real"):
        env.step(actions)
    for fine in ([0.5, 0], (1, 0.0), np.array([0.5, 0], dtype=np.float32), [np.float32(1), 0]):
        actions["attacker_0"] = fine
        env.step(actions)

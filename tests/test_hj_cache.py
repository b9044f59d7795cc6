"""Where solved tubes and compiled kernels are kept (``solvers/hj/cache.py``,
``codegen.kernel_dir``, ``reachavoid_env/jit_cache.py``): folders of this user's only,
checked before any work; entries of any kind repaired; an edited ``meta.json`` solved
again, never a crash.

Cases that need root (a chown to another user, a read-only mount) run on nodes of their
own or in a private mount namespace, and are skipped where the machine refuses.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
import subprocess
import sys
import warnings
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest
from checks import ENV, ROOT, SIMPLE_2V1, fails_cleanly, in_namespace, needs_root

import reachavoid_env
from reachavoid_env import Circle, GameMap
from solvers.hj import codegen, game_1v1, solve_1v1
from solvers.hj.cache import CacheLocationError, cache_dir, cache_key
from solvers.hj.grid import Grid
from solvers.hj.schemes import SCHEMES, Scheme
from solvers.hj.settings import SolverSettings
from solvers.hj.solve import _key_parts
from solvers.hj.value import ValueFunctionError, load_value_function

LOW = SolverSettings.with_accuracy("low")
PAPER_MAP = reachavoid_env.builtin_map("paper")
MAP = GameMap((-1.0, 1.0, -1.0, 1.0), (Circle((0.5, 0.5), 0.2),))


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
    fails_cleanly(capsys, ["play", *SIMPLE_2V1], "$REACHAVOID_CACHE_DIR")
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
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)   # else the cache is there, not in HOME
    monkeypatch.setenv("HOME", "/proc/nonexistent")
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    with pytest.raises(CacheLocationError, match="REACHAVOID_CACHE_DIR"):
        codegen.kernel_dir()
    fails_cleanly(capsys, ["play", *SIMPLE_2V1], "$REACHAVOID_CACHE_DIR")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("kind", ["dangling link", "link", "file"])
def test_cache_entries_that_are_not_folders_are_repaired(cache_in_tmp, tmp_path, kind):
    vf = solve_1v1(PAPER_MAP, grid_points=9, settings=LOW, progress=False)
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
            again = solve_1v1(PAPER_MAP, grid_points=9, settings=LOW, progress=False)
        assert again.values.shape == vf.values.shape
    assert entry.is_dir() and not entry.is_symlink() and len(caught) == 0
    assert (elsewhere / "keep.txt").read_text() == "mine"


@pytest.mark.parametrize("edit", ["huge shape", "deep", "solver list", "not an object"])
def test_an_edited_meta_json_is_stale_not_a_crash(cache_in_tmp, edit):
    vf = solve_1v1(PAPER_MAP, grid_points=9, settings=LOW, progress=False)
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
        again = solve_1v1(PAPER_MAP, grid_points=9, settings=LOW, progress=False)
    np.testing.assert_array_equal(again.values, vf.values)


def test_a_cache_under_a_file_is_refused_before_work(tmp_path, monkeypatch, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("REACHAVOID_CACHE_DIR", str(blocker / "cache"))
    fails_cleanly(capsys, ["play", *SIMPLE_2V1], "$REACHAVOID_CACHE_DIR")


def test_read_only_cache_solve_out_still_works(tmp_path):
    cache = tmp_path / "cache"
    kernels = Path(os.environ["REACHAVOID_CACHE_DIR"]) / "kernels"
    run = (f"{sys.executable} -m reachavoid solve --scenario paper_2v1 --grid 9")
    result = in_namespace(f"""
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


def test_the_env_as_a_library_refuses_a_numba_cache_others_can_write(tmp_path):
    shared = tmp_path / "numba"
    shared.mkdir()
    shared.chmod(0o777)
    play = ("import reachavoid_env\n"
            "env = reachavoid_env.parallel_env(scenario='paper_2v1')\n"
            "env.reset(seed=0)\n")
    result = subprocess.run([sys.executable, "-c", play], capture_output=True, text=True,
                            timeout=300, cwd=tmp_path,
                            env=dict(ENV, NUMBA_CACHE_DIR=str(shared), PYTHONPATH=str(ROOT)))
    assert result.returncode != 0 and "CacheLocationError" in result.stderr, result.stderr
    assert "$NUMBA_CACHE_DIR" in result.stderr and list(shared.iterdir()) == []


def test_cache_reuses_and_recomputes_corrupt_entries(cache_in_tmp):
    game_map = GameMap((-1.0, 1.0, -1.0, 1.0), (Circle((0.5, 0.5), 0.2),))
    first = solve_1v1(game_map, grid_points=11, settings=LOW, progress=False)
    entries = list(cache_dir().glob("1v1-11-*.vf"))
    assert len(entries) == 1 and cache_dir() == cache_in_tmp
    assert isinstance(first.values, np.memmap)
    again = solve_1v1(game_map, grid_points=11, settings=LOW, progress=False)
    assert again.values.filename == first.values.filename
    other_radius = solve_1v1(game_map, capture_radius=0.2, grid_points=11, settings=LOW,
                             progress=False)
    assert other_radius.values.filename != first.values.filename
    expected = np.array(first.values)
    value_file = entries[0] / "value.npy"
    value_file.write_bytes(value_file.read_bytes()[:200])
    with pytest.warns(RuntimeWarning, match="solving again"):
        repaired = solve_1v1(game_map, grid_points=11, settings=LOW, progress=False)
    np.testing.assert_array_equal(repaired.values, expected)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        solve_1v1(game_map, grid_points=11, settings=LOW, progress=False)


@pytest.mark.skipif(sys.platform != "linux", reason="XDG is the Linux convention")
def test_cache_folder_follows_xdg_unless_configured(monkeypatch, tmp_path):
    monkeypatch.delenv("REACHAVOID_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_dir() == tmp_path / "xdg" / "reachavoid"
    monkeypatch.setenv("REACHAVOID_CACHE_DIR", str(tmp_path / "mine"))
    assert cache_dir() == tmp_path / "mine"


def _other_value(value: object) -> object:
    """A valid setting value unlike ``value`` (one rule per type: a new field of a new type
    fails here until it gets one)."""
    if isinstance(value, bool):
        return not value
    if isinstance(value, int):
        return value + 1
    if isinstance(value, float):
        return value / 2
    if isinstance(value, Scheme):
        return next(s for s in SCHEMES.values() if s != value)
    if value in ("red_black", "jacobi"):
        return "jacobi" if value == "red_black" else "red_black"
    raise AssertionError(f"no other value for a setting of type {type(value).__name__}")


def test_cache_key_covers_every_setting():
    game, grid = game_1v1((1.0, 1.0), 0.1), Grid((-1.0,) * 4, (1.0,) * 4, (9,) * 4)
    base = SolverSettings()

    def key(settings):
        return cache_key(_key_parts(game, MAP, grid, settings, {}))

    for field in fields(SolverSettings):
        changed = base.replace(**{field.name: _other_value(getattr(base, field.name))})
        assert key(changed) != key(base), field.name


def _entry(cache):
    (entry,) = cache.glob("1v1-9-*.vf")
    return entry


def _edit_meta(entry, **changes):
    meta = json.loads((entry / "meta.json").read_text())
    meta.update(changes)
    (entry / "meta.json").write_text(json.dumps(meta))


@pytest.mark.parametrize("damage", ["grid_max", "nan", "capture_radius", "flipped", "version"])
def test_cache_checks_what_it_reads_and_solves_again(cache_in_tmp, damage):
    first = solve_1v1(MAP, grid_points=9, settings=LOW, progress=False)
    expected = np.array(first.values)
    entry = _entry(cache_in_tmp)
    if damage == "grid_max":
        _edit_meta(entry, grid_max=[0.9, 0.9, 0.9, 0.9])
    elif damage == "capture_radius":
        _edit_meta(entry, parameters={"capture_radius": 0.2}, capture_radius=0.2)
    elif damage == "version":
        meta = json.loads((entry / "meta.json").read_text())
        _edit_meta(entry, solver=meta["solver"] | {"version": "1"})
    else:
        values = np.load(entry / "value.npy", mmap_mode="r+")
        if damage == "nan":
            values[...] = np.nan
        else:
            values.reshape(-1)[1000] = -values.reshape(-1)[1000] - 1.0
        values.flush()
        del values
    with pytest.warns(RuntimeWarning, match="solving again") as record:
        again = solve_1v1(MAP, grid_points=9, settings=LOW, progress=False)
    assert len(record) == 1
    np.testing.assert_array_equal(again.values, expected)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        solve_1v1(MAP, grid_points=9, settings=LOW, progress=False)


def test_corruption_warning_is_one_line_without_source(cache_in_tmp):
    solve_1v1(MAP, grid_points=9, settings=LOW, progress=False)
    value_file = _entry(cache_in_tmp) / "value.npy"
    value_file.write_bytes(value_file.read_bytes()[:200])
    with pytest.warns(RuntimeWarning) as record:
        solve_1v1(MAP, grid_points=9, settings=LOW, progress=False)
    (warning,) = record
    text = warnings.formatwarning(warning.message, warning.category, warning.filename,
                                  warning.lineno)
    assert text.count("\n") == 1 and "solving again" in text


def test_stale_temporaries_are_swept_by_their_lock_not_their_pid(cache_in_tmp):
    """Temporaries go when their owner's flock can be taken, whatever their PID says (a
    live owner in another PID namespace or on another node may carry any PID)."""
    cache_in_tmp.mkdir()
    owner = subprocess.Popen(
        [sys.executable, "-c", "import fcntl, sys, time; f = open(sys.argv[1], 'w'); "
         "fcntl.flock(f, fcntl.LOCK_EX); print(flush=True); time.sleep(60)",
         str(cache_in_tmp / f".1v1-9-abc.vf.{os.getpid() + 1}.held.lock")],
        stdout=subprocess.PIPE, text=True)
    try:
        owner.stdout.readline()
        live = cache_in_tmp / f".1v1-9-abc.vf.{os.getpid() + 1}.held.tmp"
        live.mkdir()
        stale = cache_in_tmp / f".1v1-9-abc.vf.{owner.pid}.gone.tmp"   # a live PID, no lock
        stale.mkdir()
        (stale / "value.npy").write_bytes(b"0" * 1000)
        (cache_in_tmp / f".1v1-9-abc.vf.{owner.pid}.gone.lock").touch()
        legacy = cache_in_tmp / ".1v1-9-abc.vf.1.old.tmp"   # no lock file: by age
        legacy.mkdir()
        os.utime(legacy, (0, 0))
        recent = cache_in_tmp / ".1v1-9-abc.vf.1.new.tmp"
        recent.mkdir()
        foreign = cache_in_tmp / "notes.tmp"
        foreign.write_text("not ours")
        solve_1v1(MAP, grid_points=9, settings=LOW, progress=False)
        left = sorted(p.name for p in cache_in_tmp.iterdir() if p.name.startswith("."))
        assert left == sorted([live.name, live.with_suffix(".lock").name, recent.name])
        assert foreign.exists()
    finally:
        owner.kill()
        owner.wait()


def test_a_solve_says_so_in_one_line_even_without_a_terminal(cache_in_tmp, capsys):
    """With progress, a solve that runs prints a line first (standard error is not a
    terminal under pytest); one loaded from the cache prints none."""
    solve_1v1(PAPER_MAP, grid_points=9, settings=LOW, progress=True)
    first = capsys.readouterr().err
    assert "1v1 HJ solve on a 9x9x9x9 grid: not in the cache, solving once" in first
    solve_1v1(PAPER_MAP, grid_points=9, settings=LOW, progress=True)
    assert "solving" not in capsys.readouterr().err


def test_a_long_solve_says_so_without_progress(cache_in_tmp, capsys, monkeypatch):
    """A grid of ``LONG_SOLVE_NODES`` nodes or more is announced even with progress off
    (the command line's setting when standard error is not a terminal)."""
    from solvers.hj import solve

    solve_1v1(PAPER_MAP, grid_points=9, settings=LOW, progress=False)
    assert capsys.readouterr().err == ""
    monkeypatch.setattr(solve, "LONG_SOLVE_NODES", 11 ** 4)
    solve_1v1(PAPER_MAP, grid_points=11, settings=LOW, progress=False)
    assert "1v1 HJ solve on a 11x11x11x11 grid: not in the cache" in capsys.readouterr().err

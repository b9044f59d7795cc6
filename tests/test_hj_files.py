"""Value files and the cache against a careful but hostile user (issue 9, items 1, 4, 5, 9)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import warnings

import numpy as np
import pytest

from reachavoid_env import Circle, GameMap, builtin_map
from solvers.hj import (
    OutputPathError,
    SolverSettings,
    ValueFunctionError,
    load_value_function,
    solve_1v1,
    solve_game,
)
from solvers.hj.cache import cache_dir

LOW = SolverSettings.with_accuracy("low")
MAP = GameMap((-1.0, 1.0, -1.0, 1.0), (Circle((0.5, 0.5), 0.2),))


@pytest.fixture()
def cache_in_tmp(tmp_path, monkeypatch):
    monkeypatch.setenv("REACHAVOID_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


@pytest.fixture(scope="module")
def small_vf():
    return solve_1v1(builtin_map("paper"), grid_points=9, settings=LOW, cache=False,
                     progress=False)


def test_out_refuses_a_folder_that_is_not_a_value_directory(cache_in_tmp, tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("hi")
    with pytest.raises(OutputPathError, match=str(mine)):
        solve_game("paper_1v1", "1v1", 9, out=str(mine), progress=False)
    assert (mine / "notes.txt").read_text() == "hi" and sorted(os.listdir(mine)) == ["notes.txt"]
    solve_game("paper_1v1", "1v1", 9, progress=False)
    entries = sorted(os.listdir(cache_in_tmp))
    with pytest.raises(OutputPathError, match="not a value directory"):
        solve_game("paper_1v1", "1v1", 9, out=str(cache_in_tmp), progress=False)
    assert sorted(os.listdir(cache_in_tmp)) == entries
    # a value directory of ours, or an empty folder, is replaced
    out = tmp_path / "out.vf"
    for _ in range(2):
        report = solve_game("paper_1v1", "1v1", 9, out=str(out), progress=False)
        assert report.path == out and sorted(os.listdir(out)) == ["meta.json", "value.npy"]
    empty = tmp_path / "empty"
    empty.mkdir()
    solve_game("paper_1v1", "1v1", 9, out=str(empty), progress=False)
    assert sorted(os.listdir(tmp_path)) == ["cache", "empty", "mine", "out.vf"]


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


def test_old_solver_version_is_never_read(small_vf, tmp_path):
    path = small_vf.save(tmp_path / "old.vf")
    meta = json.loads((path / "meta.json").read_text())
    meta["solver"]["version"] = "1"
    (path / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(ValueFunctionError, match="solver version 1"):
        load_value_function(path)


def test_stale_temporaries_of_dead_processes_are_swept(cache_in_tmp):
    cache_in_tmp.mkdir()
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    stale = cache_in_tmp / f".1v1-9-abc.vf.{dead.stdout.strip()}.x1y2.tmp"
    stale.mkdir()
    (stale / "value.npy").write_bytes(b"0" * 1000)
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        live = cache_in_tmp / f".1v1-9-abc.vf.{sleeper.pid}.z9.tmp"
        live.mkdir()
        foreign = cache_in_tmp / "notes.tmp"
        foreign.write_text("not ours")
        solve_1v1(MAP, grid_points=9, settings=LOW, progress=False)
        assert not stale.exists() and live.exists() and foreign.exists()
    finally:
        sleeper.kill()
        sleeper.wait()


def test_value_directories_get_the_umask_mode(small_vf, tmp_path):
    old = os.umask(0o022)
    try:
        path = small_vf.save(tmp_path / "mode.vf")
    finally:
        os.umask(old)
    assert path.stat().st_mode & 0o777 == 0o755


def test_save_keeps_an_identical_entry_renamed_into_place_by_another_process(
        small_vf, tmp_path, monkeypatch):
    """Another process renames its entry into place between our check and our rename."""
    theirs = small_vf.save(tmp_path / "theirs.vf")
    target = tmp_path / "entry.vf"
    real_replace = os.replace
    raced = []

    def racing_replace(source, destination):
        if str(destination) == str(target) and not raced:
            raced.append(True)
            shutil.copytree(theirs, target)
        return real_replace(source, destination)

    monkeypatch.setattr(os, "replace", racing_replace)
    assert small_vf.save(target) == target
    assert raced
    monkeypatch.undo()
    assert (target / "meta.json").read_text() == (theirs / "meta.json").read_text()
    assert sorted(os.listdir(tmp_path)) == ["entry.vf", "theirs.vf"]
    np.testing.assert_array_equal(load_value_function(target).values, small_vf.values)

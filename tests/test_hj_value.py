"""Value-function files (saved, loaded, checked against their meta.json), the solve
driver's ``--out`` and the memory guard (the on-disk cache: ``test_hj_cache.py``)."""

from __future__ import annotations

import json
import os
import shutil

import numpy as np
import pytest

from reachavoid.solve import solve_scenario
from reachavoid_env import Box, GameMap, builtin_map
from solvers.hj import (
    Grid,
    InsufficientMemoryError,
    OutputPathError,
    SolverSettings,
    ValueFunctionError,
    game_1v1,
    game_2v1,
    load_value_function,
    solve_1v1,
)
from solvers.hj.reach_avoid import check_memory, memory_needed

LOW = SolverSettings.with_accuracy("low")


@pytest.fixture(scope="module")
def small_vf():
    return solve_1v1(builtin_map("paper"), grid_points=13, settings=LOW, cache=False,
                     progress=False)


def test_fused_lookups_equal_the_separate_ones(small_vf):
    states = np.random.default_rng(0).uniform(-1.0, 1.0, (3, 5, 4))
    value, gradient = small_vf.value_and_gradient(states)
    np.testing.assert_array_equal(value, small_vf.value(states))
    np.testing.assert_array_equal(gradient, small_vf.gradient(states))
    for player in ("A", "D"):
        value, control = small_vf.value_and_control(states, player)
        np.testing.assert_array_equal(value, small_vf.value(states))
        np.testing.assert_array_equal(control, small_vf.control(states, player))
    with pytest.raises(ValueError, match="player"):
        small_vf.value_and_control(states, "B")


def test_save_load_round_trip(small_vf, tmp_path):
    path = small_vf.save(tmp_path / "one.vf")
    loaded = load_value_function(path, game_map=builtin_map("paper"))
    assert isinstance(loaded.values, np.memmap) and loaded.values.mode == "r"
    np.testing.assert_array_equal(loaded.values, small_vf.values)
    assert loaded.grid == small_vf.grid and loaded.game == "1v1"
    assert loaded.meta() == small_vf.meta()
    meta = json.loads((path / "meta.json").read_text())
    assert meta["axes"] == ["xA", "yA", "xD", "yD"] and meta["shape"] == [13] * 4
    assert meta["solver"]["iterations"] == small_vf.solver["iterations"]
    states = np.random.default_rng(0).uniform(-1, 1, (50, 4))
    np.testing.assert_array_equal(loaded.value(states), small_vf.value(states))
    # saving again over an existing directory replaces it and leaves no temporaries
    small_vf.save(path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["one.vf"]


def test_truncated_value_file_is_rejected(small_vf, tmp_path):
    path = small_vf.save(tmp_path / "cut.vf")
    data = (path / "value.npy").read_bytes()
    (path / "value.npy").write_bytes(data[:-100])
    with pytest.raises(ValueFunctionError, match="truncated"):
        load_value_function(path)


def test_wrong_shape_is_rejected(small_vf, tmp_path):
    path = small_vf.save(tmp_path / "shape.vf")
    np.save(path / "value.npy", np.zeros((13, 13, 13, 12), np.float32))
    with pytest.raises(ValueFunctionError, match="does not match meta.json shape"):
        load_value_function(path)


def test_meta_for_another_map_is_rejected(small_vf, tmp_path):
    path = small_vf.save(tmp_path / "map.vf")
    other = GameMap((-1.0, 1.0, -1.0, 1.0), (Box((0.6, 0.1), (0.8, 0.3)),))
    with pytest.raises(ValueFunctionError, match="another map"):
        load_value_function(path, game_map=other)
    (path / "meta.json").write_text("{not json")
    with pytest.raises(ValueFunctionError, match="meta.json"):
        load_value_function(path)
    with pytest.raises(ValueFunctionError, match="missing"):
        load_value_function(tmp_path / "nothing.vf")


def test_memory_guard_names_grid_and_need():
    grid = Grid.for_players((-1, 1, -1, 1), 3, 70)
    game = game_2v1((1.0, 1.5), 0.1)
    red_black, jacobi = SolverSettings(), SolverSettings(iteration="jacobi")
    na = 70**2
    half = 4 * na * (na + 1) // 2 * na
    assert half < memory_needed(game, grid, red_black) < 1.02 * half
    assert 2 * half < memory_needed(game, grid, jacobi) < 1.02 * 2 * half
    full = SolverSettings(exchange_symmetry=False)
    assert 4 * 70**6 < memory_needed(game, grid, full) < 1.02 * 4 * 70**6
    with pytest.raises(InsufficientMemoryError, match=r"70x70x70x70x70x70 grid needs about"):
        check_memory(game, grid, red_black, "2v1 HJ solve")
    check_memory(game_1v1((1.0, 1.5), 0.1), Grid.for_players((-1, 1, -1, 1), 2, 21), red_black,
                 "1v1 HJ solve")


def test_solve_scenario_reports_where_and_how(cache_in_tmp, tmp_path):
    report = solve_scenario("paper_1v1", "1v1", 11, out=str(tmp_path / "out.vf"), progress=False)
    assert report.path == tmp_path / "out.vf" and (report.path / "value.npy").is_file()
    assert report.iterations > 0 and report.converged
    text = report.summary()
    assert "iterations" in text and str(report.path) in text
    cached = solve_scenario("paper_1v1", "1v1", 11, plot=str(tmp_path / "slices.png"),
                        progress=False)
    assert cached.path.parent == cache_in_tmp
    assert (tmp_path / "slices.png").stat().st_size > 10000 and "slices" in cached.summary()
    with pytest.raises(ValueError, match="game"):
        solve_scenario("paper_1v1", "3v1", 11, progress=False)


def test_settings_validate_and_presets():
    assert SolverSettings.with_accuracy("high").tolerance < SolverSettings().tolerance
    assert SolverSettings.with_accuracy("low").tolerance > SolverSettings().tolerance
    with pytest.raises(ValueError, match="cfl"):
        SolverSettings(cfl=1.5)
    with pytest.raises(ValueError, match="scheme"):
        SolverSettings(scheme="weno")
    with pytest.raises(ValueError, match="accuracy"):
        SolverSettings.with_accuracy("extreme")  # type: ignore[arg-type]


def test_out_refuses_a_folder_that_is_not_a_value_directory(cache_in_tmp, tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("hi")
    with pytest.raises(OutputPathError, match=str(mine)):
        solve_scenario("paper_1v1", "1v1", 9, out=str(mine), progress=False)
    assert (mine / "notes.txt").read_text() == "hi" and sorted(os.listdir(mine)) == ["notes.txt"]
    solve_scenario("paper_1v1", "1v1", 9, progress=False)
    entries = sorted(os.listdir(cache_in_tmp))
    with pytest.raises(OutputPathError, match="not a value directory"):
        solve_scenario("paper_1v1", "1v1", 9, out=str(cache_in_tmp), progress=False)
    assert sorted(os.listdir(cache_in_tmp)) == entries
    # a value directory of ours, or an empty folder, is replaced
    out = tmp_path / "out.vf"
    for _ in range(2):
        report = solve_scenario("paper_1v1", "1v1", 9, out=str(out), progress=False)
        assert report.path == out and sorted(os.listdir(out)) == ["meta.json", "value.npy"]
    empty = tmp_path / "empty"
    empty.mkdir()
    solve_scenario("paper_1v1", "1v1", 9, out=str(empty), progress=False)
    assert sorted(os.listdir(tmp_path)) == ["cache", "empty", "mine", "out.vf"]


def test_old_solver_version_is_never_read(small_vf, tmp_path):
    path = small_vf.save(tmp_path / "old.vf")
    meta = json.loads((path / "meta.json").read_text())
    meta["solver"]["version"] = "1"
    (path / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(ValueFunctionError, match="solver version 1"):
        load_value_function(path)


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


def test_meta_shape_is_checked_against_the_file_before_use(tmp_path):
    vf = solve_1v1(builtin_map("paper"), grid_points=9, settings=LOW, cache=False,
                   progress=False)
    path = vf.save(tmp_path / "one.vf")
    meta = json.loads((path / "meta.json").read_text())
    meta["shape"] = [2000, 2000, 2000, 2000, 3, 3]
    (path / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(ValueFunctionError, match="shape"):
        load_value_function(path)

"""Value-function files, the on-disk cache and the memory guard."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from reachavoid_env import Box, Circle, GameMap, builtin_map
from solvers.hj import (
    Grid,
    InsufficientMemoryError,
    SolverSettings,
    ValueFunctionError,
    load_value_function,
    game_1v1,
    game_2v1,
    solve_1v1,
    solve_game,
)
from solvers.hj.cache import cache_dir
from solvers.hj.reach_avoid import check_memory, memory_needed

LOW = SolverSettings.with_accuracy("low")


@pytest.fixture()
def cache_in_tmp(tmp_path, monkeypatch):
    monkeypatch.setenv("REACHAVOID_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


@pytest.fixture(scope="module")
def small_vf():
    return solve_1v1(builtin_map("paper"), grid_points=13, settings=LOW, cache=False,
                     progress=False)


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


def test_memory_guard_names_grid_and_need():
    grid = Grid.for_players((-1, 1, -1, 1), 3, 70)
    game = game_2v1((1.0, 1.5), 0.1)
    red_black, jacobi = SolverSettings(), SolverSettings(iteration="jacobi")
    na = 70**2
    half = 4 * na * (na + 1) // 2 * na
    assert half < memory_needed(game, grid, red_black) < 1.01 * half
    assert 2 * half < memory_needed(game, grid, jacobi) < 1.01 * 2 * half
    full = SolverSettings(exchange_symmetry=False)
    assert 4 * 70**6 < memory_needed(game, grid, full) < 1.01 * 4 * 70**6
    with pytest.raises(InsufficientMemoryError, match=r"70x70x70x70x70x70 grid needs about"):
        check_memory(game, grid, red_black, "2v1 HJ solve")
    check_memory(game_1v1((1.0, 1.5), 0.1), Grid.for_players((-1, 1, -1, 1), 2, 21), red_black,
                 "1v1 HJ solve")


def test_solve_game_reports_where_and_how(cache_in_tmp, tmp_path):
    report = solve_game("paper_1v1", "1v1", 11, out=str(tmp_path / "out.vf"), progress=False)
    assert report.path == tmp_path / "out.vf" and (report.path / "value.npy").is_file()
    assert report.iterations > 0 and report.converged
    text = report.summary()
    assert "iterations" in text and str(report.path) in text
    cached = solve_game("paper_1v1", "1v1", 11, plot=str(tmp_path / "slices.png"),
                        progress=False)
    assert cached.path.parent == cache_in_tmp
    assert (tmp_path / "slices.png").stat().st_size > 10000 and "slices" in cached.summary()
    with pytest.raises(ValueError, match="game"):
        solve_game("paper_1v1", "3v1", 11, progress=False)


def test_settings_validate_and_presets():
    assert SolverSettings.with_accuracy("high").tolerance < SolverSettings().tolerance
    assert SolverSettings.with_accuracy("low").tolerance > SolverSettings().tolerance
    with pytest.raises(ValueError, match="cfl"):
        SolverSettings(cfl=1.5)
    with pytest.raises(ValueError, match="scheme"):
        SolverSettings(scheme="weno")
    with pytest.raises(ValueError, match="accuracy"):
        SolverSettings.with_accuracy("extreme")  # type: ignore[arg-type]

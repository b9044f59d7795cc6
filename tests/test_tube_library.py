"""Tube libraries: every tube named defenders need on every map of a library, solved on the
sweep backends (reachavoid/solve.py, `reachavoid solve --defenders`)."""

from __future__ import annotations

import numpy as np
import pytest

from reachavoid import solve as solve_module
from reachavoid.cli import main
from reachavoid.solve import solve_library
from reachavoid_env.maps import MapOptions, load_library, write_library

GRID1, GRID2 = 9, 7   # grids that see every map's target (seed 6)


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    folder = tmp_path_factory.mktemp("library")
    write_library(folder, MapOptions(obstacles=(1, 2), shapes=("box", "circle"),
                                     density=(0.0, 0.3)), 6, 3)
    return load_library(folder)


def _values(rows):
    return {(row.map, row.game): np.load(row.path / "value.npy") for row in rows}


def _solve(library, backend, **kwargs):
    """``solve_library`` into the cache of the moment (``new_cache``)."""
    return solve_library(library, ["hj"], GRID1, GRID2, backend=backend, **kwargs)


def test_a_library_solves_the_same_on_the_process_pool_as_serially(tmp_path, new_cache,
                                                                   library):
    new_cache(tmp_path / "serial")
    serial = _solve(library, "serial")
    assert [(row.map, row.game, row.grid) for row in serial] == [
        (sc.name, game, grid) for sc in library for game, grid in (("1v1", GRID1),
                                                                  ("2v1", GRID2))]
    assert all(row.seconds is not None and row.peak_bytes > 0 for row in serial)
    new_cache(tmp_path / "pool")
    pooled = _solve(library, "process", workers=2)
    assert [(row.map, row.game) for row in pooled] == [(row.map, row.game) for row in serial]
    expected, got = _values(serial), _values(pooled)
    assert all(np.array_equal(expected[key], got[key]) for key in expected)
    # Resumes: what the cache holds is loaded, not solved again.
    again = _solve(library, "serial")
    assert [row.seconds for row in again] == [None] * len(serial)


def test_a_library_solves_the_same_on_ray(tmp_path, new_cache, library):
    pytest.importorskip("ray")
    new_cache(tmp_path / "serial")
    serial = _values(_solve(library, "serial"))
    new_cache(tmp_path / "ray")
    on_ray = _values(_solve(library, "ray", workers=2))
    assert serial.keys() == on_ray.keys()
    assert all(np.array_equal(serial[key], on_ray[key]) for key in serial)


def test_workers_that_cannot_fit_are_refused_before_any_work(tmp_path, monkeypatch, library,
                                                             capsys):
    monkeypatch.setenv("REACHAVOID_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(solve_module, "available_memory", lambda: 500 << 20)
    with pytest.raises(ValueError, match=r"^workers: 4 concurrent solves need about"):
        solve_library(library, ["hj"], GRID1, GRID2, backend="process", workers=4)
    assert main(["solve", "--scenario", "paper_2v1", "--defenders", "hj",
                 "--backend", "process", "--workers", "4"]) == 2
    assert capsys.readouterr().err.startswith("reachavoid solve: error: --workers: 4 concurrent")
    assert not list((tmp_path / "cache").glob("*.vf"))   # checked, nothing solved


def test_cli_solve_of_a_library_prints_the_table(tmp_path, monkeypatch, capsys, library):
    monkeypatch.setenv("REACHAVOID_CACHE_DIR", str(tmp_path / "cache"))
    folder = tmp_path / "maps"
    write_library(folder, MapOptions(obstacles=(1, 1), shapes=("box",)), 5, 2)
    args = ["solve", "--scenario", str(folder), "--defenders", "matching", "--grid1", "8"]
    assert main(args) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split() == ["map", "game", "grid", "seconds", "peak", "MiB"]
    assert [line.split()[:3] for line in out[1:3]] == [["gen-s5-0000", "1v1", "8"],
                                                      ["gen-s5-0001", "1v1", "8"]]
    assert out[-1].startswith("2 tubes on 2 maps: 2 solved, 0 from the cache")
    assert main(args) == 0
    assert capsys.readouterr().out.splitlines()[-1].startswith("2 tubes on 2 maps: 0 solved")
    assert main(["solve", "--scenario", str(folder), "paper_2v1"]) == 2
    assert "several scenarios need --defenders" in capsys.readouterr().err

"""Sweeps give the same results for the same seeds on every backend."""

from __future__ import annotations

import json
from dataclasses import asdict

import pytest
from test_bench import POLICY_MODULE, bench_json, check_rows

from reachavoid.cli import main
from reachavoid.sweep import run_sweep, sweep_of
from reachavoid_env import builtin_scenario

COARSE = {"grid1": 21, "grid2": 11}
SCENARIO = builtin_scenario("paper_2v1").with_players(3, 1)


def outcomes(results) -> list[dict]:
    """Everything an episode result says except its wall-clock time."""
    return [{k: v for k, v in asdict(r).items() if k != "seconds"} for r in results]


def test_serial_results_do_not_depend_on_order_or_batching():
    sweep = sweep_of(SCENARIO, "hj", "random", range(4), **COARSE)
    backwards = sweep_of(SCENARIO, "hj", "random", range(3, -1, -1), **COARSE)
    assert outcomes(run_sweep(sweep)) == outcomes(run_sweep(backwards))[::-1]
    assert [r.seed for r in run_sweep(sweep)] == [0, 1, 2, 3]


def test_process_pool_matches_serial():
    sweep = sweep_of(SCENARIO, "hj", "random", range(4), **COARSE)
    serial = run_sweep(sweep)
    assert len({r.captured for r in serial} | {r.arrived for r in serial}) > 1
    assert outcomes(run_sweep(sweep, "process", workers=2)) == outcomes(serial)


def test_unknown_backend():
    with pytest.raises(ValueError, match="backend: expected one of serial, process, ray"):
        run_sweep(sweep_of(SCENARIO, "greedy", "straight", [0]), "dask")


def bench(capsys, *extra: str) -> dict:
    assert main(["bench", "--config", "3v1", "--episodes", "4", "--seed", "3", "--defenders",
                 "hj,greedy", "--attackers", "random", "--grid1", "21", "--grid2", "11",
                 "--json", *extra]) == 0
    return json.loads(capsys.readouterr().out)


def without_times(report: dict) -> dict:
    return report | {"wall_seconds": None,
                     "rows": [{k: v for k, v in r.items() if k != "seconds"}
                              for r in report["rows"]],
                     "cells": [c | {"seconds_per_episode": None} for c in report["cells"]]}


def test_bench_on_ray_matches_serial(capsys):
    pytest.importorskip("ray")
    serial = bench(capsys)
    assert without_times(bench(capsys, "--backend", "ray", "--workers", "2")) == \
        without_times(serial)


def test_policy_module_of_ones_own_on_ray(tmp_path):
    """Ray workers import ``tmpmod`` themselves (from ``PYTHONPATH``)."""
    pytest.importorskip("ray")
    (tmp_path / "tmpmod.py").write_text(POLICY_MODULE)
    check_rows(bench_json(tmp_path, "--backend", "ray", "--workers", "2"))


def test_address_needs_ray_backend(capsys):
    assert main(["bench", "--address", "auto"]) == 2
    assert "--address: only with --backend ray" in capsys.readouterr().err

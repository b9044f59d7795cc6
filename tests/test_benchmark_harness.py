"""``benchmarks/harness.py``, the speed benchmarks' one timing loop and one way to compare
with another checkout: rates with their spread, side-by-side rounds, a revision unpacked
and a benchmark function run there in a fresh process."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import harness  # noqa: E402


def test_timed_keeps_every_round_and_subtracts_the_untimed_seconds():
    ticks = iter(range(100))
    timing = harness.timed(lambda: 10, 3, clock=lambda: float(next(ticks)) * 2, warmup=2,
                           untimed=lambda: 1.0)
    assert timing.counts == (10.0, 10.0, 10.0)
    assert timing.seconds == (1.0, 1.0, 1.0)        # two ticks of 2 s a round, less 1 s
    assert timing.spread() == [10.0, 10.0, 10.0] and timing.best == 10.0
    assert timing.ms(50) == pytest.approx(100.0)
    assert len(timing.wall_seconds) == 3


def test_a_work_returning_none_did_one_unit_and_once_keeps_the_result():
    assert harness.timed(lambda: None).counts == (1.0,)
    result, seconds = harness.once(lambda: "done")
    assert result == "done" and seconds >= 0.0


def test_alternate_times_the_works_in_turn():
    order = []
    runs = harness.alternate({"a": lambda: order.append("a"), "b": lambda: order.append("b")},
                             rounds=2, warmup=1)
    assert order == ["a", "b", "a", "b", "a", "b"]
    assert {label: len(t.counts) for label, t in runs.items()} == {"a": 2, "b": 2}


def test_spread_is_median_lowest_highest():
    assert harness.spread([3.0, 1.0, 2.0, 10.0]) == [2.5, 1.0, 10.0]


def test_a_revision_is_unpacked_and_a_job_runs_there_side_by_side():
    with harness.checkout("HEAD") as tree:
        assert (tree / "benchmarks" / "harness.py").exists() and not (tree / ".git").exists()
        jobs = {"there": harness.Job(tree, "harness:spread", ([1.0, 3.0],)),
                "here": harness.Job(harness.ROOT, "harness:spread", ([2.0],))}
        assert harness.side_by_side(jobs, rounds=1) == {"there": [[2.0, 1.0, 3.0]],
                                                         "here": [[2.0, 2.0, 2.0]]}
    assert not tree.exists()
    with harness.checkout(ROOT) as same:
        assert same == ROOT


def test_nothing_in_benchmarks_imports_from_tests():
    for script in sorted((ROOT / "benchmarks").rglob("*.py")):
        text = script.read_text()
        assert "from tests" not in text and "import tests" not in text, script.name

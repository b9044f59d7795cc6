"""The speed benchmarks' one timing loop and one way to compare with another checkout.

**Timing** (``timed``, ``alternate``, ``once``): a unit of work is a function that does one round
and returns how much it did (steps, frames, decisions); the harness times each round on a
clock (``CPU``, this process's CPU time, by default: on a shared machine the steadier
figure; ``WALL`` where the work waits on other processes) and keeps every round's count
and seconds (``Timing``): rates per second with their median, spread ``[median, lowest,
highest]`` and best, and per-unit milliseconds at any percentile. ``alternate`` times
several works side by side, one round of each in turn, so the machine's drift hits all
alike; ``once`` times one call (a solve, a process, a decision) and keeps its result.

**Other checkouts** (``checkout``, ``Job``, ``side_by_side``): ``checkout(REV)`` gives the
tree of another commit, unpacked (``git archive``) into a temporary folder that is
removed afterwards, or an existing folder (a ``git worktree``) as it is. A ``Job`` runs a
benchmark function (``"module:function"`` of a script in ``benchmarks/``, JSON arguments
and result) in a fresh Python process with a tree first on the path, so only the library
code differs, never the harness; ``side_by_side`` runs jobs in alternating rounds (A, B,
A, B, ...)::

    with checkout("main") as base:
        rates = side_by_side({"before": Job(base, "single_view:single_view_rate", (3000, 300)),
                              "after": Job(ROOT, "single_view:single_view_rate", (3000, 300))},
                             rounds=3)

A function a job runs in an older tree must use only names that tree has.

The speed benchmarks run on this harness; the studies (``paper_table.py``,
``defenders.py``, ``guarantee*.py``, ``attacker_*.py``, ``tube_library.py``,
``hj_schemes.py``, ``bench_record.py``, ``recipe_record.py``, ``exploit_record.py``,
``readme_frame.py``)
measure play, not speed, and keep their own loops (``docs/benchmarking.md``).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

BENCHMARKS = Path(__file__).resolve().parent
ROOT = BENCHMARKS.parent
"""This checkout: its ``benchmarks/`` runs every job, whichever tree the job times."""

T = TypeVar("T")

CPU: Callable[[], float] = time.process_time
WALL: Callable[[], float] = time.perf_counter


def spread(values: Sequence[float]) -> list[float]:
    """``[median, lowest, highest]``: a figure with its range over the rounds (the form of a
    result file's value with its interval)."""
    return [statistics.median(values), min(values), max(values)]


@dataclass(frozen=True)
class Timing:
    """Every timed round: how much it did (``counts``) in how many ``seconds`` of the
    timing's clock, and of the wall clock (``wall_seconds``, the same where that is the
    clock; the rates and ``ms`` read ``seconds``)."""

    counts: tuple[float, ...]
    seconds: tuple[float, ...]
    wall_seconds: tuple[float, ...]

    @property
    def rates(self) -> list[float]:
        """Units per second, round by round."""
        return [count / seconds for count, seconds in zip(self.counts, self.seconds,
                                                          strict=True)]

    @property
    def median(self) -> float:
        """The median rate over the rounds."""
        return statistics.median(self.rates)

    @property
    def best(self) -> float:
        """The highest rate: the least disturbed round."""
        return max(self.rates)

    def spread(self) -> list[float]:
        """``[median, lowest, highest]`` rate over the rounds."""
        return spread(self.rates)

    def ms(self, percentile: float = 50.0, wall: bool = False) -> float:
        """Milliseconds per unit at ``percentile`` over the rounds (a latency), of the
        timing's clock or (``wall``) the wall clock."""
        seconds = self.wall_seconds if wall else self.seconds
        return float(np.percentile([1e3 * s / c for c, s in zip(self.counts, seconds,
                                                                strict=True)], percentile))

    def line(self, label: str, unit: str = "/s") -> str:
        """One printed row: the median rate, its range and the rounds."""
        median, low, high = self.spread()
        return (f"{label:<50} median {median:>10,.0f}{unit} ({low:,.0f}-{high:,.0f}, "
                f"{len(self.counts)} rounds)")

    def __add__(self, other: Timing) -> Timing:
        return Timing(self.counts + other.counts, self.seconds + other.seconds,
                      self.wall_seconds + other.wall_seconds)


def timed(work: Callable[[], float | None], rounds: int = 1, *,
          clock: Callable[[], float] = CPU, warmup: int = 0,
          untimed: Callable[[], float] | None = None) -> Timing:
    """``rounds`` timed calls of ``work`` (which returns the units it did, None for one)
    after ``warmup`` untimed ones. ``untimed``, read after each round, gives the seconds of
    that round not to count on ``clock`` (work timed inside it, e.g. a scripted side's own
    decisions)."""
    for _ in range(warmup):
        work()
    counts, seconds, wall = [], [], []
    for _ in range(rounds):
        start, wall_start = clock(), WALL()
        count = work()
        spent, wall_spent = clock() - start, WALL() - wall_start
        counts.append(1.0 if count is None else float(count))
        seconds.append(spent - (untimed() if untimed is not None else 0.0))
        wall.append(wall_spent)
    return Timing(tuple(counts), tuple(seconds), tuple(wall))


def once(call: Callable[[], T], clock: Callable[[], float] = WALL) -> tuple[T, float]:
    """``call()``'s result and its seconds on ``clock`` (one round of ``timed``): a solve,
    a process, a sweep timed once."""
    kept: list[T] = []
    seconds = timed(lambda: kept.append(call()), clock=clock).seconds[0]
    return kept[0], seconds


def alternate(works: Mapping[str, Callable[[], float | None]], rounds: int, *,
              clock: Callable[[], float] = CPU, warmup: int = 0,
              untimed: Callable[[], float] | None = None) -> dict[str, Timing]:
    """Each of ``works`` timed ``rounds`` times side by side (one round of each in turn),
    after ``warmup`` untimed rounds of each; by label."""
    for work in works.values():
        timed(work, 0, warmup=warmup)
    runs = {label: Timing((), (), ()) for label in works}
    for _ in range(rounds):
        for label, work in works.items():
            runs[label] += timed(work, clock=clock, untimed=untimed)
    return runs


def commit_of(tree: str | os.PathLike[str]) -> str | None:
    """The commit of a checkout folder, short (``+dirty`` with uncommitted changes), or of
    a revision of this repository; None where git cannot say."""
    folder = Path(tree)
    where, rev = (folder, "HEAD") if folder.is_dir() else (ROOT, str(tree))
    try:
        head = subprocess.run(["git", "-C", str(where), "rev-parse", "--short", rev],
                              check=True, capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(where), "status", "--porcelain",
                                "--untracked-files=no"], check=True, capture_output=True,
                               text=True).stdout.strip() if folder.is_dir() else ""
    except (OSError, subprocess.CalledProcessError):
        return None
    return head + ("+dirty" if dirty else "")


@contextlib.contextmanager
def checkout(rev: str | os.PathLike[str]) -> Iterator[Path]:
    """The tree of ``rev``: an existing folder as it is, else that revision of this
    repository unpacked into a temporary folder, removed on exit."""
    if Path(rev).is_dir():
        yield Path(rev).resolve()
        return
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", str(rev)],
                             check=True, capture_output=True).stdout
    with tempfile.TemporaryDirectory(prefix="reachavoid-checkout-") as folder:
        with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
            tar.extractall(folder, filter="data")
        yield Path(folder)


@dataclass(frozen=True)
class Job:
    """A benchmark function run in a fresh process with ``tree`` first on the path."""

    tree: Path
    function: str
    """``"module:function"`` of a script in this checkout's ``benchmarks/``."""
    args: tuple[Any, ...] = ()
    kwargs: Mapping[str, Any] = field(default_factory=dict)
    env: Mapping[str, str] = field(default_factory=dict)
    """Variables set for the process beside ``PYTHONPATH``."""

    def run(self) -> Any:
        """The function's result (JSON), from a fresh process in ``tree``; its printing goes
        to this process's standard error."""
        module, name = self.function.split(":")
        with tempfile.TemporaryDirectory() as scratch:
            out = Path(scratch) / "result.json"
            code = ("import json, sys\n"
                    f"sys.path.append({str(BENCHMARKS)!r})\n"
                    f"from {module} import {name}\n"
                    "args, kwargs = json.loads(sys.argv[1])\n"
                    f"result = {name}(*args, **kwargs)\n"
                    "open(sys.argv[2], 'w').write(json.dumps(result))\n")
            subprocess.run([sys.executable, "-c", code,
                            json.dumps([list(self.args), dict(self.kwargs)]), str(out)],
                           cwd=self.tree, check=True, stdout=2,
                           env=dict(os.environ, PYTHONPATH=str(self.tree), **self.env))
            return json.loads(out.read_text())


def training_views() -> Any:
    """The module of the training views' factories (``make_attackers_vector_env``,
    ``make_attackers_parallel_env``, ``attacker_factory``, ``defender_factory``) in the tree
    first on the path: ``reachavoid.training.views``, or ``policies.training`` in a tree
    from before they moved (2026-12-07), so that a job runs in either."""
    import importlib

    try:
        return importlib.import_module("reachavoid.training.views")
    except ModuleNotFoundError:
        return importlib.import_module("policies.training")


def side_by_side(jobs: Mapping[str, Job], rounds: int) -> dict[str, list[Any]]:
    """Every job run ``rounds`` times, in alternating rounds; results by label."""
    results: dict[str, list[Any]] = {label: [] for label in jobs}
    for round_ in range(rounds):
        load = os.getloadavg()[0]
        for label, job in jobs.items():
            results[label].append(job.run())
        print(f"round {round_ + 1}/{rounds} done ({', '.join(jobs)}), load average at start "
              f"{load:.2f}", file=sys.stderr, flush=True)
    return results

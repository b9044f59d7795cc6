"""The test suite's wall time as CI runs it on a fresh machine, side by side with an
earlier commit's suite as its CI ran it.

Each commit is cloned fresh from this repository, as CI clones it (``clean_clone``: no
compiled numba cache comes with it, and the tests that need a git checkout have one), and
runs its own ``tests/`` with this environment's Python, an empty ``$XDG_CACHE_HOME`` (no
kernels compiled before) and its own pytest flags, one after the other
(``--rounds`` alternates them); the figures are the wall time of the pytest process
(``harness.once``) and how many tests passed and failed (a failure of the earlier
commit's is reported, not fatal: 42401d9's no-fallback cache test fails wherever
``$XDG_CACHE_HOME`` is set; this checkout's must all pass). By default the base is
42401d9, serial (its CI), and this checkout runs with ``-n auto`` (pytest-xdist, one
worker per core: CI now):

    python benchmarks/suite_time.py --json benchmarks/results/suite_time.json
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import shlex
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

from harness import ROOT, WALL, commit_of, once
from result_file import write_result


class Run(NamedTuple):
    """One pytest run: its wall seconds and the tests that passed and failed."""

    seconds: float
    passed: int
    failed: int


@contextlib.contextmanager
def clean_clone(rev: str) -> Iterator[Path]:
    """A fresh ``git clone`` of this repository at ``rev`` (detached) in a temporary folder,
    removed on exit."""
    with tempfile.TemporaryDirectory(prefix="reachavoid-suite-") as folder:
        tree = Path(folder, "tree")
        commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", rev], check=True,
                                capture_output=True, text=True).stdout.strip()
        subprocess.run(["git", "clone", "--quiet", str(ROOT), str(tree)], check=True)
        subprocess.run(["git", "-C", str(tree), "checkout", "--quiet", "--detach", commit],
                       check=True)
        yield tree


def suite_wall(tree: Path, flags: list[str]) -> Run:
    """``pytest -q -p no:cacheprovider FLAGS`` in ``tree``, that tree first on the path and
    an empty ``$XDG_CACHE_HOME`` (its failures printed); exits with pytest's last lines
    where nothing passed."""
    with tempfile.TemporaryDirectory(prefix="reachavoid-suite-cache-") as cache:
        env = dict(os.environ, PYTHONPATH=str(tree), XDG_CACHE_HOME=cache,
                   SDL_VIDEODRIVER="dummy", SDL_AUDIODRIVER="dummy")
        for name in ("REACHAVOID_CACHE_DIR", "NUMBA_CACHE_DIR"):
            env.pop(name, None)
        done, seconds = once(lambda: subprocess.run(
            [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *flags],
            cwd=tree, env=env, capture_output=True, text=True), clock=WALL)
    lines = done.stdout.strip().splitlines()
    for line in lines:
        if line.startswith(("FAILED", "ERROR")):
            print(f"{tree.name}: {line}", file=sys.stderr)
    summary = lines[-1] if lines else ""
    counts = {word: int(number) for number, word in re.findall(r"(\d+) (passed|failed)",
                                                                summary)}
    if not counts.get("passed"):
        sys.exit(f"suite_time: nothing passed in {tree}: {summary or done.stderr[-500:]}")
    return Run(seconds, counts["passed"], counts.get("failed", 0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base", default="42401d9", help="the earlier commit (default: "
                        "%(default)s)")
    parser.add_argument("--base-flags", default="", help="its pytest flags (default: none, "
                        "serial)")
    parser.add_argument("--flags", default="-n auto", help="this checkout's pytest flags "
                        "(default: %(default)s)")
    parser.add_argument("--rounds", type=int, default=1, help="alternating rounds "
                        "(default: %(default)s)")
    parser.add_argument("--json", help="write the result record here")
    args = parser.parse_args()
    runs: dict[str, list[Run]] = {"base": [], "head": []}
    with clean_clone(args.base) as base, clean_clone("HEAD") as head:
        for round_ in range(args.rounds):
            for label, tree, flags in (("base", base, args.base_flags),
                                       ("head", head, args.flags)):
                run = suite_wall(tree, shlex.split(flags))
                runs[label].append(run)
                print(f"round {round_ + 1} {label}: {run.passed} passed, {run.failed} failed "
                      f"in {run.seconds:.0f} s", flush=True)
    if any(run.failed for run in runs["head"]):
        sys.exit("suite_time: this checkout's suite failed (above)")
    wall = {label: min(run.seconds for run in kept) for label, kept in runs.items()}
    figures = {"wall_s.base": round(wall["base"], 1), "wall_s.head": round(wall["head"], 1),
               "passed.base": runs["base"][0].passed, "failed.base": runs["base"][0].failed,
               "passed.head": runs["head"][0].passed,
               "shorter_percent": round(100 * (1 - wall["head"] / wall["base"]), 1)}
    print(f"{commit_of(args.base)} ({args.base_flags or 'serial'}) {wall['base']:.0f} s, "
          f"{commit_of('HEAD')} ({args.flags}) {wall['head']:.0f} s: "
          f"{figures['shorter_percent']:+.1f}% shorter")
    if args.json:
        write_result(args.json, "suite_time", figures, {
            "wall_s": "wall seconds of the whole pytest run with cold caches, the best round",
            "passed": "tests that passed", "failed": "tests that failed",
            "shorter_percent": "how much shorter this checkout's suite is than the base's, "
                               "percent of the base's wall time"})


if __name__ == "__main__":
    main()

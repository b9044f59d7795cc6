"""The test suite's wall time as CI runs it on a fresh machine, side by side with an
earlier commit's suite as its CI ran it.

Each tree (``harness.checkout``: unpacked fresh, so no compiled numba cache comes with it)
runs its own ``tests/`` with this environment's Python, an empty ``$XDG_CACHE_HOME`` (no
kernels compiled before) and its own pytest flags, one after the other (``--rounds``
alternates them); the figure is the wall time of the pytest process (``harness.once``)
and how many tests passed. By default the base is 42401d9, serial (its CI), and this
checkout runs with ``-n auto`` (pytest-xdist, one worker per core: CI now):

    python benchmarks/suite_time.py --json benchmarks/results/suite_time.json
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

from harness import WALL, checkout, commit_of, once
from result_file import write_result


def suite_wall(tree: Path, flags: list[str]) -> tuple[float, int]:
    """Wall seconds of ``pytest -q -p no:cacheprovider FLAGS`` in ``tree`` with an empty
    cache and that tree first on the path, and the number of tests that passed; exits
    naming the tree where the suite fails."""
    with tempfile.TemporaryDirectory(prefix="reachavoid-suite-cache-") as cache:
        env = dict(os.environ, PYTHONPATH=str(tree), XDG_CACHE_HOME=cache,
                   SDL_VIDEODRIVER="dummy", SDL_AUDIODRIVER="dummy")
        env.pop("REACHAVOID_CACHE_DIR", None)
        done, seconds = once(lambda: subprocess.run(
            [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *flags],
            cwd=tree, env=env, capture_output=True, text=True), clock=WALL)
    summary = done.stdout.strip().splitlines()[-1] if done.stdout.strip() else ""
    if done.returncode != 0:
        sys.exit(f"suite_time: the suite failed in {tree}: {summary or done.stderr[-500:]}")
    passed = re.search(r"(\d+) passed", summary)
    return seconds, int(passed.group(1)) if passed else 0


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
    runs: dict[str, list[tuple[float, int]]] = {"base": [], "head": []}
    with checkout(args.base) as base, checkout("HEAD") as head:
        for round_ in range(args.rounds):
            for label, tree, flags in (("base", base, args.base_flags),
                                       ("head", head, args.flags)):
                runs[label].append(suite_wall(tree, shlex.split(flags)))
                seconds, passed = runs[label][-1]
                print(f"round {round_ + 1} {label}: {passed} passed in {seconds:.0f} s",
                      flush=True)
    wall = {label: min(seconds for seconds, _ in kept) for label, kept in runs.items()}
    figures = {"wall_s.base": round(wall["base"], 1), "wall_s.head": round(wall["head"], 1),
               "passed.base": runs["base"][0][1], "passed.head": runs["head"][0][1],
               "shorter_percent": round(100 * (1 - wall["head"] / wall["base"]), 1)}
    print(f"{commit_of(args.base)} ({args.base_flags or 'serial'}) {wall['base']:.0f} s, "
          f"{commit_of('HEAD')} ({args.flags}) {wall['head']:.0f} s: "
          f"{figures['shorter_percent']:+.1f}% shorter")
    if args.json:
        write_result(args.json, "suite_time", figures, {
            "wall_s": "wall seconds of the whole pytest run with cold caches, the best round",
            "passed": "tests that passed",
            "shorter_percent": "how much shorter this checkout's suite is than the base's, "
                               "percent of the base's wall time"})


if __name__ == "__main__":
    main()

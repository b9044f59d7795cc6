"""Start-up of the ``reachavoid`` command in two checkouts side by side: ``--help`` and a
``play`` on cached tubes, each run in fresh processes, alternating between the checkouts
(A, B, A, B, ... ``--rounds`` each); then one table of medians.

    python benchmarks/startup.py main . --rounds 5 -- --grid1 25 --grid2 15

A checkout is a folder or a revision of this repository, unpacked for the run
(``harness.checkout``). Every process is ``python -X importtime -m reachavoid.cli ...``
run in the checkout it times (``-m`` puts the working folder first on ``sys.path``), with
``PYTHONPATH`` set to it too, so only the library code differs; its wall time is taken by
``harness.timed``. Per checkout the table gives the
wall time of ``--help``; of ``play`` (arguments after ``--``; the tubes must be cached, and
a first untimed round fills numba's caches) its wall time, the time spent importing
modules (the top-level entries of ``-X importtime``, whenever they were imported: at start
or on first use), the part of that spent in OR-Tools and pandas (which
``ortools.sat.python.cp_model`` imports), and the episode itself (``seconds`` of
``play --json``). ``--json PATH`` writes the second checkout's medians as a result record
(``benchmarks/result_file.py``; the first checkout's under ``*_before``).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import re
import statistics
import subprocess
import sys
from collections import Counter
from pathlib import Path

from harness import checkout, once
from result_file import write_result

_LINE = re.compile(r"import time:\s+(\d+) \|\s+(\d+) \|( +)(\S+)")


def import_seconds(report: str) -> tuple[float, Counter[str]]:
    """Total import time of an ``-X importtime`` report (seconds) and each top-level
    package's own share (seconds, by the package of each imported module)."""
    total, own = 0, Counter[str]()
    for line in report.splitlines():
        match = _LINE.match(line)
        if match is None:
            continue
        own[match[4].split(".")[0]] += int(match[1])
        if len(match[3]) == 1:
            total += int(match[2])
    return total / 1e6, Counter({name: us / 1e6 for name, us in own.items()})


def run(tree: Path, arguments: list[str]) -> tuple[float, str, str]:
    """Wall time (s), stdout and stderr of one fresh ``reachavoid`` process."""
    env = dict(os.environ, PYTHONPATH=str(tree.resolve()), SDL_VIDEODRIVER="dummy",
               SDL_AUDIODRIVER="dummy")
    done, seconds = once(lambda: subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "reachavoid.cli", *arguments], env=env,
        cwd=tree, capture_output=True, text=True, check=True))
    return seconds, done.stdout, done.stderr


def measure(tree: Path, play: list[str]) -> dict[str, float]:
    """One round for the checkout in ``tree``: ``--help``, then ``play``."""
    help_wall, _, _ = run(tree, ["--help"])
    play_wall, out, err = run(tree, ["play", "--json", *play])
    imports, own = import_seconds(err)
    return {"help": help_wall, "play": play_wall, "imports": imports,
            "ortools": own["ortools"] + own["pandas"],
            "episode": float(json.loads(out)["seconds"])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkouts", nargs=2, metavar="CHECKOUT",
                        help="a folder or a revision")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    argv = sys.argv[1:]
    split = argv.index("--") if "--" in argv else len(argv)
    args = parser.parse_args(argv[:split])
    args.play = argv[split + 1:] or ["--grid1", "25", "--grid2", "15"]
    with contextlib.ExitStack() as stack:
        trees = {name: stack.enter_context(checkout(name)) for name in args.checkouts}
        rows: dict[str, list[dict[str, float]]] = {name: [] for name in trees}
        for tree in trees.values():  # untimed: fills numba's caches of each checkout
            measure(tree, args.play)
        for _ in range(args.rounds):
            for name, tree in trees.items():
                rows[name].append(measure(tree, args.play))
    print(f"{args.rounds} rounds, medians in seconds; play {' '.join(args.play)}")
    print(f"  {'checkout':<20} {'--help':>7} {'play':>7} {'imports':>8} {'OR-Tools':>9} "
          f"{'imports w/o OR-Tools':>21} {'episode':>8}")
    figures: dict[str, float] = {}
    sides = ("_before", "")[-len(rows):]   # one checkout named twice: just its figures
    for side, (name, runs) in zip(sides, rows.items(), strict=True):
        med = {key: statistics.median(r[key] for r in runs) for key in runs[0]}
        figures |= {f"{key}_s{side}": med[key] for key in ("help", "play", "imports")}
        rest = statistics.median(r["imports"] - r["ortools"] for r in runs)
        print(f"  {name:<20} {med['help']:7.2f} {med['play']:7.2f} "
              f"{med['imports']:8.2f} {med['ortools']:9.2f} {rest:21.2f} "
              f"{med['episode']:8.2f}")
    if args.json:
        write_result(args.json, "startup", figures, {
            "help_s": "median wall seconds of `reachavoid --help` (second checkout; _before: "
                      "the first)",
            "play_s": f"median wall seconds of a cached `play {' '.join(args.play)}`",
            "imports_s": "of which imports"})


if __name__ == "__main__":
    main()

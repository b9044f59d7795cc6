"""A ``reachavoid bench`` run as a result record: the suite, a map library, any cells.

Runs ``python -m reachavoid bench ARGS --json TEMP`` (the arguments after ``--``), prints
its tables, and writes the report's figures as a result record (``benchmarks/result_file.py``)
to ``--json``:

    python benchmarks/bench_record.py --json benchmarks/results/suite_default.json -- \\
        --suite default --defenders hj,intercept,greedy --episodes 200 --backend process
    python benchmarks/bench_record.py --json benchmarks/results/maps_defenders.json -- \\
        --scenario maps/test --defenders hj,intercept,greedy --attackers hj --episodes 20 \\
        --grid1 25 --grid2 15

Keys (a cell as labelled, ``SCENARIO.ATTACKERS`` with spaces as ``_``; a pooled library
as ``pooled.ATTACKERS``): ``capture_percent.CELL.METHOD``,
``minus_BASELINE_points.CELL.METHOD`` ([difference, 95% low, 95% high]), and ``episodes``,
``cells``, ``wall_s``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from result_file import write_result


def figures_of(report: dict[str, Any]) -> dict[str, Any]:
    """The figures of a ``bench --json`` report, keyed as the docstring says."""
    baseline = report["baseline"].replace("-", "_")
    figures: dict[str, Any] = {"episodes": len(report["rows"]), "cells": len(report["cells"]),
                               "wall_s": report["wall_seconds"]}
    groups = [(cell["cell"].replace(" / ", ".").replace(" ", "_"), cell)
              for cell in report["cells"]]   # a cell's label names its attackers
    groups += [(f"pooled.{pooled['attackers']}", pooled) for pooled in report["pooled"]]
    for where, group in groups:
        for summary in group["methods"]:
            figures[f"capture_percent.{where}.{summary['label']}"] = \
                100 * summary["capture_rate"]
        for difference in group["differences"]:
            figures[f"minus_{baseline}_points.{where}.{difference['label']}"] = [
                100 * difference["difference"], *(100 * end for end in difference["ci"])]
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", required=True,
                        help="write the result record (benchmarks/result_file.py) here")
    ours, bench = sys.argv[1:], []
    if "--" in ours:
        cut = ours.index("--")
        ours, bench = ours[:cut], ours[cut + 1:]
    args = parser.parse_args(ours)
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(scratch) / "bench.json"
        done = subprocess.run([sys.executable, "-m", "reachavoid", "bench", *bench,
                               "--json", str(out)], check=False)
        if done.returncode != 0:
            raise SystemExit(done.returncode)
        report = json.loads(out.read_text())
    baseline = report["baseline"].replace("-", "_")
    write_result(args.json, "bench", figures_of(report), {
        "capture_percent": "mean share of attackers captured, percent, by cell, attackers "
                           "and method",
        f"minus_{baseline}_points": f"paired per-seed difference against {report['baseline']},"
                                    " percentage points: [difference, 95% low, 95% high]",
        "episodes": "episodes played, every method", "cells": "cells of the run",
        "wall_s": "wall seconds of the run"})


if __name__ == "__main__":
    main()

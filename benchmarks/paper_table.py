"""The paper's Table I as a result record: ``reachavoid paper`` without its videos.

Plays every game the paper reports (``reachavoid.paper.reproduce``: the paper's Algorithm
1 and its matching baseline against shortest-path attackers, unassigned defenders
standing still, the tubes read as the paper reads them) and writes what each method
captured beside what the paper reports:

    python benchmarks/paper_table.py [--grid1 45] [--grid2 30] \\
        [--json benchmarks/results/paper_table.json]

The tubes come from the cache (solved once if missing: the paper's grids take minutes).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from result_file import write_result

from reachavoid.paper import reproduce


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid1", type=int, default=45)
    parser.add_argument("--grid2", type=int, default=30)
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:   # tubes.png and table.json: not kept
        rows = reproduce(Path(scratch), args.grid1, args.grid2, videos=False)
    figures: dict[str, float] = {}
    print(f"{'game':<10} {'method':<10} {'captured':>8} {'paper':>6}")
    for row in rows:
        game = row.scenario.removeprefix("paper_")
        for method, measured in row.measured.items():
            captured = measured["captured_count"]
            print(f"{game:<10} {method:<10} {captured:>8} {row.reported[method]:>6}")
            figures |= {f"captured.{method}.{game}": captured,
                        f"reported.{method}.{game}": row.reported[method]}
    if args.json:
        write_result(args.json, "paper_table", figures, {
            "captured": f"attackers captured (shortest-path attackers, tubes {args.grid1}^4 / "
                        f"{args.grid2}^6): paper is the paper's Algorithm 1, matching its "
                        "baseline",
            "reported": "the same, as the paper reports it"})


if __name__ == "__main__":
    main()

"""What the README's first run leaves on disk: the cached tubes of
``reachavoid play --scenario paper_6v2 --defenders hj`` (1 vs 1 at 45^4, 2 vs 1 at 30^6).

Loads (or, with an empty cache, solves: about ten minutes, ``hj_1v1.json`` and
``hj_2v1.json`` have the solve times and the peak memory) the two tubes and measures the
size of their cache entries (every file of each entry folder) and the wall time this run
took to have them (a load from a warm cache, or the solves).

    python benchmarks/first_run.py --json benchmarks/results/first_run.json
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from harness import once
from result_file import write_result

from policies.tubes import tube_2v1
from reachavoid_env import builtin_scenario


def entry_mb(values: object) -> float:
    """Megabytes (10^6 bytes) of the cache entry a memory-mapped tube was loaded from."""
    folder = Path(values.filename).parent   # numpy.memmap of the entry's value.npy
    return sum(f.stat().st_size for f in folder.iterdir() if f.is_file()) / 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", help="write the result record here")
    args = parser.parse_args()
    (vf11, vf21), seconds = once(lambda: tube_2v1(builtin_scenario("paper_6v2"),
                                                 progress=False))
    figures = {"cache_mb.1v1_45": entry_mb(vf11.values), "cache_mb.2v1_30": entry_mb(vf21.values)}
    figures["cache_mb.total"] = figures["cache_mb.1v1_45"] + figures["cache_mb.2v1_30"]
    figures["have_tubes_s"] = seconds
    for key, value in figures.items():
        print(f"{key}: {value:.1f}")
    print(f"cache: {os.environ.get('REACHAVOID_CACHE_DIR', '~/.cache/reachavoid')}")
    if args.json:
        write_result(args.json, "first_run", figures, {
            "cache_mb": "megabytes on disk of the cache entries of paper_6v2's hj tubes",
            "have_tubes_s": "wall seconds this run took to have both tubes (from a warm "
                            "cache: a load; from an empty one: the solves)"})


if __name__ == "__main__":
    main()

"""A map library's tubes solved serially and on the process pool, wall times side by side.

Generates ``--maps`` maps (``reachavoid_env.maps``, default options, ``--seed``), then solves
the tubes the HJ + MIP defenders need on every map (1 vs 1 on ``--grid1``^4, 2 vs 1 on
``--grid2``^6) once serially and once on a process pool of ``--workers``, each into an
empty cache folder of its own (so both solve everything), checks that both give the same
values bit for bit, and prints the wall times and the per-map solve seconds.

    python benchmarks/tube_library.py [--maps 32] [--grid1 25] [--grid2 15] [--workers 2]
        [--json benchmarks/results/tube_library.json]
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time

import numpy as np
from result_file import write_result

from reachavoid.solve import solve_library
from reachavoid_env.maps import MapOptions, generate_map


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--maps", type=int, default=32)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--grid1", type=int, default=25)
    parser.add_argument("--grid2", type=int, default=15)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    args = parser.parse_args()
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}; load average "
          f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}", flush=True)
    started = time.perf_counter()
    library = [generate_map(MapOptions(), args.seed, k) for k in range(args.maps)]
    print(f"{args.maps} maps generated in {time.perf_counter() - started:.1f} s", flush=True)
    results = {}
    for backend, workers in (("serial", None), ("process", args.workers)):
        with tempfile.TemporaryDirectory(prefix="tube-library-") as cache:
            os.environ["REACHAVOID_CACHE_DIR"] = cache
            started = time.perf_counter()
            rows = solve_library(library, ["hj"], args.grid1, args.grid2, backend=backend,
                                 workers=workers)
            wall = time.perf_counter() - started
            values = {(r.map, r.game): np.load(r.path / "value.npy") for r in rows}
        results[backend] = (rows, values, wall)
        solve_seconds = sum(r.seconds or 0.0 for r in rows)
        peak = max(r.peak_bytes for r in rows) / 2**20
        label = backend if workers is None else f"{backend} ({workers} workers)"
        print(f"{label:<22} {len(rows)} tubes on {args.maps} maps: wall {wall:7.1f} s, sum of "
              f"solve seconds {solve_seconds:7.1f} s, largest map peak {peak:.0f} MiB, load "
              f"average {os.getloadavg()[0]:.2f}", flush=True)
    serial, pooled = results["serial"][1], results["process"][1]
    same = serial.keys() == pooled.keys() and all(np.array_equal(serial[k], pooled[k])
                                                  for k in serial)
    print(f"values: {'the same bit for bit' if same else 'DIFFERENT'}; speed-up "
          f"{results['serial'][2] / results['process'][2]:.2f}x")
    if args.json:
        write_result(args.json, "tube_library", {
            "maps": args.maps, "wall_s.serial": results["serial"][2],
            "wall_s.process": results["process"][2],
            "speedup": results["serial"][2] / results["process"][2],
            "values_equal": int(same)}, {
            "maps": f"generated maps (seed {args.seed})",
            "wall_s": f"the tubes (1 vs 1 at {args.grid1}^4, 2 vs 1 at {args.grid2}^6) of "
                      f"every map from an empty cache, serial and on {args.workers} workers",
            "speedup": "serial wall time over the pool's",
            "values_equal": "1 when every value is the same bit for bit on both backends"})
    print(f"{'map':<16} {'1v1 s':>7} {'2v1 s':>7}")
    by_map: dict[str, dict[str, float]] = {}
    for row in results["serial"][0]:
        by_map.setdefault(row.map, {})[row.game] = row.seconds or 0.0
    for name, games in by_map.items():
        print(f"{name:<16} {games.get('1v1', 0.0):7.1f} {games.get('2v1', 0.0):7.1f}")


if __name__ == "__main__":
    main()

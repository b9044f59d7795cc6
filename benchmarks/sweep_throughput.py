"""Sweep throughput: episodes per second serially, on a process pool and on Ray.

One ``reachavoid bench``-style sweep (random starts, HJ + MIP defenders, shortest-path
attackers) is played on each backend with the same seeds; the script checks that every
backend gives the serial results and prints episodes per second (wall clock, tubes already
in the cache, worker start-up included). It also measures what a worker pays to get the
tubes: opening the cached value files (memory-mapped, what every worker does) against a
round trip of the 2 vs 1 array through Ray's object store (what a cluster without a shared
filesystem would do instead).

    .venv/bin/python benchmarks/sweep_throughput.py [--episodes 40] [--workers 2] [--json PATH]

``--json`` writes each backend's wall seconds and episodes per second as a result record
(``benchmarks/result_file.py``).
"""

from __future__ import annotations

import argparse
import os
import platform
from dataclasses import asdict
from typing import Any

import numpy as np
from harness import once
from result_file import write_result

from policies.tubes import tube_2v1
from reachavoid.sweep import run_sweep, sweep_of
from reachavoid_env import builtin_scenario
from solvers.hj import PAPER_GRIDS, load_value_function


def outcome(results) -> list[dict]:
    return [{k: v for k, v in asdict(r).items() if k != "seconds"} for r in results]


def touched(vf: Any) -> Any:
    """``vf`` after reading its first value (a memory-mapped file's first page in)."""
    float(np.asarray(vf.values[(0,) * vf.values.ndim]))
    return vf


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--config", default="6v2", help="MvN random starts (default 6v2)")
    parser.add_argument("--episodes", type=int, default=40)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--grid1", type=int, default=PAPER_GRIDS.grid1)
    parser.add_argument("--grid2", type=int, default=PAPER_GRIDS.grid2)
    parser.add_argument("--backends", nargs="+", default=["serial", "process", "ray"])
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    args = parser.parse_args()
    figures: dict[str, float] = {}
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}; load average "
          f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}")
    m, n = (int(k) for k in args.config.split("v"))
    scenario = builtin_scenario("paper_2v1").with_players(m, n)
    sweep = sweep_of(scenario, "hj", "shortest-path", range(args.episodes), grid1=args.grid1,
                     grid2=args.grid2)
    vf11, vf21 = tube_2v1(scenario, args.grid1, args.grid2, progress=False)
    reference = None
    for backend in args.backends:
        results, seconds = once(lambda backend=backend: run_sweep(sweep, backend,
                                                                  workers=args.workers))
        reference = reference or outcome(results)
        same = "same as serial" if outcome(results) == reference else "DIFFERENT"
        print(f"{backend:<8} {args.episodes} episodes of {args.config} in {seconds:7.1f} s: "
              f"{args.episodes / seconds:6.2f} episodes/s ({same})", flush=True)
        figures |= {f"wall_s.{backend}": seconds,
                    f"episodes_per_s.{backend}": args.episodes / seconds}
    if args.json:
        write_result(args.json, "sweep_throughput", figures, {
            "episodes_per_s": f"{args.episodes} random {args.config} starts, hj defenders at "
                              f"{args.grid1}^4 / {args.grid2}^6 (cached), wall clock with "
                              "worker start-up",
            "wall_s": "wall seconds of the sweep"})

    path = os.path.dirname(vf21.values.filename)
    opened, seconds = once(lambda: touched(load_value_function(path)))
    print(f"open the cached 2 vs 1 tube ({opened.values.nbytes / 2**20:,.0f} MiB, "
          f"memory-mapped): {seconds:.3f} s")
    if "ray" in args.backends:
        import ray

        ray.init(num_cpus=1, include_dashboard=False, log_to_driver=False)
        values = np.asarray(vf21.values)
        ref, put = once(lambda: ray.put(values))
        _, get = once(lambda: float(ray.get(ref).reshape(-1)[-1]))
        print(f"Ray object store, 2 vs 1 tube ({values.nbytes / 2**20:,.0f} MiB): put "
              f"{put:.2f} s, get on the same node {get:.3f} s "
              f"(another node also copies it over the network)")
        ray.shutdown()


if __name__ == "__main__":
    main()

"""Benchmark: the upwind schemes against the open-map theory checks (BENCHMARKS.md).

The 1 vs 1 game on an obstacle-free map (disc target of radius 0.3 at the origin of
[-2, 2]^2, vA = 1, vD = 1.5, capture radius 0.1): the certificates of
``solvers.open_space.disc_target_margins`` (those of ``tests/test_hj_1v1.py``) say who
must win from 20,000 random states, the attacker where it reaches the target along a
straight line before the defender can come within the capture radius of its path, the
defender where the Apollonius disc misses the target. Here with a
fixed margin (``--margin`` seconds of slack, map units of clearance), the same states at
every grid, so the errors are comparable:

- ``wrong``: fraction of certified states on the wrong side;
- ``excess``: mean value on the wrong side (map units; the value's error there);
- ``order``: ``log(excess ratio) / log(spacing ratio)`` between successive grids;
- ``seconds``: the solve (compile excluded), ``excess_x_s``: error times time (lower is
  more accuracy per second).

    python benchmarks/hj_schemes.py [--grids 21 31 45] [--schemes godunov lax_friedrichs eno2]
        [--json benchmarks/results/hj_schemes.json]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time

import numpy as np
from result_file import write_result

from reachavoid_env import Circle, GameMap
from solvers.hj import SolverSettings, solve_1v1
from solvers.open_space import disc_target_margins

VA, VD, R, TARGET = 1.0, 1.5, 0.1, 0.3


def certified_states(margin: float, count: int = 20000):
    """States ``(K, 4)`` and whether the attacker (True) or the defender (False) must win."""
    rng = np.random.default_rng(0)
    a = rng.uniform(-1.4, 1.4, (count, 2))
    d = rng.uniform(-1.4, 1.4, (count, 2))
    slack, miss = disc_target_margins(a, d, TARGET, (VA, VD), R)
    attacker, defender = slack > margin, miss > margin
    states = np.concatenate([a, d], axis=1)
    return states[attacker | defender], attacker[attacker | defender]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grids", type=int, nargs="*", default=[21, 31, 45])
    parser.add_argument("--schemes", nargs="*", default=["godunov", "lax_friedrichs", "eno2"])
    parser.add_argument("--margin", type=float, default=0.02)
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    args = parser.parse_args()
    figures: dict[str, float] = {}
    game_map = GameMap((-2.0, 2.0, -2.0, 2.0), (Circle((0.0, 0.0), TARGET),))
    states, attacker_wins = certified_states(args.margin)
    print(f"# hj_schemes: open map, {len(states)} certified states ({attacker_wins.sum()} "
          f"attacker, {(~attacker_wins).sum()} defender), margin {args.margin}, "
          f"{time.strftime('%Y-%m-%d %H:%M')}, load {os.getloadavg()[0]:.1f}", flush=True)
    for scheme in args.schemes:
        settings = SolverSettings(scheme=scheme)
        solve_1v1(game_map, (VA, VD), R, 9, settings=settings, cache=False, progress=False)
        previous = None
        for grid in args.grids:
            start = time.perf_counter()
            vf = solve_1v1(game_map, (VA, VD), R, grid, settings=settings, cache=False,
                           progress=False)
            seconds = time.perf_counter() - start
            value = vf.value(states)
            wrong_side = np.where(attacker_wins, np.maximum(value, 0), np.maximum(-value, 0))
            excess = float(wrong_side.mean())
            h = vf.grid.spacing[0]
            order = None if previous is None or min(previous[1], excess) == 0 else \
                math.log(previous[1] / excess) / math.log(previous[0] / h)
            previous = (h, excess)
            print(json.dumps({
                "scheme": scheme, "grid": f"{grid}^4", "iterations": vf.solver["iterations"],
                "converged": vf.solver["converged"], "seconds": round(seconds, 2),
                "wrong": float(np.mean(wrong_side > 0)), "excess": excess,
                "order": order, "excess_x_s": excess * seconds,
                "load": round(os.getloadavg()[0], 1)}), flush=True)
            figures |= {f"wrong_percent.{scheme}.{grid}": 100 * float(np.mean(wrong_side > 0)),
                        f"solve_s.{scheme}.{grid}": seconds,
                        f"sweeps.{scheme}.{grid}": vf.solver["iterations"]}
    if args.json:
        write_result(args.json, "hj_schemes", figures, {
            "wrong_percent": "certified 1 vs 1 states on the wrong side of the zero level, "
                             "percent, by scheme and grid (open map, disc target)",
            "solve_s": "seconds of the solve", "sweeps": "sweeps to convergence"})


if __name__ == "__main__":
    main()

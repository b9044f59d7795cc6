"""Benchmark: solve times of the assignment MIP and the matching (BENCHMARKS.md, "Assignment").

Random instances of the paper's program for 2v1, 6v2, 8v4 and 16v8: each attacker beats
each defender alone with probability ``--p1``, each pair beats each defender with
probability ``--p2``. Rows "+ teams" add the defender teams (the 1 vs 2 table): each
attacker beats each lone defender with probability ``--team-p1`` (defenders no faster than
attackers, where teams matter) and each pair of defenders with probability ``--p3``, drawn
below its 1 vs 1 table (a pair never loses where one of its defenders wins alone). Reported
per size, over ``--instances`` instances, as wall time
(``perf_counter``) and CPU time (``process_time``, less disturbed on a shared machine):

- cold: ``solve_assignment`` / ``max_matching`` on a fresh instance (model built and
  solved every call);
- cached: ``AssignmentSolver.solve`` called every step of a sequence in which the inputs
  change on a share ``--change`` of the steps (one table entry flipped), as the sets
  ``I_j`` and ``P_j`` do during a game; unchanged steps reuse the last answer.

    python benchmarks/assignment_latency.py [--instances 300] [--p1 0.3] [--p2 0.3]
        [--team-p1 0.7] [--p3 0.3] [--json benchmarks/results/assignment_latency.json]

``--json`` writes the medians and tails as a result record (``benchmarks/result_file.py``):
the team rows as ``cold_cpu_p50_ms.MvN``, ``cold_cpu_p99_ms.MvN`` and ``cached_p50_ms.MvN``
(wall), the first table as ``mip_*`` and ``matching_*``.
"""

from __future__ import annotations

import argparse
import platform
from collections.abc import Callable

import numpy as np
from harness import Timing, timed
from result_file import write_result

from solvers.assignment import AssignmentSolver, max_matching, solve_assignment

SIZES = ((2, 1), (6, 2), (8, 4), (16, 8))
TEAM_SIZES = ((6, 4), (8, 4), (16, 8))


def one_call(call: Callable[..., object], *args: object) -> Timing:
    """One call timed (``harness.timed``: CPU and wall seconds)."""
    def work() -> int:
        call(*args)
        return 1

    return timed(work)


def instances(rng: np.random.Generator, m: int, n: int, count: int, p1: float, p2: float,
              p3: float | None = None):
    """``(beats_1v1, beats_2v1, beats_1v2)`` tables; ``beats_1v2`` is ``None`` without
    ``p3``, else true only where the attacker also beats both defenders alone."""
    for _ in range(count):
        one = rng.random((m, n)) < p1
        two = rng.random((m, m, n)) < p2
        three = None
        if p3 is not None:
            three = (rng.random((m, n, n)) < p3) & one[:, :, None] & one[:, None, :]
            three |= three.transpose(0, 2, 1)
        yield one, two | two.transpose(1, 0, 2), three


def sequence(rng: np.random.Generator, m: int, n: int, steps: int, p1: float, p2: float,
             change: float, p3: float | None = None):
    """Inputs of ``steps`` consecutive steps, one random entry flipped on changed steps."""
    one, two, three = next(instances(rng, m, n, 1, p1, p2, p3))
    for _ in range(steps):
        if rng.random() < change:
            one, two = one.copy(), two.copy()
            kind = rng.integers(2 if three is None else 3)
            if kind == 0:
                one[rng.integers(m), rng.integers(n)] ^= True
            elif kind == 1:
                a, b, j = rng.integers(m), rng.integers(m), rng.integers(n)
                two[a, b, j] = two[b, a, j] = not two[a, b, j]
            else:
                three = three.copy()
                i, j, k = rng.integers(m), rng.integers(n), rng.integers(n)
                three[i, j, k] = three[i, k, j] = not three[i, j, k]
        yield one, two, three


def summary(samples: list[Timing]) -> str:
    """Wall p50 / p99 / max (CPU p50 / p99) of the calls, milliseconds."""
    calls = sum(samples, Timing((), (), ()))
    return (f"{calls.ms(50, wall=True):.3f} / {calls.ms(99, wall=True):.2f} / "
            f"{calls.ms(100, wall=True):.2f} ({calls.ms(50):.3f} / {calls.ms(99):.2f})")


def figures_of(name: str, size: str, samples: list[Timing]) -> dict[str, float]:
    """Wall p50 and CPU p50 / p99 of the calls as result-record keys, in ms."""
    calls = sum(samples, Timing((), (), ()))
    return {f"{name}_p50_ms.{size}": calls.ms(50, wall=True),
            f"{name}_cpu_p50_ms.{size}": calls.ms(50),
            f"{name}_cpu_p99_ms.{size}": calls.ms(99)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--instances", type=int, default=300)
    parser.add_argument("--p1", type=float, default=0.3, help="P(attacker beats defender 1v1)")
    parser.add_argument("--p2", type=float, default=0.3, help="P(pair beats defender 2v1)")
    parser.add_argument("--team-p1", type=float, default=0.7,
                        help="P(attacker beats defender 1v1) in the team rows")
    parser.add_argument("--p3", type=float, default=0.3,
                        help="P(attacker beats a defender pair 1v2 | it beats both alone)")
    parser.add_argument("--change", type=float, default=0.1,
                        help="share of steps whose inputs change (cached runs)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    args = parser.parse_args()
    figures: dict[str, float] = {}
    rng = np.random.default_rng(args.seed)
    print(f"machine: {platform.machine()} {platform.processor() or ''}, "
          f"python {platform.python_version()}; p1={args.p1}, p2={args.p2}, "
          f"team rows: p1={args.team_p1}, p3={args.p3}; "
          f"change={args.change}, {args.instances} instances/steps per row")
    print("times in ms: wall p50 / p99 / max (cpu p50 / p99)")
    print("| size | MIP cold | MIP cached | matching cold | matching cached | MIP re-solves |")
    print("|---|---|---|---|---|---|")
    for m, n in SIZES:
        solve_assignment(np.zeros((m, n), bool), np.zeros((m, m, n), bool))  # warm-up
        mip_cold = [one_call(solve_assignment, one, two)
                    for one, two, _ in instances(rng, m, n, args.instances, args.p1, args.p2)]
        match_cold = [one_call(max_matching, one)
                      for one, _, _ in instances(rng, m, n, args.instances, args.p1, args.p2)]
        steps = list(sequence(rng, m, n, args.instances, args.p1, args.p2, args.change))
        mip, matching = AssignmentSolver("mip"), AssignmentSolver("matching")
        mip_cached = [one_call(mip.solve, one, two) for one, two, _ in steps]
        match_cached = [one_call(matching.solve, one) for one, _, _ in steps]
        print(f"| {m}v{n} | {summary(mip_cold)} | {summary(mip_cached)} | "
              f"{summary(match_cold)} | {summary(match_cached)} | "
              f"{mip.solves}/{mip.solves + mip.reuses} |")
        for name, samples in (("mip_cold", mip_cold), ("mip_cached", mip_cached),
                              ("matching_cold", match_cold), ("matching_cached", match_cached)):
            figures |= figures_of(name, f"{m}v{n}", samples)
    print("\n| size | MIP + teams cold | MIP + teams cached | teams in answer | re-solves |")
    print("|---|---|---|---|---|")
    for m, n in TEAM_SIZES:
        tables = list(instances(rng, m, n, args.instances, args.team_p1, args.p2, args.p3))
        cold = [one_call(solve_assignment, one, two, None, None, three)
                for one, two, three in tables]
        teams = sum(len(solve_assignment(one, two, beats_1v2=three).shared)
                    for one, two, three in tables)
        steps = list(sequence(rng, m, n, args.instances, args.team_p1, args.p2, args.change,
                              args.p3))
        mip = AssignmentSolver("mip")
        cached = [one_call(mip.solve, one, two, None, three) for one, two, three in steps]
        print(f"| {m}v{n} | {summary(cold)} | {summary(cached)} | "
              f"{teams / len(tables):.2f} per instance | "
              f"{mip.solves}/{mip.solves + mip.reuses} |")
        figures |= figures_of("cold", f"{m}v{n}", cold) | figures_of("cached", f"{m}v{n}", cached)
    if args.json:
        what = {"cold": "the program with defender teams, a fresh solve",
                "cached": "the program with defender teams on the cached path a game runs",
                "mip_cold": "the paper's program, a fresh solve",
                "mip_cached": "the paper's program on the cached path",
                "matching_cold": "the maximum matching, fresh",
                "matching_cached": "the maximum matching on the cached path"}
        units = {}
        for lead in {key.split(".")[0] for key in figures}:
            name, tail = lead.split("_p")
            clock = "CPU" if name.endswith("_cpu") else "wall"
            units[lead] = (f"{what[name.removesuffix('_cpu')]}: {clock} time, "
                           f"p{tail.split('_')[0]}, milliseconds")
        write_result(args.json, "assignment_latency", figures, units)


if __name__ == "__main__":
    main()

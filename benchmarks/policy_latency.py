"""Benchmark: per-step decision latency of the defenders (BENCHMARKS.md, "Decision latency").

One decision is ``defenders.act(state)``: the 1 vs 1 and 2 vs 1 (and, with teams, 1 vs 2)
tube lookups at the current positions, the assignment (CP-SAT MIP or matching, reused when
its inputs are unchanged) and the optimal controls. Episodes are the paper's 8 vs 4 game
and seeded random 8 vs 4 starts, played by shortest-path attackers. Reported: p50, p90,
p99 and max over all decisions, with the share of steps that re-solved the assignment.

    python benchmarks/policy_latency.py [--grid1 45] [--grid2 30] [--episodes 10]
        [--json benchmarks/results/policy_latency.json]

The tubes are loaded from the cache (solved once if missing).
"""

from __future__ import annotations

import argparse
import functools
import platform

import numpy as np
from harness import once
from result_file import write_result

import reachavoid_env
from policies import (
    HJDefenderPolicy,
    HJPairsDefenderPolicy,
    MatchingDefenderPolicy,
    ShortestPathAttacker,
)
from policies.tubes import tube_1v2


def decision_times(env, defenders, episodes: int) -> tuple[np.ndarray, int]:
    """Wall times (s) of every ``defenders.act`` call over ``episodes`` episodes (each call
    timed by ``harness.once``)."""
    attackers = ShortestPathAttacker()
    times = []
    for seed in range(episodes):
        env.reset(seed=seed)
        scenario = env.unwrapped.scenario
        attackers.reset(scenario)
        defenders.reset(scenario)
        while env.agents:
            state = env.unwrapped.game_state()
            actions, seconds = once(functools.partial(defenders.act, state))
            times.append(seconds)
            actions.update(attackers.act(state))
            live = set(env.agents)
            env.step({agent: a for agent, a in actions.items() if agent in live})
    return np.asarray(times), len(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid1", type=int, default=45)
    parser.add_argument("--grid2", type=int, default=30)
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    args = parser.parse_args()

    paper = reachavoid_env.builtin_scenario("paper_8v4")
    reference = HJDefenderPolicy.for_scenario(paper, grid1=args.grid1, grid2=args.grid2)
    teams = HJPairsDefenderPolicy(reference.vf11, reference.vf21,
                                  tube_1v2(paper, args.grid1, args.grid2))
    policies = {"hj (MIP)": reference, "hj-pairs": teams,
                "matching": MatchingDefenderPolicy(reference.vf11)}
    keys = {"hj (MIP)": "hj", "hj-pairs": "hj_pairs", "matching": "matching"}
    figures: dict[str, float] = {}
    print(f"machine: {platform.processor() or platform.machine()}, "
          f"tubes {args.grid1}^4 and {args.grid2}^6")
    print(f"{'policy':<10} {'games':<22} {'decisions':>9} {'p50 ms':>8} {'p90 ms':>8} "
          f"{'p99 ms':>8} {'max ms':>8} {'solves':>7}")
    for label, policy in policies.items():
        for games, scenario, episodes in (("paper_8v4", paper, 1),
                                          ("random 8v4", paper.with_players(8, 4),
                                           args.episodes)):
            env = reachavoid_env.parallel_env(scenario=scenario)
            decision_times(env, policy, 1)  # numba compile and first page-ins
            solver = policy.solver
            solves_before = solver.solves
            times, count = decision_times(env, policy, episodes)
            p50, p90, p99 = np.percentile(times, [50, 90, 99]) * 1e3
            print(f"{label:<10} {games:<22} {count:>9} {p50:>8.3f} {p90:>8.3f} {p99:>8.3f} "
                  f"{times.max() * 1e3:>8.3f} {(solver.solves - solves_before) / count:>7.1%}")
            row = f"{keys[label]}.{games.replace(' ', '_')}"
            figures |= {f"p50_ms.{row}": p50, f"p99_ms.{row}": p99}
    if args.json:
        tails = [value for key, value in figures.items()
                 if key.startswith(("p99_ms.hj.", "p99_ms.hj_pairs."))]
        figures |= {"p99_ms.hj_and_hj_pairs.lowest": min(tails),
                    "p99_ms.hj_and_hj_pairs.highest": max(tails)}
        write_result(args.json, "policy_latency", figures,
                     {"p50_ms": f"median decision latency (defenders.act), milliseconds, "
                                f"tubes {args.grid1}^4 / {args.grid2}^6",
                      "p99_ms": "99th percentile, milliseconds (hj_and_hj_pairs: lowest and "
                                "highest over the hj and hj-pairs rows)"})


if __name__ == "__main__":
    main()

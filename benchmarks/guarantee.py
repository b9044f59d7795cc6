"""Benchmark: how often Algorithm 1's guarantee breaks, by tube resolution (BENCHMARKS.md).

For random 4v2, 6v2 and 8v4 starts on the paper map, against shortest-path, random and
HJ attackers, the HJ + MIP defenders report ``guaranteed_captures`` every step. An episode
violates the guarantee when captured-so-far plus guaranteed-from-now falls, or when more
attackers arrive than the guarantee allowed (``EpisodeResult.guarantee_violations``).
Run at the CI grids and at the paper's:

    python benchmarks/guarantee.py --grid1 25 --grid2 13 --episodes 20
    python benchmarks/guarantee.py --grid1 45 --grid2 30 --episodes 20

"clear" counts only episodes whose first assigned states lie at least ``--margin`` (in
value units) inside the defenders' winning sets, the paper's condition for the guarantee
to hold numerically.
"""

from __future__ import annotations

import argparse

import numpy as np

import reachavoid_env
from policies import HJAttacker, HJDefenderPolicy, RandomAttacker, ShortestPathAttacker
from policies.defenders import pair_states, triple_states
from reachavoid.rollout import run_episode


def assigned_margin(policy: HJDefenderPolicy, env) -> float:
    """Smallest value over the first step's assigned 1 vs 1 / 2 vs 1 states (> 0: clear)."""
    state = env.unwrapped.game_state()
    policy.act(state)
    margins = [np.inf]
    attackers, defenders = state.attacker_positions, state.defender_positions
    for j, mine in enumerate(policy.last_assignment.by_defender):
        if len(mine) == 1:
            margins.append(policy.vf11.value(pair_states(attackers[list(mine)],
                                                         defenders[[j]]))[0, 0])
        elif len(mine) == 2:
            margins.append(policy.vf21.value(triple_states(attackers, np.array([mine]),
                                                           defenders[[j]]))[0, 0])
    return float(min(margins))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid1", type=int, default=45)
    parser.add_argument("--grid2", type=int, default=30)
    parser.add_argument("--episodes", type=int, default=20, help="per configuration and attacker")
    parser.add_argument("--margin", type=float, default=0.01)
    args = parser.parse_args()

    base = reachavoid_env.builtin_scenario("paper_2v1")
    defenders = HJDefenderPolicy.for_scenario(base, grid1=args.grid1, grid2=args.grid2)
    attackers = {"shortest-path": ShortestPathAttacker(), "random": RandomAttacker(0),
                 "hj": HJAttacker(defenders.vf11)}
    print(f"tubes {args.grid1}^4 / {args.grid2}^6, {args.episodes} episodes per cell, "
          f"clear = assigned values >= {args.margin:g}")
    print(f"{'config':<7} {'attackers':<14} {'violated':>9} {'clear: violated':>16} "
          f"{'guaranteed':>10} {'stopped':>8} {'captured':>9}")
    totals = np.zeros(4, dtype=int)
    for m, n in ((4, 2), (6, 2), (8, 4)):
        env = reachavoid_env.parallel_env(scenario=base.with_players(m, n))
        for label, attacker in attackers.items():
            violated = clear = clear_violated = 0
            guaranteed, stopped, captured = [], [], []
            for seed in range(args.episodes):
                env.reset(seed=seed)
                defenders.reset(env.unwrapped.scenario)
                is_clear = assigned_margin(defenders, env) >= args.margin
                result = run_episode(env, attacker, defenders, seed=seed)
                bad = result.guarantee_violations > 0
                violated += bad
                clear += is_clear
                clear_violated += bad and is_clear
                guaranteed.append(result.guarantees[0])
                stopped.append(result.stopped_count)
                captured.append(result.captured_count)
            totals += (violated, args.episodes, clear_violated, clear)
            print(f"{m}v{n:<5} {label:<14} {violated:>4}/{args.episodes:<4} "
                  f"{clear_violated:>8}/{clear:<7} {np.mean(guaranteed):>10.2f} "
                  f"{np.mean(stopped):>8.2f} {np.mean(captured):>9.2f}")
    print(f"all: violated in {totals[0]}/{totals[1]} episodes ({totals[0] / totals[1]:.1%}); "
          f"clear starts: {totals[2]}/{totals[3]}"
          f" ({totals[2] / max(totals[3], 1):.1%})")


if __name__ == "__main__":
    main()

"""Batched defenders: game steps per second of K copies of a game driven by one policy call.

K copies (``--copies``, default 64) of ``--scenario`` (default ``paper_8v4``), random starts,
attackers on uniform random actions drawn beforehand, each copy starting a new game when
its game ends. Each step builds the copies' ``BatchState``, asks the defenders for
``(K, N, 2)`` actions, and steps every copy's ``parallel_env`` with them. Defenders, in
one process, runs alternating (``--repeats`` rounds):

- ``per-copy hj``: ``reachavoid_env.PerCopy`` of ``HJDefenderPolicy`` (one single-game
  policy per copy: what the code before the batched defenders does);
- ``batched hj``: ``policies.batch_defenders.BatchHJDefenders``;
- ``batched greedy``: ``policies.greedy.BatchGreedyDefenders``.

Each figure is game steps (copies times steps) per CPU second of the whole loop (``all``),
and the defenders' share alone (``defenders``: CPU seconds in ``act_batch`` per step);
the best of the rounds is kept, and the ratios hj / greedy and batched / per-copy are
taken from the best rates. The copies are stepped one ``parallel_env`` at a time (the
vector env is not part of this benchmark), so ``all`` counts the single env's stepping
too; ``defenders`` is what the batching changes. One core:

    taskset -c 0 .venv/bin/python benchmarks/defender_batch.py \
        --json benchmarks/results/defender_batch.json

``hj`` loads (or solves and caches) its tubes at ``--grid1`` / ``--grid2`` first.
"""

from __future__ import annotations

import argparse
import functools
from pathlib import Path
from typing import Any

import numpy as np
from harness import CPU, once, timed

import reachavoid_env
from policies.batch_defenders import BatchHJDefenders
from policies.defenders import HJDefenderPolicy
from policies.greedy import BatchGreedyDefenders
from reachavoid_env import BatchState, PerCopy
from solvers.hj.settings import TRAINING_GRIDS


def run(policy: Any, scenario: reachavoid_env.Scenario, copies: int,
        actions: np.ndarray) -> dict[str, float]:
    """Play ``len(actions)`` steps of ``copies`` games with ``policy`` (a ``BatchPolicy``);
    ``actions (steps, copies, M, 2)``: the attackers'. Returns CPU seconds in all and in
    the defenders (``harness.timed``) and the games played."""
    envs = [reachavoid_env.parallel_env(scenario=scenario, starts="random")
            for _ in range(copies)]
    for k, env in enumerate(envs):
        env.reset(seed=k)
    policy.reset_copies(np.arange(copies), [env.scenario for env in envs])
    games = copies
    defenders = 0.0

    def play() -> int:
        nonlocal games, defenders
        for step in actions:
            states = BatchState.of([env.game_state() for env in envs])
            chosen, seconds = once(functools.partial(policy.act_batch, states), clock=CPU)
            defenders += seconds
            games = step_copies(envs, step, chosen, policy, games)
        return len(actions)

    return {"all": timed(play, clock=CPU).seconds[0], "defenders": defenders, "games": games}


def step_copies(envs: list, step: np.ndarray, chosen: np.ndarray, policy: Any,
                games: int) -> int:
    """Step every copy with the attackers' ``step`` and the defenders' ``chosen`` actions,
    a copy whose game ended starting the next game; the games started so far."""
    ended = []
    for k, env in enumerate(envs):
        moves = {f"attacker_{i}": a for i, a in enumerate(step[k])}
        moves |= {f"defender_{j}": a for j, a in enumerate(chosen[k])}
        env.step({name: a for name, a in moves.items() if name in env.agents})
        if not env.agents:
            env.reset(seed=games)
            games += 1
            ended.append(k)
    if ended:
        policy.reset_copies(np.array(ended), [envs[k].scenario for k in ended])
    return games


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scenario", default="paper_8v4")
    parser.add_argument("--copies", type=int, default=64)
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--grid1", type=int, default=TRAINING_GRIDS.grid1)
    parser.add_argument("--grid2", type=int, default=TRAINING_GRIDS.grid2)
    parser.add_argument("--json", type=Path, help="write every figure to this file")
    args = parser.parse_args(argv)
    scenario = reachavoid_env.builtin_scenario(args.scenario)
    hj = HJDefenderPolicy.for_scenario(scenario, args.grid1, args.grid2, progress=False)
    builders = {
        "per-copy hj": lambda: PerCopy(lambda _: HJDefenderPolicy(hj.vf11, hj.vf21)),
        "batched hj": lambda: BatchHJDefenders(hj.vf11, hj.vf21),
        "batched greedy": BatchGreedyDefenders,
    }
    m = scenario.num_attackers
    actions = np.random.default_rng(0).uniform(
        -1, 1, (args.steps, args.copies, m, 2)).astype(np.float32)
    warm = actions[: min(20, args.steps)]
    for build in builders.values():  # compile and load everything once
        run(build(), scenario, args.copies, warm)
    rounds: dict[str, list[dict[str, float]]] = {name: [] for name in builders}
    for _ in range(args.repeats):
        for name, build in builders.items():
            rounds[name].append(run(build(), scenario, args.copies, actions))
    game_steps = args.steps * args.copies
    rows = {}
    for name, runs in rounds.items():
        best = min(runs, key=lambda r: r["all"])
        rows[name] = {"game_steps_per_s": game_steps / best["all"],
                      "defender_ms_per_step": 1000 * min(r["defenders"] for r in runs)
                      / args.steps,
                      "defender_us_per_copy_step": 1e6 * min(r["defenders"] for r in runs)
                      / game_steps,
                      "games": best["games"], "runs_s": [r["all"] for r in runs]}
        print(f"{name:>15}: {rows[name]['game_steps_per_s']:9.0f} game steps/s, defenders "
              f"{rows[name]['defender_ms_per_step']:7.2f} ms per step of {args.copies} "
              f"({rows[name]['defender_us_per_copy_step']:6.1f} us per copy)")
    rate = {name: row["game_steps_per_s"] for name, row in rows.items()}
    ratios = {"hj_over_greedy": rate["batched hj"] / rate["batched greedy"],
              "batched_over_per_copy_hj": rate["batched hj"] / rate["per-copy hj"],
              "defender_time_per_copy_over_batched_hj":
                  rows["per-copy hj"]["defender_ms_per_step"]
                  / rows["batched hj"]["defender_ms_per_step"]}
    for name, value in ratios.items():
        print(f"{name}: {value:.2f}")
    if args.json:
        from result_file import write_result

        figures: dict[str, float] = {}
        for name, row in rows.items():
            key = name.replace(" ", "_").replace("-", "_")
            for field in ("game_steps_per_s", "defender_ms_per_step",
                          "defender_us_per_copy_step"):
                figures[f"{field}.{key}"] = row[field]
        figures.update(ratios)
        where = f"{args.scenario}, K = {args.copies} copies, tubes {args.grid1}/{args.grid2}"
        write_result(args.json, "defender_batch", figures, {
            "game_steps_per_s": f"{where}: game steps per CPU second, best of the repeats",
            "defender_ms_per_step": f"{where}: the defenders' CPU ms per step of all copies",
            "defender_us_per_copy_step": f"{where}: the defenders' CPU us per copy and step",
            "hj_over_greedy": "batched hj's game steps/s over batched greedy's",
            "batched_over_per_copy_hj": "batched hj's game steps/s over PerCopy(hj)'s",
            "defender_time_per_copy_over_batched_hj": "PerCopy(hj)'s defender time over "
                                                      "batched hj's"})

if __name__ == "__main__":
    main()

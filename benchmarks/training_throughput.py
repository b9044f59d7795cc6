"""Training throughput: env steps per second with the defenders driven by a policy.

For each scenario (default ``paper_1v1``, ``paper_2v1``, ``paper_8v4``) and defender policy
(default ``greedy`` and ``hj``), 1000-step episodes, resets included:

- ``game``: ``ReachAvoidEnv`` alone, random actions for everyone (the floor);
- ``attackers``: ``AttackerParallelEnv``, the defenders moved by the policy, the attackers
  by uniform random actions (``random``: a learner early in training; the defenders catch
  many, so fewer attackers stay in play) or by the paper's ``shortest-path`` attacker
  (a competent learner: attackers stay in play until they arrive or are caught);
- ``single``: ``SingleAttackerEnv``, ``attacker_0`` random, the others shortest-path.

``hj`` rows are repeated with the wrappers' ``scripted_every`` set to each value of
``--every`` (the defenders decide every k env steps and hold their actions in between).
Each figure is env steps per CPU second (``--clock``; best and median of ``--repeats``
runs; the time the
attackers' own scripted policy takes is not counted), the share of the step time spent in
the defender policy's ``act``, and the mean number of attackers in play per step. The target
is at least 1,000 steps/s for ``attackers`` on ``paper_8v4`` with ``hj`` on one core:

    taskset -c 0 .venv/bin/python benchmarks/training_throughput.py [--steps 3000]

``hj`` defenders load (or solve and cache) their tubes at ``--grid1`` / ``--grid2`` first.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from policies.registry import DEFENDERS
from policies.training import attacker_factory, defender_factory
from reachavoid_env import ReachAvoidEnv, Scenario, load_scenario
from reachavoid_env.wrappers import AttackerParallelEnv, SingleAttackerEnv

EPISODE_STEPS = 1000
CLOCK = time.process_time
"""CPU time of this process (``--clock wall`` for wall time): on a shared machine the CPU
time of a one-core run is the steadier figure, and every row is timed alike."""
RATES: dict[str, float] = {}


class Timed:
    """A policy whose ``act`` time is added up in ``seconds``."""

    def __init__(self, policy: Any) -> None:
        self.policy = policy
        self.seconds = 0.0

    def reset(self, scenario: Scenario) -> None:
        self.policy.reset(scenario)

    def act(self, state: Any) -> dict[str, np.ndarray]:
        start = CLOCK()
        actions = self.policy.act(state)
        self.seconds += CLOCK() - start
        return actions


def random_actions(steps: int, players: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1, 1, (steps, players, 2)).astype(np.float32)


def run_game(env: ReachAvoidEnv, actions: np.ndarray, learners: Timed | None,
             ) -> tuple[float, float]:
    """Seconds for ``len(actions)`` steps and the mean attackers in play per step."""
    index = {name: k for k, name in enumerate(env.possible_agents)}
    env.reset(seed=0)
    in_play = 0
    start = CLOCK()
    for drawn in actions:
        if not env.agents:
            env.reset()
        env.step({name: drawn[index[name]] for name in env.agents})
        in_play += sum(name.startswith("attacker") for name in env.agents)
    return CLOCK() - start, in_play / len(actions)


def run_attackers(env: AttackerParallelEnv, actions: np.ndarray, learners: Timed | None,
                  ) -> tuple[float, float]:
    index = {name: k for k, name in enumerate(env.possible_agents)}
    env.reset(seed=0)
    if learners is not None:
        learners.reset(env.game.scenario)
    in_play = 0
    start = CLOCK()
    for drawn in actions:
        if not env.agents:
            env.reset()
            if learners is not None:
                learners.reset(env.game.scenario)
        if learners is None:
            env.step({name: drawn[index[name]] for name in env.agents})
        else:
            env.step(learners.act(env.game_state()))
        in_play += len(env.agents)
    return CLOCK() - start, in_play / len(actions)


def run_single(env: SingleAttackerEnv, actions: np.ndarray, learners: Timed | None,
               ) -> tuple[float, float]:
    env.reset(seed=0)
    in_play = 0
    start = CLOCK()
    for drawn in actions:
        _, _, terminated, truncated, _ = env.step(drawn[0])
        if terminated or truncated:
            env.reset()
        in_play += int(env.game_state().active_attackers.sum())
    return CLOCK() - start, in_play / len(actions)


def measure(label: str, run: Callable[..., tuple[float, float]], env: Any,
            actions: np.ndarray, defenders: Timed | None, repeats: int,
            learners: Timed | None = None) -> None:
    rates, shares, in_play = [], [], []
    for _ in range(repeats):
        for timed in (defenders, learners):
            if timed is not None:
                timed.seconds = 0.0
        seconds, attackers = run(env, actions, learners)
        if learners is not None:
            seconds -= learners.seconds
        rates.append(len(actions) / seconds)
        shares.append(defenders.seconds / seconds if defenders is not None else 0.0)
        in_play.append(attackers)
    RATES[label] = statistics.median(rates)
    share = f"defenders {statistics.median(shares):>4.0%}" if defenders is not None else ""
    print(f"{label:<42} best {max(rates):>7,.0f}/s  median {statistics.median(rates):>7,.0f}/s"
          f"  {share:<15} attackers in play {statistics.mean(in_play):.1f}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scenarios", nargs="+", default=["paper_1v1", "paper_2v1",
                                                             "paper_8v4"])
    parser.add_argument("--defenders", nargs="+", default=["greedy", "hj"],
                        choices=list(DEFENDERS))
    parser.add_argument("--every", nargs="+", type=int, default=[1, 5],
                        help="scripted_every values for hj rows (default: 1 5)")
    parser.add_argument("--grid1", type=int, default=31, help="hj 1v1 tube nodes per axis")
    parser.add_argument("--grid2", type=int, default=15, help="hj 2v1 tube nodes per axis")
    parser.add_argument("--steps", type=int, default=3000, help="env steps per timed run")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs per figure")
    parser.add_argument("--clock", choices=["cpu", "wall"], default="cpu",
                        help="time CPU seconds of this process or wall seconds")
    args = parser.parse_args()
    global CLOCK
    CLOCK = time.process_time if args.clock == "cpu" else time.perf_counter

    cores = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else "?"
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores "
          f"(this process may run on {cores}), Python {platform.python_version()}; load "
          f"average {', '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for name in args.scenarios:
        scenario = load_scenario(name)
        players = scenario.num_attackers + scenario.num_defenders
        actions = random_actions(args.steps, players, seed=0)
        print(f"\n{name} ({scenario.num_attackers} vs {scenario.num_defenders})")
        game = ReachAvoidEnv(scenario=scenario, max_cycles=EPISODE_STEPS)
        measure("game, all random", run_game, game, actions, None, args.repeats)
        shortest = Timed(attacker_factory("shortest-path")(scenario))
        for defenders in args.defenders:
            options = ({"grid1": args.grid1, "grid2": args.grid2, "progress": False}
                       if defenders == "hj" else {})
            policy = Timed(defender_factory(defenders, **options)(scenario))
            for every in args.every if defenders == "hj" else [1]:
                label = defenders + (f", every {every}" if every > 1 else "")
                kwargs = {"scenario": scenario, "max_cycles": EPISODE_STEPS,
                          "scripted_every": every}
                env = AttackerParallelEnv(policy, **kwargs)
                measure(f"attackers random, {label}", run_attackers, env, actions, policy,
                        args.repeats)
                measure(f"attackers shortest-path, {label}", run_attackers, env, actions,
                        policy, args.repeats, learners=shortest)
                single = SingleAttackerEnv(policy, teammates=attacker_factory()(scenario),
                                           **kwargs)
                measure(f"single, {label}", run_single, single, actions, policy,
                        args.repeats)
        if {"greedy", "hj"} <= set(args.defenders):
            for kind in ("attackers random", "attackers shortest-path", "single"):
                print(f"  {kind}: hj / greedy = "
                      f"{RATES[f'{kind}, hj'] / RATES[f'{kind}, greedy']:.0%} (medians)")


if __name__ == "__main__":
    main()

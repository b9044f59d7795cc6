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

With both ``greedy`` and ``hj`` (deciding every step), their runs of each env alternate
(greedy, hj, greedy, hj, ... ``--repeats`` pairs, same process): the machine's drift
between runs hits both alike, and each pair gives one hj / greedy ratio; the median ratio
is printed with its range over the pairs. ``--json FILE`` writes every run's rate.
Scripts under ``benchmarks/`` import the installed package: to time a checkout, put it
first on the path (``PYTHONPATH=$PWD``).

``hj`` defenders load (or solve and cache) their tubes at ``--grid1`` / ``--grid2`` first.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from harness import CPU, WALL, once, timed, training_views

from policies.registry import DEFENDERS
from reachavoid_env import ReachAvoidEnv, Scenario, load_scenario
from reachavoid_env.wrappers import AttackerParallelEnv, SingleAttackerEnv
from solvers.hj.settings import TRAINING_GRIDS

EPISODE_STEPS = 1000
CLOCK = CPU
"""CPU time of this process (``--clock wall`` for wall time): on a shared machine the CPU
time of a one-core run is the steadier figure, and every row is timed alike."""


class Timed:
    """A policy whose ``act`` time is added up in ``seconds``."""

    def __init__(self, policy: Any) -> None:
        self.policy = policy
        self.seconds = 0.0

    def reset(self, scenario: Scenario) -> None:
        self.policy.reset(scenario)

    def act(self, state: Any) -> dict[str, np.ndarray]:
        actions, seconds = once(lambda: self.policy.act(state), clock=CLOCK)
        self.seconds += seconds
        return actions


def random_actions(steps: int, players: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1, 1, (steps, players, 2)).astype(np.float32)


def run_game(env: ReachAvoidEnv, actions: np.ndarray, learners: Timed | None) -> float:
    """``len(actions)`` steps (a new episode where one ended); the mean attackers in play
    per step."""
    index = {name: k for k, name in enumerate(env.possible_agents)}
    env.reset(seed=0)
    in_play = 0
    for drawn in actions:
        if not env.agents:
            env.reset()
        env.step({name: drawn[index[name]] for name in env.agents})
        in_play += sum(name.startswith("attacker") for name in env.agents)
    return in_play / len(actions)


def run_attackers(env: AttackerParallelEnv, actions: np.ndarray, learners: Timed | None
                  ) -> float:
    """As ``run_game``, the attackers random or moved by ``learners``."""
    index = {name: k for k, name in enumerate(env.possible_agents)}
    env.reset(seed=0)
    if learners is not None:
        learners.reset(env.game.scenario)
    in_play = 0
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
    return in_play / len(actions)


def run_single(env: SingleAttackerEnv, actions: np.ndarray, learners: Timed | None) -> float:
    """As ``run_game``, ``attacker_0`` random, its teammates the env's."""
    env.reset(seed=0)
    in_play = 0
    for drawn in actions:
        _, _, terminated, truncated, _ = env.step(drawn[0])
        if terminated or truncated:
            env.reset()
        in_play += int(env.game_state().active_attackers.sum())
    return in_play / len(actions)


class Rows:
    """Every timed run's rate, defenders' share and attackers in play, by row label."""

    def __init__(self) -> None:
        self.runs: dict[str, list[tuple[float, float, float]]] = {}

    def time(self, label: str, run: Callable[..., float], env: Any,
             actions: np.ndarray, defenders: Timed | None,
             learners: Timed | None = None) -> None:
        """One timed run of ``env`` (the learners' own decisions not counted), added to
        ``label``'s row."""
        for policy in (defenders, learners):
            if policy is not None:
                policy.seconds = 0.0
        attackers = []
        timing = timed(lambda: attackers.append(run(env, actions, learners)) or len(actions),
                       clock=CLOCK, untimed=lambda: learners.seconds if learners else 0.0)
        share = defenders.seconds / timing.seconds[0] if defenders is not None else 0.0
        self.runs.setdefault(label, []).append((timing.rates[0], share, attackers[0]))

    def rates(self, label: str) -> list[float]:
        return [rate for rate, _, _ in self.runs[label]]

    def report(self, label: str) -> None:
        rates = self.rates(label)
        shares = [share for _, share, _ in self.runs[label]]
        share = f"defenders {statistics.median(shares):>4.0%}" if max(shares) > 0 else ""
        in_play = statistics.mean(attackers for _, _, attackers in self.runs[label])
        print(f"{label:<52} best {max(rates):>7,.0f}/s  median "
              f"{statistics.median(rates):>7,.0f}/s  {share:<15} attackers in play "
              f"{in_play:.1f}", flush=True)


def ratio_line(kind: str, hj: list[float], greedy: list[float]) -> str:
    """The median and range of the per-pair hj / greedy ratios."""
    ratios = [h / g for h, g in zip(hj, greedy, strict=True)]
    return (f"  {kind}: hj / greedy = {statistics.median(ratios):.0%} (median of "
            f"{len(ratios)} pairs, range {min(ratios):.0%}-{max(ratios):.0%})")


def measure(argv: list[str] | None = None) -> dict[str, list[tuple[float, float, float]]]:
    """Every row the options ``argv`` ask for, timed and printed; each row's runs (rate,
    the defenders' share, attackers in play), what ``--json`` writes
    (``compare_throughput.py`` runs this in each checkout)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scenarios", nargs="+", default=["paper_1v1", "paper_2v1",
                                                             "paper_8v4"])
    parser.add_argument("--defenders", nargs="+", default=["greedy", "hj"],
                        choices=list(DEFENDERS))
    parser.add_argument("--every", nargs="+", type=int, default=[1, 5],
                        help="scripted_every values for hj rows (default: 1 5)")
    parser.add_argument("--grid1", type=int, default=TRAINING_GRIDS.grid1,
                        help="hj 1v1 tube nodes per axis")
    parser.add_argument("--grid2", type=int, default=TRAINING_GRIDS.grid2,
                        help="hj 2v1 tube nodes per axis")
    parser.add_argument("--steps", type=int, default=3000, help="env steps per timed run")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs per figure")
    parser.add_argument("--clock", choices=["cpu", "wall"], default="cpu",
                        help="time CPU seconds of this process or wall seconds")
    parser.add_argument("--json", help="write every run's steps/s to this file")
    args = parser.parse_args(argv)
    global CLOCK
    CLOCK = CPU if args.clock == "cpu" else WALL

    cores = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else "?"
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores "
          f"(this process may run on {cores}), Python {platform.python_version()}; load "
          f"average {', '.join(f'{x:.2f}' for x in os.getloadavg())}")
    rows = Rows()
    for name in args.scenarios:
        time_scenario(name, args, rows)
    if args.json:
        Path(args.json).write_text(json.dumps(rows.runs, indent=1) + "\n")
    return rows.runs


def time_scenario(name: str, args: argparse.Namespace, rows: Rows) -> None:
    """Every row of scenario ``name``: the game alone, then each env with each defender
    policy (greedy and hj alternating, run by run)."""
    scenario = load_scenario(name)
    players = scenario.num_attackers + scenario.num_defenders
    actions = random_actions(args.steps, players, seed=0)
    print(f"\n{name} ({scenario.num_attackers} vs {scenario.num_defenders})")
    game = ReachAvoidEnv(scenario=scenario, max_cycles=EPISODE_STEPS)
    for _ in range(args.repeats):
        rows.time(f"{name}: game, all random", run_game, game, actions, None)
    rows.report(f"{name}: game, all random")
    views = training_views()
    shortest = Timed(views.attacker_factory("shortest-path")(scenario))
    configs = [(defenders, every) for defenders in args.defenders
               for every in (args.every if defenders == "hj" else [1])]
    paired = {("greedy", 1), ("hj", 1)} <= set(configs)
    envs = {}
    for defenders, every in configs:
        options = ({"grid1": args.grid1, "grid2": args.grid2, "progress": False}
                   if defenders == "hj" else {})
        policy = Timed(views.defender_factory(defenders, **options)(scenario))
        kwargs = {"scenario": scenario, "max_cycles": EPISODE_STEPS,
                  "scripted_every": every}
        envs[defenders, every] = (policy, AttackerParallelEnv(policy, **kwargs),
                                  SingleAttackerEnv(policy, teammates=views.attacker_factory()(
                                      scenario), **kwargs))
    for kind, run in (("attackers random", run_attackers),
                      ("attackers shortest-path", run_attackers), ("single", run_single)):
        groups = ([[("greedy", 1), ("hj", 1)]] if paired else []) + [
            [config] for config in configs
            if not paired or config not in (("greedy", 1), ("hj", 1))]
        for group in groups:
            for defenders, every in group:  # untimed: compiles, maps the tubes in
                policy, attackers_env, single_env = envs[defenders, every]
                run(single_env if kind == "single" else attackers_env,
                    actions[:len(actions) // 10], shortest if kind.endswith("path") else None)
            for _ in range(args.repeats):
                for defenders, every in group:
                    policy, attackers_env, single_env = envs[defenders, every]
                    rows.time(f"{name}: {kind}, {_label(defenders, every)}", run,
                              single_env if kind == "single" else attackers_env, actions,
                              policy, shortest if kind.endswith("shortest-path") else None)
            for defenders, every in group:
                rows.report(f"{name}: {kind}, {_label(defenders, every)}")
            if len(group) == 2:
                print(ratio_line(kind, rows.rates(f"{name}: {kind}, hj"),
                                 rows.rates(f"{name}: {kind}, greedy")))


def _label(defenders: str, every: int) -> str:
    return defenders + (f", every {every}" if every > 1 else "")


if __name__ == "__main__":
    measure()

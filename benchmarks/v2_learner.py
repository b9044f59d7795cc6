"""Does v2 teach? Stock Stable-Baselines3 PPO on v2's shaped reward for ``--cpu-minutes``
of CPU time, against random attackers, on 200 seeded starts.

The attackers of ``paper_2v1`` learn one shared policy (SuperSuit's vector env, a slot per
attacker, ``remove_agents=False``, ``reward="shaped"``) against ``greedy`` defenders (each
runs at the nearest attacker), with ``PPO("MlpPolicy", env)``'s stock settings. Then both
the learned policy (deterministic) and uniformly random actions play the same
``--starts`` seeded starts against the same defenders: the mean arrivals per start of
each, and the paired difference (learned minus random) with its normal 95% interval.

    taskset -c 1 python benchmarks/v2_learner.py --json benchmarks/results/v2_learner.json
"""

from __future__ import annotations

import argparse
import math
import time
from typing import Any

import numpy as np
import supersuit as ss
import torch
from pettingzoo import ParallelEnv
from result_file import write_result
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback

from policies import GreedyDefender
from reachavoid_env import reach_avoid_v2

SCENARIO = "paper_2v1"


class Attackers(ParallelEnv):
    """v2's attackers as the agents; greedy defenders act every decision."""

    metadata = {"name": "v2_attackers", "render_modes": []}
    render_mode = None

    def __init__(self) -> None:
        self.game = reach_avoid_v2.parallel_env(scenario=SCENARIO, reward="shaped",
                                                remove_agents=False)
        self.defenders = GreedyDefender()
        self.possible_agents = self.game.scenario.attacker_names
        self.agents: list[str] = []

    def observation_space(self, agent: str) -> Any:
        return self.game.observation_space(agent)

    def action_space(self, agent: str) -> Any:
        return self.game.action_space(agent)

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple:
        observations, infos = self.game.reset(seed=seed)
        self.defenders.reset(self.game.scenario)
        self.agents = self.possible_agents[:]
        return ({a: observations[a] for a in self.agents}, {a: infos[a] for a in self.agents})

    def step(self, actions: dict[str, Any]) -> tuple:
        moves = {**self.defenders.act(self.game.game_state()), **actions}
        out = self.game.step({a: moves[a] for a in self.game.agents})
        live, self.agents = self.agents, (self.agents if self.game.agents else [])
        return tuple({a: part[a] for a in live} for part in out)


class CpuBudget(BaseCallback):
    """Stops training once the process has used ``seconds`` of CPU time."""

    def __init__(self, seconds: float) -> None:
        super().__init__()
        self.seconds, self.start = seconds, time.process_time()

    def _on_step(self) -> bool:
        return time.process_time() - self.start < self.seconds


def arrivals(act: Any, starts: int) -> np.ndarray:
    """Arrivals per start (seeds 10,000 on) with ``act(observations) -> actions``."""
    env, counts = Attackers(), []
    for seed in range(10_000, 10_000 + starts):
        observations, _ = env.reset(seed=seed)
        while env.agents:
            observations, _, _, _, infos = env.step(act(observations))
        counts.append(infos["attacker_0"]["arrived"])
    return np.array(counts, dtype=float)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cpu-minutes", type=float, default=10.0)
    parser.add_argument("--starts", type=int, default=200)
    parser.add_argument("--json", help="write the result record here")
    args = parser.parse_args()
    torch.set_num_threads(1)
    torch.manual_seed(0)
    vec = ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(Attackers()), 4, num_cpus=0,
                                base_class="stable_baselines3")
    vec.venv.reset(seed=0)
    model = PPO("MlpPolicy", vec, device="cpu", verbose=0)
    budget = CpuBudget(60 * args.cpu_minutes)
    model.learn(10**9, callback=budget)
    steps, cpu_s = model.num_timesteps, time.process_time() - budget.start
    rng = np.random.default_rng(0)
    learned = arrivals(lambda obs: {a: model.predict(o, deterministic=True)[0]
                                    for a, o in obs.items()}, args.starts)
    random = arrivals(lambda obs: {a: rng.uniform(-1, 1, 2).astype(np.float32)
                                   for a in obs}, args.starts)
    diff = learned - random
    half = 1.959964 * diff.std(ddof=1) / math.sqrt(len(diff))
    figures = {"arrivals_per_start.learned": float(learned.mean()),
               "arrivals_per_start.random": float(random.mean()),
               "paired_difference": [float(diff.mean()), float(diff.mean() - half),
                                     float(diff.mean() + half)],
               "training.agent_steps": float(steps),
               "training.cpu_s": cpu_s}
    for key, value in figures.items():
        print(f"{key}: {value}")
    if args.json:
        write_result(args.json, "v2_learner", figures, {
            "arrivals_per_start": f"mean arrivals per start (of 2 attackers) over {args.starts} "
                                  f"seeded paper_2v1 starts against greedy defenders",
            "paired_difference": "learned minus random arrivals per start, [mean, low, high] "
                                 "(normal 95%)",
            "training": "stock SB3 PPO on v2 reward='shaped': agent steps, CPU seconds of the "
                        "training (before the evaluation)"})


if __name__ == "__main__":
    main()

"""Stable-Baselines3 PPO with SuperSuit on ReachAvoid-v2, as PettingZoo's waterworld
tutorial: every agent (attackers and defenders) is one slot of a vector env and all slots
share one policy. ``remove_agents=False`` keeps the agents that leave in their slots, so
SuperSuit's ``MarkovVectorEnv`` runs without ``black_death``.

    python examples/sb3_supersuit_v2.py --timesteps 200000

Prints the absolute reward seen and the episodes finished, then ``done``.
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass

import numpy as np
import supersuit as ss
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.utils import set_random_seed

from reachavoid_env import reach_avoid_v2


@dataclass
class Config:
    scenario: str = "paper_2v1"
    reward: str = "shaped"
    copies: int = 4            # games stepped together (each gives a slot per agent)
    timesteps: int = 200_000   # agent steps in all
    n_steps: int = 256         # PPO rollout per slot
    seed: int = 0


class Seen(BaseCallback):
    """Sums the absolute rewards of the rollouts and counts the finished games."""

    def __init__(self) -> None:
        super().__init__()
        self.reward, self.games = 0.0, 0

    def _on_step(self) -> bool:
        self.reward += float(np.abs(self.locals["rewards"]).sum())
        self.games += int(self.locals["dones"].sum())
        return True


def main(config: Config) -> None:
    torch.set_num_threads(1)
    set_random_seed(config.seed)   # Python's, numpy's and torch's generators
    env = reach_avoid_v2.parallel_env(scenario=config.scenario, reward=config.reward,
                                      remove_agents=False)
    vec = ss.pettingzoo_env_to_vec_env_v1(env)
    vec = ss.concat_vec_envs_v1(vec, config.copies, num_cpus=0, base_class="stable_baselines3")
    # PPO(seed=) calls the vector env's seed(), which SuperSuit's lacks: seed the games
    # through the concatenated env's reset instead (copy i with seed + i; later resets
    # draw on from there).
    vec.venv.reset(seed=config.seed)
    model = PPO("MlpPolicy", vec, n_steps=config.n_steps, batch_size=config.n_steps,
                device="cpu", verbose=0)
    seen = Seen()
    model.learn(config.timesteps, callback=seen)
    vec.close()
    print(f"reward seen {seen.reward:.4g} over {seen.games} agent-episodes")
    print("done")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    for field in dataclasses.fields(Config):
        parser.add_argument(f"--{field.name.replace('_', '-')}", type=type(field.default),
                            default=field.default)
    main(Config(**vars(parser.parse_args())))

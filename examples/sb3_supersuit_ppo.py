"""Every attacker learns one shared Stable-Baselines3 PPO policy, on the attacker-only env
vectorised by SuperSuit.

Needs the ``rl`` extra (torch, stable-baselines3, supersuit).
``reachavoid_env.integrations.supersuit.sb3_vec_env`` makes the vector env (a slot per
attacker and game copy; ``black_death_v3`` keeps the slots of attackers that have left):

    python examples/sb3_supersuit_ppo.py --scenario paper_6v2 --defenders hj --timesteps 100000

``PPO(seed=...)`` seeds the games through their ``reset``.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from typing import Any

import torch
from stable_baselines3 import PPO
from stable_baselines3.common.logger import KVWriter, Logger

from reachavoid.training.flags import (
    DefenderFields,
    RewardFields,
    attackers_from_args,
    config_parser,
)
from reachavoid_env.integrations.supersuit import sb3_vec_env


@dataclass
class Config(RewardFields, DefenderFields):
    copies: int = field(default=2, metadata={"help": "game copies in the vector env"})
    timesteps: int = field(default=100_000, metadata={"help": "agent steps"})
    n_steps: int = field(default=256, metadata={"help": "PPO rollout per slot"})
    seed: int = 0               # PPO's seed (torch, numpy, the games' resets)


class Records(KVWriter):
    """Keeps what SB3 logs (one dict per rollout) in memory."""

    def __init__(self) -> None:
        self.rows: list[dict[str, Any]] = []

    def write(self, key_values: dict[str, Any], key_excluded: dict[str, Any],
              step: int = 0) -> None:
        self.rows.append(dict(key_values))


def main(config: Config) -> None:
    """Trains; prints SB3's log rows (``train/loss``, ``rollout/ep_rew_mean``, ...), one per
    rollout, then the timesteps and slots."""
    torch.set_num_threads(1)    # small networks: more threads only contend for the cores
    # the vector env, with SB3's episode statistics (one episode per slot and game); the
    # flags' helper reads the defender and reward fields of the config
    envs = sb3_vec_env(attackers_from_args(config), copies=config.copies)
    model = PPO("MlpPolicy", envs, n_steps=config.n_steps, batch_size=config.n_steps,
                seed=config.seed, device="cpu", verbose=0)
    records = Records()
    model.set_logger(Logger(None, [records]))
    model.learn(config.timesteps, progress_bar=sys.stderr.isatty())
    envs.close()
    for row in records.rows:
        print(", ".join(f"{key} {value:.4g}" for key, value in row.items()
                        if isinstance(value, float)), flush=True)
    print(f"timesteps {model.num_timesteps}, slots {model.n_envs}")


if __name__ == "__main__":
    parser = config_parser(Config, __doc__.split("\n\n")[0])
    main(Config(**vars(parser.parse_args())))

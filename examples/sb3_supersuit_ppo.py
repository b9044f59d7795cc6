"""Every attacker learns one shared Stable-Baselines3 PPO policy, on the attacker-only env
vectorised by SuperSuit.

Needs the ``rl`` extra (torch, stable-baselines3, supersuit).
``reachavoid_env.integrations.supersuit.sb3_vec_env`` makes the vector env (a slot per
attacker and game copy; ``black_death_v3`` keeps the slots of attackers that have left):

    python examples/sb3_supersuit_ppo.py --scenario paper_6v2 --defenders hj --timesteps 100000

``PPO(seed=...)`` seeds the games through their ``reset``.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

import torch
from stable_baselines3 import PPO
from stable_baselines3.common.logger import KVWriter, Logger
from stable_baselines3.common.vec_env import VecEnv

from reachavoid.training.flags import (
    add_defender_arguments,
    add_reward_arguments,
    attackers_from_args,
)
from reachavoid_env.integrations.supersuit import sb3_vec_env


class Records(KVWriter):
    """Keeps what SB3 logs (one dict per rollout) in memory."""

    def __init__(self) -> None:
        self.rows: list[dict[str, Any]] = []

    def write(self, key_values: dict[str, Any], key_excluded: dict[str, Any],
              step: int = 0) -> None:
        self.rows.append(dict(key_values))


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    add_defender_arguments(parser, scenario="paper_6v2")
    parser.add_argument("--copies", type=int, default=2, help="game copies in the vector env")
    parser.add_argument("--timesteps", type=int, default=100_000, help="agent steps")
    parser.add_argument("--n-steps", type=int, default=256, help="PPO rollout per slot")
    add_reward_arguments(parser, team=True)
    parser.add_argument("--seed", type=int, default=0)
    return parser.parse_args(argv)


def make_vec_env(args: argparse.Namespace) -> VecEnv:
    """The vector env, with SB3's episode statistics (one episode per slot and game)."""
    return sb3_vec_env(attackers_from_args(args), copies=args.copies)


def main(argv: Sequence[str] | None = None) -> tuple[PPO, list[dict[str, Any]]]:
    """Trains; returns the model and SB3's log rows (``train/loss``, ``rollout/ep_rew_mean``,
    ...), one per rollout."""
    args = parse_args(argv)
    torch.set_num_threads(1)    # small networks: more threads only contend for the cores
    envs = make_vec_env(args)
    model = PPO("MlpPolicy", envs, n_steps=args.n_steps, batch_size=args.n_steps,
                seed=args.seed, device="cpu", verbose=0)
    records = Records()
    model.set_logger(Logger(None, [records]))
    model.learn(args.timesteps, progress_bar=sys.stderr.isatty())
    envs.close()
    for row in records.rows:
        print(", ".join(f"{key} {value:.4g}" for key, value in row.items()
                        if isinstance(value, float)), flush=True)
    print(f"timesteps {model.num_timesteps}, slots {model.n_envs}")
    return model, records.rows


if __name__ == "__main__":
    main()

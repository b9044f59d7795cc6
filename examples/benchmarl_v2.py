"""MAPPO with BenchMARL on ReachAvoid-v2 (``ReachAvoidTask.REACH_AVOID_V2``): attackers and
defenders each learn a shared policy, one group per team.

Needs the ``benchmarl`` extra in a virtual environment of its own (BenchMARL pins
torchrl < 0.12):

    python examples/benchmarl_v2.py --frames 200000 --out runs/benchmarl_v2

Prints the reward seen in each collected batch per group, then ``done``.
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass
from pathlib import Path

import torch
from benchmarl.algorithms import MappoConfig
from benchmarl.experiment import Callback, Experiment, ExperimentConfig
from benchmarl.models import MlpConfig
from tensordict import TensorDictBase

from reachavoid_env.integrations.benchmarl import ReachAvoidTask


@dataclass
class Config:
    scenario: str = "paper_2v1"
    reward: str = "shaped"
    continuous_actions: int = 1   # 0: BenchMARL's discrete MAPPO on v2's Discrete(9)
    frames: int = 200_000
    batch: int = 2_000            # decisions per iteration
    seed: int = 0
    out: str = "runs/benchmarl_v2"


class Seen(Callback):
    """Prints the absolute reward of each collected batch per group."""

    def on_batch_collected(self, batch: TensorDictBase) -> None:
        print("reward seen " + ", ".join(
            f"{group} {batch['next', group, 'reward'].abs().sum().item():.4g}"
            for group in self.experiment.group_map), flush=True)


def main(c: Config) -> None:
    torch.set_num_threads(1)
    Path(c.out).mkdir(parents=True, exist_ok=True)
    task = ReachAvoidTask.REACH_AVOID_V2.get_task({"scenario": c.scenario,
                                                   "reward": c.reward})
    config = ExperimentConfig.get_from_yaml()
    config.max_n_frames = c.frames
    config.on_policy_collected_frames_per_batch = c.batch
    config.on_policy_n_envs_per_worker = 1
    config.on_policy_minibatch_size = min(400, c.batch)
    config.prefer_continuous_actions = bool(c.continuous_actions)
    config.evaluation, config.render, config.checkpoint_at_end = False, False, False
    config.loggers = ["csv"]
    config.save_folder = c.out
    mlp = MlpConfig.get_from_yaml()
    Experiment(task=task, algorithm_config=MappoConfig.get_from_yaml(), model_config=mlp,
               critic_model_config=mlp, seed=c.seed, config=config,
               callbacks=[Seen()]).run()
    print("done")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    for field in dataclasses.fields(Config):
        parser.add_argument(f"--{field.name.replace('_', '-')}", type=type(field.default),
                            default=field.default)
    main(Config(**vars(parser.parse_args())))

"""MAPPO on the game with BenchMARL: attackers and defenders each learn a shared policy, or
the attackers alone learn against scripted defenders.

Needs the ``benchmarl`` extra in a virtual environment of its own (BenchMARL pins
torchrl < 0.12): ``pip install -e '.[benchmarl]'``. ``--task game`` (the default) is
``reachavoid_env.integrations.benchmarl.ReachAvoidTask.REACH_AVOID``, both teams learning;
``--task attackers`` is ``reachavoid.training.benchmarl_task.ScriptedDefendersTask.ATTACKERS``, the
attackers of ``--envs`` copies stepped together learning against ``--defenders`` (``hj`` on
``--grid1`` / ``--grid2`` tubes by default):

    python examples/benchmarl_mappo.py --scenario paper_2v1 --frames 60000 --out runs/benchmarl
    python examples/benchmarl_mappo.py --task attackers --scenario paper_6v2 --envs 16 \
        --frames 200000 --out runs/benchmarl_attackers

BenchMARL writes its logs (CSV) and JSON results under ``--out``.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import torch
from benchmarl.algorithms import MappoConfig
from benchmarl.environments.common import TaskClass
from benchmarl.experiment import Callback, Experiment, ExperimentConfig
from benchmarl.models import MlpConfig
from tensordict import TensorDictBase

from reachavoid.training.benchmarl_task import ScriptedDefendersTask
from reachavoid.training.flags import add_defender_arguments, defender_options
from reachavoid_env.integrations.benchmarl import ReachAvoidTask


class Losses(Callback):
    """Keeps each group's mean losses of every training iteration."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[dict[str, Any]] = []

    def on_train_end(self, training_td: TensorDictBase, group: str) -> None:
        self.rows.append({"group": group} | {
            key: training_td[key].mean().item() for key in training_td.keys()
            if key.startswith("loss_")})


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--task", choices=("game", "attackers"), default="game",
                        help="game: both teams learn; attackers: the attackers learn against "
                             "scripted --defenders")
    add_defender_arguments(parser, scenario="paper_2v1")
    parser.add_argument("--envs", type=int, default=16,
                        help="copies stepped together (--task attackers)")
    parser.add_argument("--max-cycles", type=int, default=300, help="steps per episode")
    parser.add_argument("--frames", type=int, default=60_000,
                        help="total env steps (a batched step counts one per copy)")
    parser.add_argument("--batch", type=int, default=1000, help="env steps per iteration")
    parser.add_argument("--shaping", type=float, default=1.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("runs/benchmarl"))
    args = parser.parse_args(argv)
    if args.envs < 1:
        parser.error(f"--envs: expected at least 1, got {args.envs}")
    if args.task == "attackers" and args.batch % args.envs:
        parser.error(f"--batch: a batched step is --envs ({args.envs}) env steps, so "
                     f"--batch must be a multiple of it, got {args.batch}")
    return args


def build_task(args: argparse.Namespace) -> TaskClass:
    """The BenchMARL task of ``--task``."""
    game = {"scenario": args.scenario, "max_cycles": args.max_cycles, "shaping": args.shaping}
    if args.task == "game":
        return ReachAvoidTask.REACH_AVOID.get_task(game)
    return ScriptedDefendersTask.ATTACKERS.get_task(
        game | {"defenders": args.defenders, "defender_options": defender_options(args)})


def build_experiment(args: argparse.Namespace, callbacks: list[Callback]) -> Experiment:
    task = build_task(args)
    config = ExperimentConfig.get_from_yaml()
    config.max_n_frames = args.frames
    config.on_policy_collected_frames_per_batch = args.batch
    config.on_policy_n_envs_per_worker = args.envs if args.task == "attackers" else 1
    config.on_policy_minibatch_size = min(400, args.batch)
    config.on_policy_n_minibatch_iters = 4
    config.evaluation = False
    config.render = False
    config.loggers = ["csv"]
    config.save_folder = args.out
    config.checkpoint_at_end = False
    return Experiment(task=task, algorithm_config=MappoConfig.get_from_yaml(),
                      model_config=MlpConfig.get_from_yaml(),
                      critic_model_config=MlpConfig.get_from_yaml(), seed=args.seed,
                      config=config, callbacks=callbacks)


def main(argv: Sequence[str] | None = None) -> tuple[Experiment, list[dict[str, Any]]]:
    """Runs the experiment; returns it and the per-iteration losses of each group."""
    args = parse_args(argv)
    torch.set_num_threads(1)    # small networks: more threads only contend for the cores
    args.out.mkdir(parents=True, exist_ok=True)
    losses = Losses()
    experiment = build_experiment(args, [losses])
    experiment.run()
    for row in losses.rows:
        print(", ".join(f"{key} {value:.4g}" if isinstance(value, float) else str(value)
                        for key, value in row.items()), flush=True)
    return experiment, losses.rows


if __name__ == "__main__":
    main()

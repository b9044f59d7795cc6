"""A BenchMARL MAPPO experiment on the game (``benchmarl`` extra, in a virtual environment of
its own): both teams learning a shared policy each, or the attackers alone against scripted
defenders.

    from reachavoid.training.benchmarl_experiment import MappoSettings, run

    experiment, losses = run(MappoSettings(task="attackers", scenario="paper_6v2",
                                           defenders="greedy", envs=16, frames=200_000))

``MappoSettings.task`` ``"game"`` is ``reachavoid_env.integrations.benchmarl.ReachAvoidTask
.REACH_AVOID``; ``"attackers"`` is ``reachavoid.training.benchmarl_task
.ScriptedDefendersTask.ATTACKERS``, the attackers of ``envs`` copies stepped together. BenchMARL
writes its logs (CSV) and JSON results under ``out``. BenchMARL and torch are imported here
alone (``examples/benchmarl_mappo.py`` runs this).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from benchmarl.algorithms import MappoConfig
from benchmarl.environments.common import TaskClass
from benchmarl.experiment import Callback, Experiment, ExperimentConfig
from benchmarl.models import MlpConfig
from tensordict import TensorDictBase

from reachavoid.training.benchmarl_task import ScriptedDefendersTask
from reachavoid_env import checks
from reachavoid_env.integrations.benchmarl import ReachAvoidTask

TASKS = ("game", "attackers")
"""``MappoSettings.task``: both teams learn, or the attackers against scripted defenders."""


@dataclass
class MappoSettings:
    """What ``run`` trains: the ``task`` (``TASKS``) on ``scenario`` with ``max_cycles``
    steps per episode and progress reward weight ``shaping``; for ``"attackers"`` the
    scripted ``defenders`` (with their ``defender_options``) and the ``envs`` copies stepped
    together (``batch`` a multiple of it). ``frames`` env steps in all (a batched step
    counts one per copy), ``batch`` per iteration; ``seed``; logs under ``out``. A bad
    value is a ``checks.FieldError`` naming its field, raised on construction."""

    task: str = "game"
    scenario: str = "paper_2v1"
    defenders: str = "hj"
    defender_options: dict[str, Any] | None = None
    envs: int = 16
    max_cycles: int = 300
    frames: int = 60_000
    batch: int = 1000
    shaping: float = 1.0
    seed: int = 0
    out: Path = Path("runs/benchmarl")

    def __post_init__(self) -> None:
        if self.task not in TASKS:
            raise checks.FieldError(f"task: expected one of {', '.join(TASKS)}, got "
                                    f"{self.task!r}", "task")
        checks.integer(self.envs, "envs", 1)
        checks.integer(self.max_cycles, "max_cycles", 1)
        checks.integer(self.frames, "frames", 1)
        checks.integer(self.batch, "batch", 1)
        checks.real(self.shaping, "shaping")
        if self.task == "attackers" and self.batch % self.envs:
            raise checks.FieldError(f"batch: a batched step is envs ({self.envs}) env steps, "
                                    f"so batch must be a multiple of it, got {self.batch}",
                                    "batch")


class Losses(Callback):
    """Keeps each group's mean losses of every training iteration: ``rows``, one dict per
    group and iteration (``"group"`` and every ``loss_*`` key)."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[dict[str, Any]] = []

    def on_train_end(self, training_td: TensorDictBase, group: str) -> None:
        self.rows.append({"group": group} | {
            key: training_td[key].mean().item() for key in training_td.keys()
            if key.startswith("loss_")})


def make_task(settings: MappoSettings) -> TaskClass:
    """The BenchMARL task of ``settings.task``."""
    game = {"scenario": settings.scenario, "max_cycles": settings.max_cycles,
            "shaping": settings.shaping}
    if settings.task == "game":
        return ReachAvoidTask.REACH_AVOID.get_task(game)
    return ScriptedDefendersTask.ATTACKERS.get_task(
        game | {"defenders": settings.defenders,
                "defender_options": settings.defender_options})


def make_experiment(settings: MappoSettings, callbacks: list[Callback]) -> Experiment:
    """MAPPO with BenchMARL's default algorithm and MLP configs on ``make_task``: minibatches
    of up to 400 steps, 4 passes per iteration, no evaluation, rendering or checkpoint, CSV
    logs under ``settings.out``."""
    config = ExperimentConfig.get_from_yaml()
    config.max_n_frames = settings.frames
    config.on_policy_collected_frames_per_batch = settings.batch
    config.on_policy_n_envs_per_worker = settings.envs if settings.task == "attackers" else 1
    config.on_policy_minibatch_size = min(400, settings.batch)
    config.on_policy_n_minibatch_iters = 4
    config.evaluation = False
    config.render = False
    config.loggers = ["csv"]
    config.save_folder = settings.out
    config.checkpoint_at_end = False
    return Experiment(task=make_task(settings), algorithm_config=MappoConfig.get_from_yaml(),
                      model_config=MlpConfig.get_from_yaml(),
                      critic_model_config=MlpConfig.get_from_yaml(), seed=settings.seed,
                      config=config, callbacks=callbacks)


def run(settings: MappoSettings) -> tuple[Experiment, list[dict[str, Any]]]:
    """Runs the experiment (torch on one thread: small networks, more threads only contend
    for the cores; ``settings.out`` made); returns it and ``Losses.rows``."""
    torch.set_num_threads(1)
    settings.out.mkdir(parents=True, exist_ok=True)
    losses = Losses()
    experiment = make_experiment(settings, [losses])
    experiment.run()
    return experiment, losses.rows

"""The game as a BenchMARL task (``benchmarl`` extra; BenchMARL pins torchrl < 0.12, so
install it in a virtual environment of its own).

    from benchmarl.algorithms import MappoConfig
    from benchmarl.experiment import Experiment, ExperimentConfig
    from benchmarl.models import MlpConfig
    from reachavoid_env.integrations.benchmarl import ReachAvoidTask

    task = ReachAvoidTask.REACH_AVOID.get_task({"scenario": "paper_2v1", "max_cycles": 300})
    mlp = MlpConfig.get_from_yaml()
    Experiment(task=task, algorithm_config=MappoConfig.get_from_yaml(), model_config=mlp,
               critic_model_config=mlp, seed=0, config=ExperimentConfig.get_from_yaml()).run()

The task config holds ``ReachAvoidEnv`` keyword arguments (``scenario``, ``max_cycles``,
``shaping``, ...); both teams learn, as the groups ``"attacker"`` and ``"defender"``
(continuous actions, the global ``state`` for centralised critics). The env is made by
``reachavoid_env.integrations.torchrl.torchrl_env``: agents that leave are masked.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from benchmarl.environments.common import Task
from benchmarl.environments.pettingzoo.common import PettingZooClass
from torchrl.envs import EnvBase

from reachavoid_env.environment import ReachAvoidEnv
from reachavoid_env.integrations.torchrl import torchrl_env


class ReachAvoidClass(PettingZooClass):
    """BenchMARL's view of the game; everything not defined here is BenchMARL's PettingZoo
    handling (specs and groups read from the TorchRL env)."""

    def get_env_fun(self, num_envs: int, continuous_actions: bool, seed: int | None,
                    device: Any) -> Callable[[], EnvBase]:
        config = dict(self.config)
        return lambda: torchrl_env(ReachAvoidEnv(**config), seed=seed, device=device)

    def supports_continuous_actions(self) -> bool:
        return True

    def supports_discrete_actions(self) -> bool:
        return False

    def has_state(self) -> bool:
        return True

    def has_render(self, env: EnvBase) -> bool:
        return False

    def max_steps(self, env: EnvBase) -> int:
        return ReachAvoidEnv(**self.config).max_cycles

    @staticmethod
    def env_name() -> str:
        return "reachavoid"


class ReachAvoidTask(Task):
    """BenchMARL tasks of this package: ``REACH_AVOID``, the game with both teams
    learning (``get_task(config)`` with ``ReachAvoidEnv`` keyword arguments)."""

    REACH_AVOID = None

    @staticmethod
    def associated_class() -> type[ReachAvoidClass]:
        return ReachAvoidClass

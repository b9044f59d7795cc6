"""The game as BenchMARL tasks (``benchmarl`` extra; BenchMARL pins torchrl < 0.12, so
install it in a virtual environment of its own).

    from benchmarl.algorithms import MappoConfig
    from benchmarl.experiment import Experiment, ExperimentConfig
    from benchmarl.models import MlpConfig
    from reachavoid_env.integrations.benchmarl import ReachAvoidTask

    task = ReachAvoidTask.REACH_AVOID.get_task({"scenario": "paper_2v1", "max_cycles": 300})
    mlp = MlpConfig.get_from_yaml()
    Experiment(task=task, algorithm_config=MappoConfig.get_from_yaml(), model_config=mlp,
               critic_model_config=mlp, seed=0, config=ExperimentConfig.get_from_yaml()).run()

``ReachAvoidTask.REACH_AVOID``: the task config holds ``ReachAvoidEnv`` keyword arguments
(``scenario``, ``max_cycles``, ``shaping``, ...); ``ReachAvoidTask.REACH_AVOID_V2`` holds
v2's (``decisions.DecisionEnv``: ``reward``, ``decision_steps``, ...; continuous or
discrete actions as the algorithm asks). Both teams learn, as the groups
``"attacker"`` and ``"defender"`` (continuous actions, the global ``state`` for
centralised critics). The env is made by ``reachavoid_env.integrations.torchrl.torchrl_env``:
agents that leave are masked.

``VectorGroupClass`` is the task class over a vector training view
(``vector_views.LearnerVectorEnv``): one side learns, as one group, and the other side is
scripted inside the env; BenchMARL's ``num_envs`` is the view's number of copies (a batched
env, so BenchMARL does not wrap it in a ``SerialEnv``). A subclass says which view
(``view(num_envs)``); the view with scripted defenders is ``reachavoid.training.benchmarl_task``'s
``ScriptedDefendersTask.ATTACKERS`` (scripted policies live above this package).
"""

from __future__ import annotations

import math
from abc import abstractmethod
from collections.abc import Callable
from typing import Any

import torch
from benchmarl.environments.common import Task, TaskClass
from benchmarl.environments.pettingzoo.common import PettingZooClass
from torchrl.data import Composite
from torchrl.envs import EnvBase

from reachavoid_env.decisions import DecisionEnv
from reachavoid_env.environment import ReachAvoidEnv
from reachavoid_env.integrations.torchrl import VectorGroupEnv, torchrl_env
from reachavoid_env.vector_views import LearnerVectorEnv


class ReachAvoidClass(PettingZooClass):
    """BenchMARL's view of the game; everything not defined here is BenchMARL's PettingZoo
    handling (specs and groups read from the TorchRL env)."""

    def _game(self, **changes: Any) -> ReachAvoidEnv | DecisionEnv:
        """The env of the task's config: v2's ``DecisionEnv`` for ``REACH_AVOID_V2``."""
        if self.name.upper() == "REACH_AVOID_V2":
            return DecisionEnv(**(dict(self.config) | changes))
        return ReachAvoidEnv(**self.config)

    def get_env_fun(self, num_envs: int, continuous_actions: bool, seed: int | None,
                    device: Any) -> Callable[[], EnvBase]:
        def make() -> EnvBase:
            game = self._game(continuous_actions=continuous_actions)
            return torchrl_env(game, seed=seed, device=device)

        return make

    def supports_continuous_actions(self) -> bool:
        return True

    def supports_discrete_actions(self) -> bool:
        return self.name.upper() == "REACH_AVOID_V2"

    def has_state(self) -> bool:
        return True

    def has_render(self, env: EnvBase) -> bool:
        return False

    def max_steps(self, env: EnvBase) -> int:
        return self._game().max_cycles

    @staticmethod
    def env_name() -> str:
        return "reachavoid"


class ReachAvoidTask(Task):
    """BenchMARL tasks of this package: ``REACH_AVOID``, the game with both teams
    learning (``get_task(config)`` with ``ReachAvoidEnv`` keyword arguments), and
    ``REACH_AVOID_V2``, v2 (``DecisionEnv`` keyword arguments; discrete actions too)."""

    REACH_AVOID = None
    REACH_AVOID_V2 = None

    @staticmethod
    def associated_class() -> type[ReachAvoidClass]:
        return ReachAvoidClass


class VectorGroupClass(TaskClass):
    """A BenchMARL task over a vector training view (module docstring): the env is
    ``VectorGroupEnv(self.view(num_envs))``, batch size ``(num_envs,)``, with the one group
    of the view's learners (observation, continuous action; no global state, so critics
    see the group's observations). Runs on the CPU (``sampling_device="cpu"``; training
    may use another device)."""

    @abstractmethod
    def view(self, num_envs: int) -> LearnerVectorEnv:
        """The training view of ``num_envs`` copies, made with ``autoreset=False``."""

    def get_env_fun(self, num_envs: int, continuous_actions: bool, seed: int | None,
                    device: Any) -> Callable[[], EnvBase]:
        if torch.device(device).type != "cpu":
            raise ValueError(f"sampling_device: the vector env steps on the CPU, got "
                             f"{device!r}")

        def make() -> VectorGroupEnv:
            env = VectorGroupEnv(self.view(num_envs))
            env.set_seed(seed)
            return env

        return make

    def supports_continuous_actions(self) -> bool:
        return True

    def supports_discrete_actions(self) -> bool:
        return False

    def has_render(self, env: EnvBase) -> bool:
        return False

    def max_steps(self, env: EnvBase) -> int:
        view = env.view
        return math.ceil(view.vec.max_cycles / view.action_repeat)

    def group_map(self, env: EnvBase) -> dict[str, list[str]]:
        return {env.group: list(env.view.learners)}

    def observation_spec(self, env: EnvBase) -> Composite:
        spec = env.full_observation_spec_unbatched.clone()
        del spec[env.group, "mask"]
        return spec

    def info_spec(self, env: EnvBase) -> Composite | None:
        return None

    def state_spec(self, env: EnvBase) -> Composite | None:
        return None

    def action_spec(self, env: EnvBase) -> Composite:
        return env.full_action_spec_unbatched

    def action_mask_spec(self, env: EnvBase) -> Composite | None:
        return None

    @staticmethod
    def env_name() -> str:
        return "reachavoid"

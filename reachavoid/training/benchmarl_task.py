"""A BenchMARL task in which the attackers learn against scripted defenders (``benchmarl``
extra, in a virtual environment of its own).

    from reachavoid.training.benchmarl_task import ScriptedDefendersTask

    task = ScriptedDefendersTask.ATTACKERS.get_task(
        {"scenario": "paper_6v2", "defenders": "hj",
         "defender_options": {"grid1": 31, "grid2": 15}, "shaping": 1.0})
    # Experiment(task=task, algorithm_config=MappoConfig.get_from_yaml(), ...).run()

The env is ``reachavoid.training.views.make_attackers_vector_env(..., num_envs=K,
autoreset=False)`` through ``reachavoid_env.integrations.torchrl.VectorGroupEnv``:
BenchMARL's ``num_envs`` (``on_policy_n_envs_per_worker``) copies of the game stepped
together, the defenders of every copy moved by one batched scripted policy (``hj``,
``greedy``, ...: ``policies.registry``), and the one learning group ``"attacker"``
(continuous actions; an attacker that left has its ``mask`` False and zero observations).
The config holds that factory's keywords, ``CONFIG_KEYS``; an unknown key is refused when
the task is made. ``get_task()`` without a config takes the factory's defaults
(``paper_2v1``, ``hj`` defenders on the paper's grids).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from benchmarl.environments.common import Task

from reachavoid.training.views import make_attackers_vector_env
from reachavoid_env.checks import FieldError
from reachavoid_env.integrations.benchmarl import VectorGroupClass
from reachavoid_env.vector_views import LearnerVectorEnv

CONFIG_KEYS = ("scenario", "defenders", "defender_options", "starts", "max_cycles",
               "shaping", "action_repeat", "timeout_reward", "observation", "copies_per_map")
"""The keywords of ``make_attackers_vector_env`` a task config may hold."""


class ScriptedDefendersClass(VectorGroupClass):
    """The task class of ``ScriptedDefendersTask``: attackers learn, as the group
    ``"attacker"``, in ``num_envs`` copies against scripted defenders."""

    def __init__(self, name: str, config: Mapping[str, Any] | None) -> None:
        config = dict(config or {})
        for key in config:
            if key not in CONFIG_KEYS:
                raise FieldError(f"config.{key}: not a key of the {name} task (keys: "
                                 f"{', '.join(CONFIG_KEYS)})", f"config.{key}")
        super().__init__(name, config)

    def view(self, num_envs: int) -> LearnerVectorEnv:
        return make_attackers_vector_env(num_envs=num_envs, autoreset=False, **self.config)


class ScriptedDefendersTask(Task):
    """``ATTACKERS``: every attacker learns (one group, ``"attacker"``) against scripted
    defenders; ``get_task(config)`` with ``CONFIG_KEYS``."""

    ATTACKERS = None

    @staticmethod
    def associated_class() -> type[ScriptedDefendersClass]:
        return ScriptedDefendersClass

    def get_task(self, config: dict[str, Any] | None = None) -> ScriptedDefendersClass:
        """The task with ``config`` (``None``: the factory's defaults; no YAML file)."""
        return ScriptedDefendersClass(self.name, config)

"""reachavoid_env: the multi-agent reach-avoid game (design.md).

Every name below loads its module on first use (PEP 562). The ground floor (shapes,
``GameMap``, ``Scenario``, the rules and the game state) imports numpy alone; only the
env (``ReachAvoidEnv``, ``env``, ``parallel_env``, ``raw_env``) loads PettingZoo,
Gymnasium and pymunk, so the solvers stand on the map without the simulator.

Importing the package registers the env with PettingZoo as ``reachavoid/ReachAvoid-v1``
(the egocentric observation; ``env``, ``parallel_env`` and ``raw_env`` here are v1's),
``reachavoid/ReachAvoid-v0`` (the global observation, ``reach_avoid_v0``) and
``reachavoid/ReachAvoid-v2`` (decisions, random starts, shaped reward and discrete actions
as options: the version for learning from scratch, ``reach_avoid_v2``), all for
``pettingzoo.make("parallel", ...)`` and ``pettingzoo.make("aec", ...)``: at once when
PettingZoo is loaded already, else the moment it is imported. PettingZoo has a registry
from 1.27; on older releases (pyproject allows 1.25) nothing is registered and the
versioned modules (``reach_avoid_v2.parallel_env(...)``) make the envs. The attacker
training envs' ids (``training_ids``) register the same way, with Gymnasium too: no
``import policies`` first.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from reachavoid_env import lazy

if TYPE_CHECKING:
    from reachavoid_env.environment import ReachAvoidEnv
    from reachavoid_env.game_map import GameMap
    from reachavoid_env.game_state import AttackerStatus, BatchState, GameState
    from reachavoid_env.observations import ObservationConfig
    from reachavoid_env.overlay import Overlay
    from reachavoid_env.policy import (
        BatchPolicy,
        PerCopy,
        PerMap,
        PerMapPolicy,
        Policy,
        PolicyMismatch,
        Single,
        merged_overlay,
    )
    from reachavoid_env.reach_avoid_v1 import env, parallel_env, raw_env
    from reachavoid_env.scenario import (
        Scenario,
        ScenarioError,
        builtin_map,
        builtin_names,
        builtin_scenario,
        load_scenario,
        save_scenario,
    )
    from reachavoid_env.shapes import Box, Circle, Polygon, ShapeError
    from reachavoid_env.vector import ReachAvoidVectorEnv, vector_env

__all__ = [
    "AttackerStatus",
    "BatchPolicy",
    "BatchState",
    "Box",
    "Circle",
    "GameMap",
    "GameState",
    "ObservationConfig",
    "Overlay",
    "PerCopy",
    "PerMap",
    "PerMapPolicy",
    "Policy",
    "PolicyMismatch",
    "Polygon",
    "ReachAvoidEnv",
    "ReachAvoidVectorEnv",
    "Scenario",
    "ScenarioError",
    "ShapeError",
    "Single",
    "builtin_map",
    "builtin_names",
    "builtin_scenario",
    "env",
    "load_scenario",
    "merged_overlay",
    "parallel_env",
    "raw_env",
    "save_scenario",
    "vector_env",
]

ENV_IDS = {"reachavoid/ReachAvoid-v0": "reachavoid_env.reach_avoid_v0",
           "reachavoid/ReachAvoid-v1": "reachavoid_env.reach_avoid_v1",
           "reachavoid/ReachAvoid-v2": "reachavoid_env.reach_avoid_v2"}
ENV_ID = "reachavoid/ReachAvoid-v1"
"""The current version's id."""

__getattr__, __dir__ = lazy.attributes(__name__, {
    "GameMap": "reachavoid_env.game_map",
    **dict.fromkeys(["AttackerStatus", "BatchState", "GameState"], "reachavoid_env.game_state"),
    "Overlay": "reachavoid_env.overlay",
    **dict.fromkeys(["BatchPolicy", "PerCopy", "PerMap", "PerMapPolicy", "Policy",
                     "PolicyMismatch", "Single", "merged_overlay"], "reachavoid_env.policy"),
    **dict.fromkeys(["Scenario", "ScenarioError", "builtin_map", "builtin_names",
                     "builtin_scenario", "load_scenario", "save_scenario"],
                    "reachavoid_env.scenario"),
    **dict.fromkeys(["Box", "Circle", "Polygon", "ShapeError"], "reachavoid_env.shapes"),
    "ReachAvoidEnv": "reachavoid_env.environment",
    **dict.fromkeys(["ReachAvoidVectorEnv", "vector_env"], "reachavoid_env.vector"),
    "ObservationConfig": "reachavoid_env.observations",
    **dict.fromkeys(["env", "parallel_env", "raw_env"], "reachavoid_env.reach_avoid_v1"),
})


def _register(pettingzoo: Any) -> None:
    """Register ``ENV_IDS`` with PettingZoo's registry (1.27 on; older releases have
    none, and the versioned modules are their way in)."""
    if not hasattr(pettingzoo, "register"):
        return
    for env_id, module in ENV_IDS.items():
        pettingzoo.register("parallel", env_id, entry_point=f"{module}:parallel_env")
        pettingzoo.register("aec", env_id, entry_point=f"{module}:env")
    from reachavoid_env.training_ids import register_pettingzoo

    register_pettingzoo(pettingzoo)


def _register_training(gymnasium: Any) -> None:
    """Register the attacker training envs' Gymnasium ids (``training_ids``)."""
    from reachavoid_env.training_ids import register_gymnasium

    register_gymnasium(gymnasium)


lazy.after_import("pettingzoo", _register)
lazy.after_import("gymnasium", _register_training)

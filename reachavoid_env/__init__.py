"""reachavoid_env: the multi-agent reach-avoid game (design.md).

Importing the package registers the env with PettingZoo as ``reachavoid/ReachAvoid-v0``
(both ``pettingzoo.make("parallel", ...)`` and ``pettingzoo.make("aec", ...)``).
``reachavoid_env.env`` is the AEC constructor; the env class lives in
``reachavoid_env.environment``.
"""

import pettingzoo

from reachavoid_env.environment import ReachAvoidEnv
from reachavoid_env.game_state import AttackerStatus, GameState, Overlay, Policy, merged_overlay
from reachavoid_env.reach_avoid_v0 import env, parallel_env, raw_env
from reachavoid_env.scenario import (
    GameMap,
    Scenario,
    ScenarioError,
    builtin_map,
    builtin_names,
    builtin_scenario,
    load_scenario,
    save_scenario,
)
from reachavoid_env.shapes import Box, Circle, Polygon, ShapeError

__all__ = [
    "AttackerStatus",
    "Box",
    "Circle",
    "GameMap",
    "GameState",
    "Overlay",
    "Policy",
    "Polygon",
    "ReachAvoidEnv",
    "Scenario",
    "ScenarioError",
    "ShapeError",
    "builtin_map",
    "builtin_names",
    "builtin_scenario",
    "env",
    "load_scenario",
    "merged_overlay",
    "parallel_env",
    "raw_env",
    "save_scenario",
]

ENV_ID = "reachavoid/ReachAvoid-v0"
pettingzoo.register("parallel", ENV_ID, entry_point="reachavoid_env.reach_avoid_v0:parallel_env")
pettingzoo.register("aec", ENV_ID, entry_point="reachavoid_env.reach_avoid_v0:env")

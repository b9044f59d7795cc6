"""reachavoid_env: the multi-agent reach-avoid game (design.md)."""

from reachavoid_env.game_state import AttackerStatus, GameState, Overlay
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
    "Polygon",
    "Scenario",
    "ScenarioError",
    "ShapeError",
    "builtin_map",
    "builtin_names",
    "builtin_scenario",
    "load_scenario",
    "save_scenario",
]

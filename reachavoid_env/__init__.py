"""reachavoid_env: the multi-agent reach-avoid game (design.md).

The ground floor (shapes, ``GameMap``, ``Scenario``, the rules and the game state) imports
numpy alone and loads with the package; the env (``ReachAvoidEnv``, ``env``,
``parallel_env``, ``raw_env``) loads on first use (PEP 562), so the solvers can stand on
the map without PettingZoo, Gymnasium, pymunk or pygame.

Importing the package registers the env with PettingZoo as ``reachavoid/ReachAvoid-v0``
(both ``pettingzoo.make("parallel", ...)`` and ``pettingzoo.make("aec", ...)``): at once
when PettingZoo is loaded already, else the moment it is imported.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
from typing import TYPE_CHECKING, Any

from reachavoid_env.game_map import GameMap
from reachavoid_env.game_state import AttackerStatus, GameState, Overlay, Policy, merged_overlay
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

if TYPE_CHECKING:
    from reachavoid_env.environment import ReachAvoidEnv
    from reachavoid_env.reach_avoid_v0 import env, parallel_env, raw_env

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
_LAZY = {"ReachAvoidEnv": "reachavoid_env.environment", "env": "reachavoid_env.reach_avoid_v0",
         "parallel_env": "reachavoid_env.reach_avoid_v0",
         "raw_env": "reachavoid_env.reach_avoid_v0"}
"""Names of the env, loaded on first use: name -> module."""


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


def _register(pettingzoo: Any) -> None:
    pettingzoo.register("parallel", ENV_ID,
                        entry_point="reachavoid_env.reach_avoid_v0:parallel_env")
    pettingzoo.register("aec", ENV_ID, entry_point="reachavoid_env.reach_avoid_v0:env")


class _RegisterWhenImported(importlib.abc.MetaPathFinder):
    """Registers the env right after ``pettingzoo`` itself is imported (then leaves
    ``sys.meta_path``), so importing this package does not load PettingZoo."""

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> Any:
        if name != "pettingzoo":
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None:
            return spec
        loader = spec.loader
        exec_module = loader.exec_module

        def exec_and_register(module: Any) -> None:
            exec_module(module)
            _register(module)

        loader.exec_module = exec_and_register  # type: ignore[method-assign]
        return spec


if "pettingzoo" in sys.modules:
    _register(sys.modules["pettingzoo"])
elif not any(isinstance(finder, _RegisterWhenImported) for finder in sys.meta_path):
    sys.meta_path.insert(0, _RegisterWhenImported())

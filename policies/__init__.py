"""Defender and attacker policies (design.md section 3).

The names below load their modules on first use (PEP 562). Importing the package
registers the attacker-training envs with Gymnasium and PettingZoo (``policies.training``)
as soon as those libraries are imported.
"""

from __future__ import annotations

import importlib
import sys
from types import ModuleType
from typing import TYPE_CHECKING

from reachavoid_env import lazy

if TYPE_CHECKING:
    from policies.attackers import (
        HJAttacker,
        RandomAttacker,
        ShortestPathAttacker,
        StraightAttacker,
    )
    from policies.defenders import (
        GreedyDefender,
        HJDefenderPolicy,
        HJPairsDefenderPolicy,
        IdleDefender,
        MatchingDefenderPolicy,
    )
    from policies.training import make_attacker_env, make_attackers_parallel_env

__all__ = [
    "GreedyDefender",
    "HJAttacker",
    "HJDefenderPolicy",
    "HJPairsDefenderPolicy",
    "IdleDefender",
    "MatchingDefenderPolicy",
    "RandomAttacker",
    "ShortestPathAttacker",
    "StraightAttacker",
    "make_attacker_env",
    "make_attackers_parallel_env",
]

__getattr__, __dir__ = lazy.attributes(__name__, {
    **dict.fromkeys(["HJAttacker", "RandomAttacker", "ShortestPathAttacker", "StraightAttacker"],
                    "policies.attackers"),
    **dict.fromkeys(["GreedyDefender", "HJDefenderPolicy", "HJPairsDefenderPolicy",
                     "IdleDefender", "MatchingDefenderPolicy"], "policies.defenders"),
    **dict.fromkeys(["make_attacker_env", "make_attackers_parallel_env"], "policies.training"),
})


def _register_training_envs(library: ModuleType) -> None:
    """Import ``policies.training`` (which registers the ids) once ``library`` is loaded;
    Gymnasium loading inside PettingZoo's import leaves it to PettingZoo's turn."""
    if library.__name__ == "gymnasium" and "pettingzoo" in sys.modules:
        return
    importlib.import_module("policies.training")


lazy.after_import("gymnasium", _register_training_envs)
lazy.after_import("pettingzoo", _register_training_envs)

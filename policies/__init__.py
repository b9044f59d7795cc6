"""Defender and attacker policies (design.md section 3).

The names below load their modules on first use (PEP 562). Importing the package after
Gymnasium or PettingZoo (as ``gymnasium.make("policies:reachavoid/Attacker-v0")`` does)
registers the attacker-training envs with both (``policies.training``); importing
``policies.training`` registers them in any case. Without either library loaded, the
package imports neither (the command line's path).
"""

from __future__ import annotations

import importlib
import sys
from typing import TYPE_CHECKING

from reachavoid_env import lazy

if TYPE_CHECKING:
    from policies.attackers import (
        HJAttacker,
        HJPairsAttacker,
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
    "HJPairsAttacker",
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
    **dict.fromkeys(["HJAttacker", "HJPairsAttacker", "RandomAttacker", "ShortestPathAttacker",
                     "StraightAttacker"],
                    "policies.attackers"),
    **dict.fromkeys(["GreedyDefender", "HJDefenderPolicy", "HJPairsDefenderPolicy",
                     "IdleDefender", "MatchingDefenderPolicy"], "policies.defenders"),
    **dict.fromkeys(["make_attacker_env", "make_attackers_parallel_env"], "policies.training"),
})

if "gymnasium" in sys.modules or "pettingzoo" in sys.modules:
    importlib.import_module("policies.training")

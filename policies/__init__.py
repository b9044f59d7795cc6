"""Defender and attacker policies (design.md section 3).

The names below load their modules on first use (PEP 562); the package imports neither
Gymnasium nor PettingZoo (the command line's path). The training envs that name these
policies, and their registered ids, are the application's (``reachavoid.training.views``,
``reachavoid_env.training_ids``).
"""

from __future__ import annotations

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
]

__getattr__, __dir__ = lazy.attributes(__name__, {
    **dict.fromkeys(["HJAttacker", "HJPairsAttacker", "RandomAttacker", "ShortestPathAttacker",
                     "StraightAttacker"],
                    "policies.attackers"),
    **dict.fromkeys(["GreedyDefender", "HJDefenderPolicy", "HJPairsDefenderPolicy",
                     "IdleDefender", "MatchingDefenderPolicy"], "policies.defenders"),
})

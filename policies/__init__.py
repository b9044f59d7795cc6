"""Defender and attacker policies (design.md section 3).

The names below load their modules on first use (PEP 562). The attacker-training envs'
ids (factories in ``policies.training``) are registered by ``reachavoid_env``
(``reachavoid_env.training_ids``) when Gymnasium or PettingZoo is imported, so
``gymnasium.make("policies:reachavoid/Attacker-v1")`` and a plain ``import reachavoid_env``
both find them. The package imports neither library (the command line's path).
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

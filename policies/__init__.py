"""Defender and attacker policies (design.md section 3).

Importing the package registers the attacker-training envs with Gymnasium and PettingZoo
(``policies.training``).
"""

from policies.attackers import HJAttacker, RandomAttacker, ShortestPathAttacker, StraightAttacker
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

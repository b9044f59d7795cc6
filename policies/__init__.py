"""Defender and attacker policies (design.md section 3)."""

from policies.attackers import RandomAttacker, StraightAttacker
from policies.base import Policy, overlay_of
from policies.defenders import GreedyDefender, IdleDefender

__all__ = [
    "GreedyDefender",
    "IdleDefender",
    "Policy",
    "RandomAttacker",
    "StraightAttacker",
    "overlay_of",
]

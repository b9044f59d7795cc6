"""What the assignment defenders ask the renderer to draw (``reachavoid_env.Overlay``):
the games played by kind, the races, the counts line."""

from __future__ import annotations

from policies.certificate import Match
from reachavoid_env import Overlay
from reachavoid_env.game_state import EdgeKind


def overlay(games: list[Match], races: tuple[tuple[int, int], ...], line: str) -> Overlay:
    """The ``games`` played as edges by kind (a defender with two attackers plays a 2 vs 1
    game, a pair; two defenders on one attacker a 1 vs 2 game, a team), an
    ``EdgeKind.RACE`` edge for every ``(attacker, defender)`` of ``races``, and the text
    ``line``."""
    edges, kinds = [], []
    for game in games:
        kind = (EdgeKind.TEAM if len(game.defenders) == 2 else
                EdgeKind.PAIR if len(game.attackers) == 2 else EdgeKind.ASSIGN)
        edges += [(f"defender_{j}", f"attacker_{i}") for j in game.defenders
                  for i in game.attackers]
        kinds += [kind] * (len(game.defenders) * len(game.attackers))
    edges += [(f"defender_{j}", f"attacker_{i}") for i, j in races]
    kinds += [EdgeKind.RACE] * len(races)
    return Overlay(edges=tuple(edges), kinds=tuple(kinds), lines=(line,))

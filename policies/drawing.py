"""What the assignment defenders ask the renderer to draw (``reachavoid_env.Overlay``):
the games played by kind, the races along their ways, the counts line."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from policies.certificate import Match
from policies.intercept import Plan, traced_points
from reachavoid_env import GameState, Overlay
from reachavoid_env.geodesic import DistanceField, distance_to
from reachavoid_env.overlay import EdgeKind, Route


def overlay(games: list[Match], races: tuple[tuple[int, int], ...], line: str,
            ways: Callable[[], tuple[Route, ...]] | None = None) -> Overlay:
    """The ``games`` played as edges by kind (a defender with two attackers plays a 2 vs 1
    game, a pair; two defenders on one attacker a 1 vs 2 game, a team), an
    ``EdgeKind.RACE`` edge for every ``(attacker, defender)`` of ``races`` (drawn along
    the routes ``ways`` makes, ``race_routes``), and the text ``line``."""
    edges, kinds = [], []
    for game in games:
        kind = (EdgeKind.TEAM if len(game.defenders) == 2 else
                EdgeKind.PAIR if len(game.attackers) == 2 else EdgeKind.ASSIGN)
        edges += [(f"defender_{j}", f"attacker_{i}") for j in game.defenders
                  for i in game.attackers]
        kinds += [kind] * (len(game.defenders) * len(game.attackers))
    edges += [(f"defender_{j}", f"attacker_{i}") for i, j in races]
    kinds += [EdgeKind.RACE] * len(races)
    return Overlay(edges=tuple(edges), kinds=tuple(kinds), lines=(line,), ways=ways)


def race_routes(field: DistanceField, state: GameState, plan: Plan,
                races: tuple[tuple[int, int], ...]) -> tuple[Route, ...]:
    """The way of each race ``(attacker, defender)`` of ``plan``: the defender's shortest
    path around the obstacles to its race point (``plan.aims``; ``field``'s clearance),
    then the attacker's path to the target (``field``) from there back to the attacker.
    The defender's part is straight where that keeps the clearance (the defender heads
    straight for its race point) or where the race point lies in a grown obstacle."""
    routes = []
    for i, j in races:
        aim, defender = plan.aims[j], state.defender_positions[j]
        path, count = traced_points(field, state.attacker_positions[i])
        path = path[0, :count[0]]
        back = path[:int(np.argmin(np.hypot(*(path - aim).T))) + 1][::-1]
        way = defender[None]
        if not _clear(field, defender, aim):
            to_aim = distance_to(field.game_map, field.clearance, aim)
            if to_aim is not None:
                way, count = traced_points(to_aim, defender)
                way = way[0, :count[0]]
        points = np.concatenate([way, back])
        routes.append(Route(f"defender_{j}", f"attacker_{i}",
                            tuple((x, y) for x, y in points.tolist())))
    return tuple(routes)


SAMPLE = 0.005
"""Spacing (map units) of the points at which a straight way is checked against the
obstacles (``_clear``)."""


def _clear(field: DistanceField, start: np.ndarray, end: np.ndarray) -> bool:
    """Whether the segment from ``start`` to ``end`` keeps ``field``'s clearance from the
    obstacles (checked every ``SAMPLE`` map units)."""
    count = int(np.hypot(*(end - start)) / SAMPLE) + 2
    points = start + np.linspace(0.0, 1.0, count)[:, None] * (end - start)
    return bool(field.game_map.obstacle_signed_distance(points).min() >= field.clearance)

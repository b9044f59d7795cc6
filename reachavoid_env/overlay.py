"""What a policy asks the renderer to draw on top of the game (``Overlay``: edges of each
kind of game, their routes, text lines) and the line that says how a game ended."""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import NamedTuple


class EdgeKind(str, Enum):
    """Which game an overlay edge belongs to; each kind is drawn in its own style."""

    ASSIGN = "assign"  # one defender on one attacker (a 1 vs 1 game)
    PAIR = "pair"      # one defender on two attackers (a 2 vs 1 game): both its edges
    TEAM = "team"      # two defenders on one attacker (a 1 vs 2 game): both edges to it
    RACE = "race"      # a defender racing to intercept an attacker, in no certified game


class Edge(NamedTuple):
    """One defender-attacker edge of an overlay, with the kind of game it is."""

    defender: str
    attacker: str
    kind: EdgeKind


class Route(NamedTuple):
    """The way an overlay edge runs, where it is no straight line: ``points`` (map units,
    at least two) from the ``defender``'s position to the ``attacker``'s, around the
    obstacles (a racing defender's way to its race point, then the attacker's path back
    from there)."""

    defender: str
    attacker: str
    points: tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class Overlay:
    """What a policy asks the renderer to draw on top of the game.

    ``edges`` are ``(defender name, attacker name)`` pairs (the paper's assignment edges);
    ``kinds`` optionally gives each edge's ``EdgeKind``, in the same order (empty: every
    edge is a 1 vs 1 assignment). ``lines`` are extra text lines shown under the clock.
    ``routes`` give the way of some edges (``Route``): the renderer draws such an edge
    along its route (its ends at the players' current positions), any other straight.
    They are made by ``ways`` when first read: a route may cost a geodesic solve, and
    only a frame reads them (``reachavoid.rollout`` reads every step's overlay for its
    text).
    """

    edges: tuple[tuple[str, str], ...] = ()
    lines: tuple[str, ...] = ()
    kinds: tuple[EdgeKind, ...] = ()
    ways: Callable[[], tuple[Route, ...]] | None = dataclasses.field(
        default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.kinds and len(self.kinds) != len(self.edges):
            raise ValueError(f"kinds: expected one per edge ({len(self.edges)}), got "
                             f"{len(self.kinds)}")
        kinds = tuple(EdgeKind(k) for k in self.kinds)
        # one form per meaning: all-ASSIGN kinds are stored as ()
        object.__setattr__(self, "kinds", () if set(kinds) <= {EdgeKind.ASSIGN} else kinds)

    @functools.cached_property
    def routes(self) -> tuple[Route, ...]:
        """The ``Route`` of each edge that has one (made by ``ways`` on first read); a route
        of no edge, or of fewer than two points, is a ``ValueError``."""
        routes = () if self.ways is None else tuple(self.ways())
        edges = set(self.edges)
        for route in routes:
            if (route.defender, route.attacker) not in edges or len(route.points) < 2:
                raise ValueError(f"routes: ({route.defender!r}, {route.attacker!r}) is no "
                                 f"edge of the overlay or has fewer than 2 points")
        return routes

    @property
    def kinded_edges(self) -> tuple[Edge, ...]:
        """Every edge with its kind (``ASSIGN`` where ``kinds`` is empty)."""
        kinds = self.kinds or (EdgeKind.ASSIGN,) * len(self.edges)
        return tuple(Edge(d, a, k) for (d, a), k in zip(self.edges, kinds, strict=True))


def outcome_line(num_attackers: int, captured: int, arrived: int) -> str:
    """How a game ended, in words: the banner of a video's last frame and the summary of
    ``reachavoid play``. Attackers neither captured nor arrived were held off until the
    time ran out."""
    if captured == num_attackers:
        return f"All {num_attackers} attackers captured"
    held = num_attackers - captured - arrived
    parts = [f"{captured} captured", f"{arrived} reached the target"]
    if held:
        parts.append(f"{held} held off (time up)")
    return f"{num_attackers} attackers: " + ", ".join(parts)

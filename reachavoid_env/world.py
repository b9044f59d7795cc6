"""The physical world of a game: a pymunk ``Space`` with the map's walls and obstacles.

Every player is a small dynamic circle (radius ``player_radius``, map units) that collides
with the static geometry only: players pass through each other, stop at walls and slide
along them. Each step the world takes one desired velocity per player (map units per
second) and advances ``dt`` seconds in ``substeps`` equal physics steps, short enough
that no player moves more than half its radius per sub-step, so a player never tunnels
through a wall however thin, and its centre stays outside every obstacle.

How a step runs (Chipmunk integrates positions before it solves contacts, so the order
matters): the bodies' velocities are zeroed and the desired velocity is applied as a
one-step force; one physics step then moves nobody but lets the contact solver clip the
new velocity against the walls the player touches; ``substeps`` further physics steps
move the players with the clipped velocity. A player pushing into a wall therefore
slides along it instead of sinking in and being pushed back.
"""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING

import numpy as np
import pymunk
import pymunk.autogeometry
import pymunk.batch

from reachavoid_env.scenario import substeps_for
from reachavoid_env.shapes import Box, Circle, Polygon, Shape

if TYPE_CHECKING:
    from reachavoid_env.game_map import GameMap

__all__ = ["World", "static_shapes", "substeps_for"]

_PLAYER_GROUP = 1
_SET_FIELDS = pymunk.batch.BodyFields.VELOCITY | pymunk.batch.BodyFields.FORCE
_GET_FIELDS = pymunk.batch.BodyFields.POSITION


class World:
    """A pymunk space holding one map and the players' bodies.

    ``positions`` is ``(K, 2)`` start positions in map units, one row per player in the
    env's agent order. ``max_speed`` (map units per second) and ``dt`` (seconds) fix the
    number of sub-steps; ``substeps`` overrides it (tests use it to show tunnelling).
    """

    def __init__(
        self,
        game_map: GameMap,
        player_radius: float,
        positions: np.ndarray,
        max_speed: float,
        dt: float,
        substeps: int | None = None,
    ) -> None:
        positions = np.asarray(positions, dtype=np.float64)
        if positions.ndim != 2 or positions.shape[1] != 2:
            raise ValueError(f"positions must have shape (K, 2), got {positions.shape}")
        self.dt = float(dt)
        self.substeps = substeps if substeps is not None else substeps_for(
            max_speed, dt, player_radius)
        if self.substeps < 1:
            raise ValueError(f"substeps must be at least 1, got {self.substeps}")
        self._h = self.dt / self.substeps
        self._map = game_map
        self._radius = float(player_radius)
        self.space = _walled_space(game_map, player_radius)
        self._replay_space: pymunk.Space | None = None
        self.bodies = [_player(self.space, x, y, player_radius) for x, y in positions]
        self._ids = np.array([body.id for body in self.bodies], dtype=np.uintp)
        self._index_bodies()
        self._get_buffer = pymunk.batch.Buffer()

    def _index_bodies(self) -> None:
        self._rows, body_count = self._body_rows()
        # Batch buffer: one (vx, vy, fx, fy) row per body the space iterates over (its
        # static body included). Velocities stay zero; a player's force is m v / h, so the
        # first physics step of a step turns it into the velocity v (mass 1).
        self._commands = np.zeros((body_count, 4), dtype=np.float64)
        self._set_buffer = pymunk.batch.Buffer()
        self._set_buffer.set_float_buf(self._commands)

    def replace_players(self, rows: np.ndarray, positions: np.ndarray) -> None:
        """Put new bodies at ``positions`` ``(len(rows), 2)`` in place of the players
        ``rows``: a fresh body keeps no contact of the old one, so the players move on
        exactly as in a new ``World`` (the vector env's reset of one copy)."""
        for row, (x, y) in zip(rows.tolist(), np.asarray(positions, dtype=np.float64),
                               strict=True):
            old = self.bodies[row]
            self.space.remove(old, *old.shapes)
            self.bodies[row] = _player(self.space, x, y, self._radius)
            self._ids[row] = self.bodies[row].id
        self._index_bodies()

    def _body_rows(self) -> tuple[slice | np.ndarray, int]:
        """Rows of the players' bodies in pymunk's batch order (a slice where they are
        consecutive, as they are when added in order: cheaper to index), and the number of
        rows. The players' body ids are kept (``_ids``): reading ``Body.id`` costs a
        foreign call per body, and a vector env re-reads the order at every reset."""
        buffer = pymunk.batch.Buffer()
        pymunk.batch.get_space_bodies(self.space, pymunk.batch.BodyFields.BODY_ID, buffer)
        ids = np.frombuffer(buffer.int_buf(), dtype=np.uintp)
        order = np.argsort(ids, kind="stable")
        rows = order[np.searchsorted(ids, self._ids, sorter=order)].astype(np.intp)
        first = int(rows[0]) if len(rows) else 0
        if np.array_equal(rows, np.arange(first, first + len(rows))):
            return slice(first, first + len(rows)), len(ids)
        return rows, len(ids)

    def step(self, velocities: np.ndarray) -> np.ndarray:
        """Advance ``dt`` seconds with desired ``velocities`` ``(K, 2)`` (map units/s).

        Returns the new positions ``(K, 2)`` (a fresh array). A player keeps its desired
        velocity except where a wall stops it; then it slides along the wall.
        """
        rows = self._rows
        self._commands[rows, 2:] = np.asarray(velocities, dtype=np.float64) / self._h
        step = self.space.step
        h = self._h
        pymunk.batch.set_space_bodies(self.space, _SET_FIELDS, self._set_buffer)
        for _ in range(self.substeps + 1):
            step(h)
        buffer = self._get_buffer
        buffer.clear()
        pymunk.batch.get_space_bodies(self.space, _GET_FIELDS, buffer)
        all_positions = np.frombuffer(buffer.float_buf(), dtype=np.float64).reshape(-1, 2)
        return all_positions[rows].copy()

    def replay(self, starts: np.ndarray, velocities: np.ndarray) -> np.ndarray:
        """The path a step moves players along: ``(substeps + 1, P, 2)`` positions at the
        sub-step boundaries of players started at ``starts`` ``(P, 2)`` with desired
        ``velocities`` ``(P, 2)``, the first row ``starts``.

        Within a sub-step a player moves in a straight line; a wall changes its velocity
        only between sub-steps. The players are moved again, alone, in a space of this
        map's walls (players never meet each other, so alone is how ``step`` moved them;
        the contact solver starts afresh, so positions agree to rounding). For the few
        players whose step left its straight segment (``rules.resolve_events``)."""
        if self._replay_space is None:
            self._replay_space = _walled_space(self._map, self._radius)
        space, h = self._replay_space, self._h
        bodies = [_player(space, x, y, self._radius) for x, y in starts]
        for body, (vx, vy) in zip(bodies, np.asarray(velocities, dtype=np.float64),
                                  strict=True):
            body.force = (vx / h, vy / h)
        path = np.empty((self.substeps + 1, len(bodies), 2))
        path[0] = starts
        try:
            space.step(h)   # as in ``step``: turns the force into a velocity, moves nobody
            for k in range(1, self.substeps + 1):
                space.step(h)
                path[k] = [tuple(body.position) for body in bodies]
        finally:
            for body in bodies:
                space.remove(body, *body.shapes)
        return path


def _walled_space(game_map: GameMap, player_radius: float) -> pymunk.Space:
    """A space holding the map's walls and obstacles (no friction, no bounce)."""
    space = pymunk.Space()
    space.collision_slop = 0.01 * player_radius
    space.collision_bias = 0.0
    static = space.static_body
    walls = _domain_walls(game_map.domain, static)
    for obstacle in game_map.obstacles:
        walls.extend(static_shapes(obstacle, static))
    for shape in walls:
        shape.friction = 0.0
        shape.elasticity = 0.0
    space.add(*walls)
    return space


def _player(space: pymunk.Space, x: float, y: float, player_radius: float) -> pymunk.Body:
    """A player's body at ``(x, y)`` in ``space``: a circle that meets walls, not players."""
    body = pymunk.Body(mass=1.0, moment=math.inf)
    body.position = (float(x), float(y))
    circle = pymunk.Circle(body, player_radius)
    circle.filter = pymunk.ShapeFilter(group=_PLAYER_GROUP)
    circle.friction = 0.0
    circle.elasticity = 0.0
    space.add(body, circle)
    return body


def _domain_walls(domain: tuple[float, float, float, float],
                  body: pymunk.Body) -> list[pymunk.Shape]:
    """Four thick boxes framing the domain from outside."""
    xmin, xmax, ymin, ymax = domain
    t = max(xmax - xmin, ymax - ymin)
    boxes = [
        (xmin - t, xmin, ymin - t, ymax + t),
        (xmax, xmax + t, ymin - t, ymax + t),
        (xmin, xmax, ymin - t, ymin),
        (xmin, xmax, ymax, ymax + t),
    ]
    return [pymunk.Poly(body, [(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
            for x0, x1, y0, y1 in boxes]


@functools.singledispatch
def static_shapes(shape: Shape, body: pymunk.Body) -> list[pymunk.Shape]:
    """Static pymunk collision shapes of a map ``shape`` attached to ``body``; a new shape
    kind registers its conversion here (``@static_shapes.register``)."""
    raise TypeError(f"no pymunk conversion for {type(shape).__name__} shapes")


@static_shapes.register
def _(shape: Box, body: pymunk.Body) -> list[pymunk.Shape]:
    return [pymunk.Poly(body, [tuple(p) for p in shape.outline().tolist()])]


@static_shapes.register
def _(shape: Circle, body: pymunk.Body) -> list[pymunk.Shape]:
    return [pymunk.Circle(body, shape.radius, offset=shape.center)]


@static_shapes.register
def _(shape: Polygon, body: pymunk.Body) -> list[pymunk.Shape]:
    """Concave polygons become their convex pieces (pymunk collides convex shapes only)."""
    ring = [tuple(v) for v in shape.vertices]
    if shape.area < 0:
        ring.reverse()
    ring.append(ring[0])
    parts = pymunk.autogeometry.convex_decomposition(ring, 0.0)
    return [pymunk.Poly(body, part) for part in parts]

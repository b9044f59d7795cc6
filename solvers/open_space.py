"""Who wins a 1 vs 1 game, decided without a grid where the map is open around the players.

Simple motion (``x' = v u``, ``|u| <= 1``), attacker speed ``vA``, defender speed ``vD``,
capture when the players are within the capture radius ``R`` (ties go to capture), the
attacker arriving when it is in the target. Two sufficient conditions, both exact
geometry (no grid, no margin of a cell), batched over ``K`` states:

**The attacker wins** (``attacker_certifies``) when for some target point ``z`` on a
straight segment from the attacker clear of obstacles the attacker's time ``|a - z| / vA``
is shorter than the defender's time to come within ``R`` of ``z``, ``(|d - z| - R) / vD``.
With ``vD >= vA`` that is enough: if the defender came within ``R`` of the attacker at
``p`` on the way, at time ``t``, it could follow on to within ``R`` of ``z`` by the
attacker's arrival, as ``|p - z| = vA (T - t) <= vD (T - t)``. With ``vD < vA`` the
defender's time to come within ``R`` of any point of the segment is used instead. The
defender's own path is not checked: obstacles only slow it. Target points are sampled
inside the target near its edge (``target_points``); each sample is a valid choice, so
sampling keeps the test sound.

**The defender wins** (``defender_certifies``, needs ``vD > vA``) when the Apollonius
disc of the two players (point capture: the points the attacker reaches no later than the
defender, centre ``c = (a - k^2 d) / (1 - k^2)``, radius ``k |a - d| / (1 - k^2)``,
``k = vA / vD``) is disjoint from the target and the region both players can visit under
parallel navigation is clear of obstacles and inside the domain. Parallel navigation
(``parallel_navigation``) keeps the line of sight ``e = (d - a) / |d - a|`` fixed: the
defender matches the attacker's velocity across ``e`` and closes along it. The attacker
then cannot leave the first Apollonius disc before capture (Dorothy, Maity, Shishika,
Von Moll, "One Apollonius circle is enough for many pursuit-evasion games",
arXiv:2111.09205), and a capture radius only ends the game sooner. The defender's
position is ``a(t) + rho(t) e`` with ``a(t)`` in the disc; its motion along ``-e`` is at
least ``sqrt(vD^2 - w^2)`` where ``w <= vA`` is its (the attacker's) speed across ``e``,
so it stays in the cone from ``d`` around ``-e`` of half-angle ``asin k`` (the tangent
cone of the disc) and in the band of the disc's width around the axis. Both players stay
in the disc together with the part of that cone-and-band from the disc's centre on
(``play_region``), which lies inside the capsule of radius ``r`` around the segment from
``c`` to the shoulder (where the cone meets the band) followed by capsules narrowing
along the cone to ``d``: the test is that these are clear of obstacles (exact
segment-to-shape distances, ``segment_gaps``) and that the domain's walls cannot stop the defender
(``defender_certifies``).

A game certified by either condition is won by the strategy that proves it: the
attacker's straight run to the certified target point, the defender's
``parallel_navigation``. Play in discrete time reads the attacker's velocity of the last
step, so the caller keeps a margin (``margin``: seconds of slack for the attacker
condition, map units of disc growth for the defender condition).
"""

from __future__ import annotations

import numpy as np

from reachavoid_env import Circle, GameMap
from reachavoid_env.shapes import Shape


def target_points(game_map: GameMap, spacing: float = 0.01) -> np.ndarray:
    """Points inside the map's target within ``spacing`` of its edge, on a grid of that
    spacing over the target's bounds (and at least 5 per axis): ``(P, 2)`` map units."""
    points = []
    for shape in game_map.target:
        x0, x1, y0, y1 = shape.bounds()
        xs = np.linspace(x0, x1, max(5, int(np.ceil((x1 - x0) / spacing)) + 1))
        ys = np.linspace(y0, y1, max(5, int(np.ceil((y1 - y0) / spacing)) + 1))
        grid = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)
        depth = game_map.target_signed_distance(grid)
        points.append(grid[(depth <= 0) & (depth >= -spacing)])
    return np.concatenate(points)


def segment_clear(game_map: GameMap, start: np.ndarray, end: np.ndarray,
                  clearance: np.ndarray | float = 0.0) -> np.ndarray:
    """Whether every point of each segment ``start``-``end`` lies farther than
    ``clearance`` from every obstacle (exact distances, ``segment_gaps``; the domain's
    edge is not an obstacle here).

    Args:
        start, end: ``(K, 2)`` map units.
        clearance: ``(K,)`` or a number, map units.

    Returns:
        ``(K,)`` bool.
    """
    start, end = np.asarray(start, dtype=np.float64), np.asarray(end, dtype=np.float64)
    clearance = np.broadcast_to(np.asarray(clearance, dtype=np.float64), (len(start),))
    clear = np.ones(len(start), dtype=bool)
    low = np.minimum(start, end) - clearance[:, None]
    high = np.maximum(start, end) + clearance[:, None]
    for shape in game_map.obstacles:
        x0, x1, y0, y1 = shape.bounds()
        near = np.flatnonzero((low[:, 0] <= x1) & (high[:, 0] >= x0) & (low[:, 1] <= y1)
                              & (high[:, 1] >= y0))  # the others are clear of its bounds
        if near.size:
            clear[near] &= segment_gaps(shape, start[near], end[near]) > clearance[near]
    return clear


def segment_gaps(shape: Shape, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """``(K,)`` the distance from each segment ``start``-``end`` ``(K, 2)`` to ``shape``
    (0 where they meet): a circle's from its centre less its radius; a box's or polygon's
    from its outline, its exact boundary (the distance between two segments that do not
    cross is the smallest of their endpoints' distances to the other)."""
    meets = np.isfinite(shape.segment_entry_time(start, end))
    if isinstance(shape, Circle):
        centre = np.broadcast_to(np.asarray(shape.center, dtype=np.float64), start.shape)
        gaps = segment_distance(centre, start, end) - shape.radius
    else:
        ring = shape.outline()
        corners, after = ring[None], np.roll(ring, -1, axis=0)[None]
        gaps = np.minimum(
            segment_distance(corners, start[:, None], end[:, None]).min(axis=1),
            np.minimum(segment_distance(start[:, None], corners, after),
                       segment_distance(end[:, None], corners, after)).min(axis=1))
    return np.where(meets, 0.0, gaps)


def attacker_certifies(game_map: GameMap, attackers: np.ndarray, defenders: np.ndarray,
                       speeds: tuple[float, float], capture_radius: float,
                       margin: float = 0.0, points: np.ndarray | None = None,
                       candidates: int = 8, clearance: float = 0.0) -> np.ndarray:
    """Whether the attacker provably wins each 1 vs 1 state (module docstring).

    Args:
        attackers, defenders: ``(K, 2)`` positions, map units.
        speeds: ``(vA, vD)``, map units per second.
        capture_radius: ``R``, map units.
        margin: the slack (seconds) the attacker must have over the defender.
        points: target points to try (default ``target_points(game_map)``).
        candidates: how many of the best target points per state are checked for a clear
            straight segment.
        clearance: how far the run keeps from obstacles (map units; the players' radius
            in the physics world).

    Returns:
        ``(K,)`` bool.
    """
    return _attacker_slack(game_map, attackers, defenders, speeds, capture_radius,
                           points, candidates, margin, clearance)[0] > margin


def attacker_target_point(game_map: GameMap, attackers: np.ndarray, defenders: np.ndarray,
                          speeds: tuple[float, float], capture_radius: float,
                          points: np.ndarray | None = None, candidates: int = 8,
                          clearance: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The attacker's certified run: ``(slack (K,) seconds, target point (K, 2))``, the
    best clear straight run found (slack ``-inf`` and the point NaN where none is);
    arguments as ``attacker_certifies``."""
    return _attacker_slack(game_map, attackers, defenders, speeds, capture_radius, points,
                           candidates, -np.inf, clearance)


_CHUNK = 4096
"""States per block of the ``(states, target points)`` arrays."""


def _attacker_slack(game_map, attackers, defenders, speeds, capture_radius, points,
                    candidates, floor, clearance):
    a = np.asarray(attackers, dtype=np.float64).reshape(-1, 2)
    d = np.asarray(defenders, dtype=np.float64).reshape(-1, 2)
    z = target_points(game_map) if points is None else np.asarray(points, dtype=np.float64)
    found = np.full(len(a), -np.inf)
    point = np.full((len(a), 2), np.nan)
    for lo in range(0, len(a), _CHUNK):
        block = slice(lo, lo + _CHUNK)
        found[block], point[block] = _slack_block(game_map, a[block], d[block], speeds,
                                                  capture_radius, z, candidates, floor,
                                                  clearance)
    return found, point


def _slack_block(game_map, a, d, speeds, capture_radius, z, candidates, floor, clearance):
    va, vd = speeds
    run = np.linalg.norm(a[:, None, :] - z[None], axis=2) / va
    if vd >= va:
        reach = np.linalg.norm(d[:, None, :] - z[None], axis=2)
    else:
        reach = segment_distance(d[:, None, :], a[:, None, :], z[None])
    slack = (reach - capture_radius) / vd - run
    best = np.argsort(-slack, axis=1)[:, :candidates]
    value = np.take_along_axis(slack, best, axis=1)
    state, rank = np.nonzero(value > floor)  # only runs that would decide are checked
    clear = np.zeros(value.shape, dtype=bool)
    clear[state, rank] = segment_clear(game_map, a[state], z[best[state, rank]], clearance)
    first = np.argmax(clear, axis=1)
    rows = np.arange(len(a))
    has = clear[rows, first]
    found = np.where(has, value[rows, first], -np.inf)
    point = np.where(has[:, None], z[best[rows, first]], np.nan)
    return found, point


def segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from points ``p`` to the segments ``a``-``b`` (broadcast, points on the
    last axis)."""
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, -1) / np.maximum(np.sum(ab * ab, -1), 1e-300), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)


def apollonius_disc(attackers: np.ndarray, defenders: np.ndarray,
                    speeds: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Centres ``(K, 2)`` and radii ``(K,)`` (map units) of the point-capture Apollonius
    discs: the points the attacker reaches no later than the defender (``vD > vA``)."""
    va, vd = speeds
    if not vd > va:
        raise ValueError(f"speeds: the Apollonius disc needs vD > vA, got {speeds}")
    k2 = (va / vd) ** 2
    a = np.asarray(attackers, dtype=np.float64)
    d = np.asarray(defenders, dtype=np.float64)
    centres = (a - k2 * d) / (1 - k2)
    radii = (va / vd) * np.linalg.norm(a - d, axis=1) / (1 - k2)
    return centres, radii


def disc_target_margins(attackers: np.ndarray, defenders: np.ndarray, target_radius: float,
                        speeds: tuple[float, float], capture_radius: float
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Both conditions on an obstacle-free map with a disc target at the origin, as margins,
    for attackers and defenders ``(K, 2)`` (``vD > vA``): the theory the HJ solves and the
    schemes are checked against.

    - ``slack`` (seconds): the best, over 128 target points, of the defender's time to come
      within the capture radius of the attacker's straight path minus the attacker's time
      along it; > 0: the attacker wins;
    - ``miss`` (map units): how far the Apollonius disc (capture radius 0) misses the
      target; > 0: the defender wins.
    """
    va, vd = speeds
    a = np.asarray(attackers, dtype=np.float64)
    d = np.asarray(defenders, dtype=np.float64)
    angles = np.linspace(0.0, 2 * np.pi, 128, endpoint=False)
    slack = np.full(len(a), -np.inf)
    for z in target_radius * np.stack([np.cos(angles), np.sin(angles)], axis=1):
        z = np.broadcast_to(z, a.shape)
        slack = np.maximum(slack, (segment_distance(d, a, z) - capture_radius) / vd
                           - np.linalg.norm(a - z, axis=1) / va)
    centres, radii = apollonius_disc(a, d, speeds)
    return slack, np.linalg.norm(centres, axis=1) - radii - target_radius


def play_region(attackers: np.ndarray, defenders: np.ndarray, speeds: tuple[float, float]
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where both players stay under parallel navigation (module docstring): the
    Apollonius disc (centres ``(K, 2)``, radii ``(K,)``) and the corners ``(K, 5, 2)`` of
    the cone-and-band part from the disc's centre to the defender (map units)."""
    centres, radii = apollonius_disc(attackers, defenders, speeds)
    d = np.asarray(defenders, dtype=np.float64)
    k = speeds[0] / speeds[1]
    axis = d - centres
    length = np.linalg.norm(axis, axis=1)
    e = axis / np.maximum(length, 1e-300)[:, None]
    n = np.stack([-e[:, 1], e[:, 0]], axis=1)
    shoulder = radii * (1 - np.sqrt(1 - k * k)) / k  # where the cone meets the band
    r, s = radii[:, None], shoulder[:, None]
    corners = np.stack([centres + r * n, centres + s * e + r * n, d,
                        centres + s * e - r * n, centres - r * n], axis=1)
    return centres, radii, corners


def defender_certifies(game_map: GameMap, attackers: np.ndarray, defenders: np.ndarray,
                       speeds: tuple[float, float], margin: float = 0.0,
                       clearance: float = 0.0) -> np.ndarray:
    """Whether the defender provably wins each 1 vs 1 state by parallel navigation
    (module docstring): the Apollonius disc grown by ``margin`` (map units) misses the
    target, the capsule around the segment from its centre to the defender (radius the
    disc's plus ``margin``, narrowing along the cone towards the defender) misses the
    obstacles, and the domain's walls cannot stop the
    defender: a wall whose outward normal ``nu`` has ``nu . e <= 0`` (``e`` from attacker
    to defender) is never reached, as the defender stays on the ray ``a(t) + rho e``; one
    with ``nu . e >= k`` is only left behind, as ``nu . d(t)`` cannot grow (the defender's
    speed across ``e`` is the attacker's, ``w <= vA``, along ``-e`` at least
    ``sqrt(vD^2 - w^2)``); for any other wall disc and corners must lie inside it.

    Args:
        attackers, defenders: ``(K, 2)`` positions, map units.
        speeds: ``(vA, vD)`` with ``vD > vA``.
        margin: map units.
        clearance: how far the defender's region keeps from obstacles and walls (map
            units; the players' radius in the physics world).

    Returns:
        ``(K,)`` bool.
    """
    centres, radii, corners = play_region(attackers, defenders, speeds)
    radii = radii + margin
    d = np.asarray(defenders, dtype=np.float64)
    sight = d - np.asarray(attackers, dtype=np.float64)
    e = sight / np.maximum(np.linalg.norm(sight, axis=1), 1e-300)[:, None]
    k = speeds[0] / speeds[1]
    xmin, xmax, ymin, ymax = game_map.domain
    certified = game_map.target_signed_distance(centres) > radii
    for axis, sign, edge in ((0, -1.0, -xmin), (0, 1.0, xmax), (1, -1.0, -ymin), (1, 1.0, ymax)):
        # the wall {sign * p[axis] <= edge}: safe when the line of sight points away from it
        # or within 90 degrees - asin(k) of its outward normal (docstring), else the
        # region must lie inside it
        facing = sign * e[:, axis]
        safe = (facing <= 0) | (facing >= k)
        inside = ((sign * centres[:, axis] + radii <= edge - clearance)
                  & (sign * corners[..., axis] <= edge - clearance).all(axis=1))
        certified &= safe | inside
    # the region: the capsule of the disc's radius from its centre to the shoulder, then
    # the cone in _CONE_PIECES pieces, each inside the capsule of its widest half-width;
    # all pieces of the states still in checked in one batch
    shoulder = (corners[:, 1] + corners[:, 3]) / 2  # on the axis, where the cone meets the band
    todo = np.flatnonzero(certified)
    if todo.size == 0:
        return certified
    cuts = np.linspace(0.0, 1.0, _CONE_PIECES + 1)[:, None, None]
    cone = shoulder[todo] + cuts * (d[todo] - shoulder[todo])
    starts = np.concatenate([centres[todo][None], cone[:-1]])
    ends = np.concatenate([shoulder[todo][None], cone[1:]])
    widths = np.concatenate([radii[todo][None], radii[todo] * (1 - cuts[:-1, :, 0])]) + clearance
    clear = segment_clear(game_map, starts.reshape(-1, 2), ends.reshape(-1, 2),
                          widths.reshape(-1))
    certified[todo] = clear.reshape(_CONE_PIECES + 1, -1).all(axis=0)
    return certified


_CONE_PIECES = 4
"""Pieces of the cone part of the parallel-navigation region in the obstacle test."""


def parallel_navigation(attackers: np.ndarray, defenders: np.ndarray,
                        attacker_velocities: np.ndarray, defender_speed: float) -> np.ndarray:
    """The defender's heading under parallel navigation: match the attacker's velocity
    across the line of sight and close along it at the rest of the defender's speed.

    Args:
        attackers, defenders: ``(K, 2)`` positions, map units.
        attacker_velocities: ``(K, 2)`` the attacker's velocity (map units per second;
            in discrete time its last step's displacement over the step). Zero gives pure
            pursuit.
        defender_speed: ``vD`` (map units per second), larger than the attacker's speed.

    Returns:
        ``(K, 2)`` unit headings (towards the attacker where the players coincide).
    """
    a = np.asarray(attackers, dtype=np.float64)
    d = np.asarray(defenders, dtype=np.float64)
    w = np.asarray(attacker_velocities, dtype=np.float64)
    sight = a - d
    distance = np.linalg.norm(sight, axis=1)
    e = sight / np.maximum(distance, 1e-300)[:, None]
    e[distance == 0] = (1.0, 0.0)
    across = w - np.sum(w * e, axis=1)[:, None] * e
    across_speed = np.minimum(np.linalg.norm(across, axis=1), defender_speed)
    scale = across_speed / np.maximum(np.linalg.norm(across, axis=1), 1e-300)
    closing = np.sqrt(defender_speed**2 - across_speed**2)
    velocity = across * scale[:, None] + closing[:, None] * e
    return velocity / defender_speed

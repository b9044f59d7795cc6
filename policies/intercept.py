"""Time-to-intercept defenders: race each attacker to a point of its shortest path.

An attacker heading for the target takes the shortest path around the obstacles (the
descent of the map's geodesic distance field, ``reachavoid_env.geodesic``). ``trace_paths``
samples that path every ``step`` map units from each attacker's position; the attacker
reaches the ``k``-th point after ``k * step / attacker_speed`` seconds. A defender
*intercepts* at the first point it can reach, within the capture radius, no later than
the attacker (straight-line distance at the defender's speed): heading there and
re-planning every step cuts the attacker off before the target. Where no point can be
reached in time, the defender's best point is the one it misses by the least time,
which lies near the target: it guards the attacker's way in.

``plan_intercepts`` assigns defenders to attackers by threat: the attacker closest to
the target (in time) first, to the free defender that intercepts it earliest; attackers
no free defender can intercept are skipped; defenders left over join the most
threatening attacker (a second chaser, or a guard on its way in).
``BatchInterceptDefenders`` is that plan as a policy on K copies, ``InterceptDefender``
it in one game (registry name ``intercept``), the heuristic bar the reference defenders
must clear; the assignment defenders (``policies.batch_defenders``) use the same plan
for the defenders that no certified game holds.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numba import njit

from reachavoid_env import BatchState, GameState, Overlay, Scenario
from reachavoid_env.game_state import AttackerStatus
from reachavoid_env.geodesic import DEFAULT_CELLS, DistanceField, distance_field
from reachavoid_env.jit_cache import check_numba_config
from reachavoid_env.policy import Single, checked_copies
from reachavoid_env.rules import unit_vectors

check_numba_config()   # numba loads pickled code: only from a folder of ours

PATH_STEP = 0.02
"""Spacing of the sampled attacker paths (map units)."""

MAX_POINTS = 256
"""Most points sampled on one path (``PATH_STEP`` times this covers any path of the paper
map, whose longest is about 3 map units)."""


@njit(cache=True)
def _trace(values, x0, y0, hx, hy, starts, step, max_points, points, counts):
    nx, ny = values.shape
    for a in range(starts.shape[0]):
        x, y = starts[a, 0], starts[a, 1]
        count = 0
        for _ in range(max_points):
            u = min(max((x - x0) / hx, 0.0), nx - 1.0)
            w = min(max((y - y0) / hy, 0.0), ny - 1.0)
            i = min(int(u), nx - 2)
            j = min(int(w), ny - 2)
            tx, ty = u - i, w - j
            v00, v10 = values[i, j], values[i + 1, j]
            v01, v11 = values[i, j + 1], values[i + 1, j + 1]
            points[a, count, 0], points[a, count, 1] = x, y
            count += 1
            if (v00 * (1 - tx) * (1 - ty) + v10 * tx * (1 - ty) + v01 * (1 - tx) * ty
                    + v11 * tx * ty) <= 0.0:
                break
            gx = ((v10 - v00) * (1 - ty) + (v11 - v01) * ty) / hx
            gy = ((v01 - v00) * (1 - tx) + (v11 - v10) * tx) / hy
            norm = np.sqrt(gx * gx + gy * gy)
            if norm < 1e-12:
                break
            x -= step * gx / norm
            y -= step * gy / norm
        counts[a] = count


class Paths(NamedTuple):
    """Sampled shortest paths: ``points (M, K, 2)`` (map units; row ``i`` valid up to
    ``counts[i]``, the last valid point repeated after it) and ``counts (M,)``."""

    points: np.ndarray
    counts: np.ndarray


def trace_paths(field: DistanceField, starts: np.ndarray, step: float = PATH_STEP,
                max_points: int = MAX_POINTS) -> Paths:
    """Each start's shortest path to the target, sampled every ``step`` map units.

    Args:
        field: the map's geodesic distance field.
        starts: ``(M, 2)`` start points (map units).
        step: spacing of the samples along the path (map units).
        max_points: most samples per path.

    Returns:
        ``Paths``: the first point is the start; a path ends at its first point inside
        the target (or where the field is flat, or after ``max_points``).
    """
    points, counts = traced_points(field, starts, step, max_points)
    last = np.maximum(counts - 1, 0)
    beyond = np.arange(max_points)[None, :] >= counts[:, None]
    points = np.where(beyond[..., None], points[np.arange(len(starts)), last][:, None, :],
                      points)
    return Paths(points, counts)


def traced_points(field: DistanceField, starts: np.ndarray, step: float = PATH_STEP,
                  max_points: int = MAX_POINTS) -> Paths:
    """``trace_paths`` without the padding: row ``i`` of ``points`` is valid up to
    ``counts[i]`` only (what lies beyond is undefined)."""
    starts = np.ascontiguousarray(starts, dtype=np.float64).reshape(-1, 2)
    points = np.empty((len(starts), max_points, 2))
    counts = np.zeros(len(starts), dtype=np.int64)
    hx, hy = field.spacing
    _trace(field.values, float(field.xs[0]), float(field.ys[0]), hx, hy, starts, step,
           max_points, points, counts)
    return Paths(points, counts)


class Races(NamedTuple):
    """Every defender's race against every attacker along its path (``(M, N)`` arrays).

    ``wins``: the defender reaches some point of the path, within the capture radius, no
    later than the attacker. ``aims (M, N, 2)``: the first such point, else the point it
    misses by the least time. ``times``: seconds until the attacker reaches ``aims``
    (the interception time where ``wins``). ``threat (M,)``: the attacker's time to the
    target along its path (seconds).
    """

    wins: np.ndarray
    aims: np.ndarray
    times: np.ndarray
    threat: np.ndarray


def race_copies(field: DistanceField, attackers: np.ndarray, defenders: np.ndarray,
                active: np.ndarray, attacker_speed: float, defender_speed: float,
                capture_radius: float) -> Races:
    """The ``Races`` of L copies of a game at once: every defender against every active
    attacker of its copy, the paths of all copies' active attackers traced in one call and
    raced in one; an inactive attacker's rows are never won, at infinite times.

    Args:
        field: the map's geodesic distance field.
        attackers: ``(L, M, 2)`` positions (map units), copies first.
        defenders: ``(L, N, 2)`` positions (map units).
        active: ``(L, M)`` bool, the attackers still in the game.
        attacker_speed, defender_speed: map units per second.
        capture_radius: map units.

    Returns:
        ``Races`` with a leading copy axis: ``wins``, ``times`` ``(L, M, N)``, ``aims``
        ``(L, M, N, 2)``, ``threat`` ``(L, M)``.
    """
    c, i = np.nonzero(active)
    points, counts = traced_points(field, attackers[c, i])
    attacker_time = np.arange(points.shape[1]) * PATH_STEP / attacker_speed
    won, best = race_points(points, counts, defenders, c, defender_speed, capture_radius,
                            attacker_time)
    copies, m = active.shape
    n = defenders.shape[1]
    race = Races(np.zeros((copies, m, n), dtype=bool), np.zeros((copies, m, n, 2)),
                 np.full((copies, m, n), np.inf), np.full((copies, m), np.inf))
    race.wins[c, i] = won
    race.aims[c, i] = points[np.arange(len(c))[:, None], best]
    race.times[c, i] = attacker_time[best]
    race.threat[c, i] = attacker_time[np.maximum(counts - 1, 0)]
    return race


def race_all(field: DistanceField, state: GameState) -> Races:
    """``race_copies`` of the one game ``state`` (``(M, N)`` arrays, no copy axis)."""
    race = race_copies(field, state.attacker_positions[None], state.defender_positions[None],
                       state.active_attackers[None], state.attacker_speed,
                       state.defender_speed, state.capture_radius)
    return Races(*(array[0] for array in race))


@njit(cache=True)
def race_points(points, counts, defenders, copy_of, defender_speed, capture_radius,
                attacker_time):
    """The races of traced paths, point by point: path ``t`` (``points (T, K, 2)``, valid
    up to ``counts[t]``) against every defender of ``defenders[copy_of[t]]`` (``(C, N,
    2)``: the paths of several games at once). A point's slack is the defender's time to
    come within ``capture_radius`` of it (straight line at ``defender_speed``) less the
    attacker's ``attacker_time`` (seconds, by point index). Returns ``won (T, N)``, some
    point's slack <= 0, and ``best (T, N)``: the first such point, else the first of
    least slack."""
    paths, n = points.shape[0], defenders.shape[1]
    won = np.zeros((paths, n), dtype=np.bool_)
    best = np.zeros((paths, n), dtype=np.int64)
    for t in range(paths):
        c = copy_of[t]
        for j in range(n):
            least, at = np.inf, 0
            for k in range(counts[t]):
                gap = np.hypot(points[t, k, 0] - defenders[c, j, 0],
                               points[t, k, 1] - defenders[c, j, 1])
                slack = max(gap - capture_radius, 0.0) / defender_speed - attacker_time[k]
                if slack <= 0.0:
                    won[t, j] = True
                    at = k
                    break
                if slack < least:
                    least, at = slack, k
            best[t, j] = at
    return won, best


class Plan(NamedTuple):
    """Which attacker each defender goes for (``targets (N,)``, -1 for none) and the point
    it heads to (``aims (N, 2)``, map units)."""

    targets: np.ndarray
    aims: np.ndarray


def plan_intercepts(race: Races, free: np.ndarray, open_: np.ndarray) -> Plan:
    """The free defenders' plan against the ``open_`` attackers of one game (bool masks
    ``(N,)`` and ``(M,)``): ``plan_copies`` of that one copy.

    Most threatening attacker first (smallest ``race.threat``), each gets the free
    defender that intercepts it earliest; attackers no free defender can intercept are
    skipped. Each defender still free then joins the open attacker it intercepts
    earliest, or, where it intercepts none, the most threatening open attacker (its aim
    the point it misses by the least time: a guard on that attacker's way in).
    """
    plan = plan_copies(Races(*(np.asarray(array)[None] for array in race)),
                       np.asarray(free, dtype=bool)[None], np.asarray(open_, dtype=bool)[None])
    return Plan(plan.targets[0], plan.aims[0])


def plan_copies(race: Races, free: np.ndarray, open_: np.ndarray) -> Plan:
    """``plan_intercepts`` of L copies at once (one numba call).

    Args:
        race: ``Races`` with a leading copy axis (``race_copies``).
        free: ``(L, N)`` bool, the defenders the plan may send.
        open_: ``(L, M)`` bool, the attackers it plans against.

    Returns:
        ``Plan`` with a leading copy axis: ``targets (L, N)`` (-1 for none), ``aims
        (L, N, 2)`` map units (zero for none). Ties go as in a stable sort of the threat,
        then to the first defender, then to the first attacker in threat order
        (``tests/defenders_reference.py`` holds a numpy twin).
    """
    targets, aims = _plan(np.ascontiguousarray(race.wins, dtype=np.bool_),
                          np.ascontiguousarray(race.aims, dtype=np.float64),
                          np.ascontiguousarray(race.times, dtype=np.float64),
                          np.ascontiguousarray(race.threat, dtype=np.float64),
                          np.ascontiguousarray(free, dtype=np.bool_),
                          np.ascontiguousarray(open_, dtype=np.bool_))
    return Plan(targets, aims)


@njit(cache=True)
def _plan(wins, aims, times, threat, free, open_):
    """The kernel of ``plan_copies``: ``targets (L, N)`` and ``aims (L, N, 2)``."""
    copies, m, n = wins.shape
    targets = np.full((copies, n), -1, dtype=np.int64)
    planned = np.zeros((copies, n, 2))
    order = np.empty(m, dtype=np.int64)
    left = np.empty(n, dtype=np.bool_)
    for c in range(copies):
        count = 0
        for i in range(m):  # open attackers by threat, stable (insertion sort)
            if not open_[c, i]:
                continue
            at = count
            while at > 0 and threat[c, i] < threat[c, order[at - 1]]:
                order[at] = order[at - 1]
                at -= 1
            order[at] = i
            count += 1
        if count == 0:
            continue
        left[:] = free[c]
        for r in range(count):
            i = order[r]
            best = -1
            for j in range(n):
                if left[j] and wins[c, i, j] and (best < 0 or times[c, i, j] < times[c, i, best]):
                    best = j
            if best >= 0:
                targets[c, best] = i
                planned[c, best] = aims[c, i, best]
                left[best] = False
        for j in range(n):
            if not left[j]:
                continue
            best = -1
            for r in range(count):
                i = order[r]
                if wins[c, i, j] and (best < 0 or times[c, i, j] < times[c, best, j]):
                    best = i
            if best < 0:
                best = order[0]
            targets[c, j] = best
            planned[c, j] = aims[c, best, j]
    return targets, planned


def headings(plan: Plan, defenders: np.ndarray, attackers: np.ndarray) -> np.ndarray:
    """Unit headings ``(..., N, 2)`` towards each planned aim (straight at the attacker
    where the aim is the defender's own position); zero for defenders without a target.
    Any leading axes (copies of a game) are shared by ``plan``'s arrays, ``defenders``
    and ``attackers`` (``(..., M, 2)``)."""
    planned = plan.targets >= 0
    gaps = plan.aims - defenders
    at_aim = np.hypot(gaps[..., 0], gaps[..., 1]) < 1e-9
    chased = np.take_along_axis(attackers, np.maximum(plan.targets, 0)[..., None], axis=-2)
    gaps[at_aim] = chased[at_aim] - defenders[at_aim]
    gaps[~planned] = 0.0
    return unit_vectors(gaps) * planned[..., None]


class BatchInterceptDefenders:
    """The time-to-intercept defenders on K copies of a game: in each copy, every defender
    races an attacker to a point of its shortest path (``plan_copies``), re-planned every
    step; defenders left over back up the most threatening attacker.

    ``cells`` is the resolution of the geodesic field (``reachavoid_env.geodesic``). The
    copies share the map and player radius of the first scenario reset (a reset of every
    copy may change them). ``overlay(copy)`` shows each of copy ``copy``'s defenders'
    targets as an edge.
    """

    def __init__(self, cells: int = DEFAULT_CELLS) -> None:
        self.cells = cells
        self.field: DistanceField | None = None
        self._targets = np.zeros((0, 0), dtype=np.int64)   # (K, N), -1 for none
        self._copies = 0
        self._game: tuple | None = None

    def reset_copies(self, copies: np.ndarray, scenarios: Sequence[Scenario]) -> None:
        copies = checked_copies(copies, scenarios)
        if set(range(self._copies)) <= set(copies.tolist()):
            self._game = None   # every copy starts again: the map may change
        for scenario in scenarios:
            game = (scenario.map, scenario.player_radius)
            if self._game is None:
                self._game = game
                self.field = distance_field(scenario.map, scenario.player_radius, self.cells)
            elif game != self._game:
                raise ValueError(f"scenarios: {scenario.name!r} has another map or player "
                                 f"radius than the copies'")
        if len(copies):
            self._copies = max(self._copies, int(copies.max()) + 1)
        self._targets[copies[copies < len(self._targets)]] = -1

    def act_batch(self, states: BatchState) -> np.ndarray:
        """Unit headings ``(K, N, 2)`` float32 towards each defender's aim (fractions of
        the defender's speed); zeros in a copy without active attackers."""
        if self.field is None:
            raise RuntimeError("act_batch: call reset_copies first")
        attackers = np.asarray(states.attacker_positions, dtype=np.float64)
        defenders = np.asarray(states.defender_positions, dtype=np.float64)
        active = np.asarray(states.attacker_status) == AttackerStatus.ACTIVE.code
        plan = plan_copies(race_copies(self.field, attackers, defenders, active,
                                       states.attacker_speed, states.defender_speed,
                                       states.capture_radius),
                           np.ones(defenders.shape[:2], dtype=bool), active)
        actions = headings(plan, defenders, attackers).astype(np.float32)
        actions[~active.any(axis=1)] = 0.0
        self._targets = plan.targets
        return actions

    def overlay(self, copy: int) -> Overlay:
        """Copy ``copy``'s edges ``(defender, target)`` of the last step."""
        targets = self._targets[copy].tolist() if copy < len(self._targets) else []
        return Overlay(edges=tuple((f"defender_{j}", f"attacker_{i}")
                                   for j, i in enumerate(targets) if i >= 0))


class InterceptDefender(Single):
    """``BatchInterceptDefenders`` in one game (registry name ``intercept``): every
    defender races an attacker to a point of its shortest path, re-planned every step;
    ``overlay()`` shows each defender's target as an edge."""

    def __init__(self, cells: int = DEFAULT_CELLS) -> None:
        super().__init__(BatchInterceptDefenders(cells))

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        if self.batch.field is None:
            raise RuntimeError("InterceptDefender.act called before reset(scenario)")
        return super().act(state)

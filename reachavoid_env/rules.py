"""The rulebook: controls, capture, arrival and which event comes first within a step.

Every other place that needs a rule (the env, scenario validation, the policies, the HJ
games' target and avoid sets) calls or cites these functions; the numba kernels of the
solvers keep their own fast form and are tested against this module.

- **Controls**: a player's velocity is ``speed * u`` with ``|u| <= 1``; a longer ``u`` is
  scaled to length 1 (``bounded_controls``).
- **Capture**: an attacker is captured when some defender is within ``capture_radius``
  (``distance <= capture_radius``, map units; ``within_capture``).
- **Arrival**: an attacker arrives when its position is in the target (inclusive bounds,
  ``GameMap.in_target``).
- **Within one step** every player moves along the path the world moved it along: the
  straight segment from its old to its new position, unless a wall turned it during the
  step (it slid: its new position is not where its velocity alone would have taken it).
  A slid player's path is the polyline through its sub-step positions (``world.World``
  moves players in straight lines between sub-steps; ``Moves.replay``), so an attacker that
  slid into a corner is judged where it went, not on the chord. An active attacker's
  earliest event wins: capture at the first instant a defender is within
  ``capture_radius``, arrival at the first instant its path touches the target; a tie
  goes to capture (``resolve_batch``, the one resolver, for ``K`` copies at once;
  ``resolve_events`` is its view of one game). Players that did not slide are judged on
  their straight segment exactly as without ``Moves``; paths are replayed only for slid
  players that are near an event, so an ordinary step costs nothing more. ``EventWatch``
  tells steps in which no event can happen, so that one game skips the resolver.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from reachavoid_env.shapes import quadratic_entry_time

if TYPE_CHECKING:
    from reachavoid_env.game_map import GameMap


def bounded_controls(controls: np.ndarray) -> np.ndarray:
    """``controls`` ``(..., 2)`` with every vector longer than 1 scaled to length 1.

    Lengths use ``hypot``, so huge finite vectors (``[1e200, 1e200]``) are scaled, not lost
    to overflow.
    """
    lengths = np.hypot(controls[..., 0], controls[..., 1])
    return controls / np.maximum(lengths, 1.0)[..., None]


def unit_vectors(vectors: np.ndarray, floor: float = 0.0) -> np.ndarray:
    """``vectors`` ``(..., 2)`` scaled to length 1; those no longer than ``floor`` become
    zero (no direction)."""
    lengths = np.hypot(vectors[..., 0], vectors[..., 1])[..., None]
    return np.divide(vectors, lengths, out=np.zeros_like(vectors, dtype=np.float64),
                     where=lengths > floor)


def within_capture(attackers: np.ndarray, defenders: np.ndarray,
                   capture_radius: float) -> np.ndarray:
    """``(M, N)`` bool: defender ``j`` is within ``capture_radius`` of attacker ``i``.

    Positions are ``(M, 2)`` and ``(N, 2)`` map units.
    """
    gaps = attackers[:, None, :] - defenders[None, :, :]
    return np.einsum("ijk,ijk->ij", gaps, gaps) <= capture_radius * capture_radius


def capture_times(attackers_old: np.ndarray, attackers_new: np.ndarray,
                  defenders_old: np.ndarray, defenders_new: np.ndarray,
                  capture_radius: float) -> np.ndarray:
    """Earliest capture time of every attacker-defender pair within one step.

    Positions are ``(..., M, 2)`` and ``(..., N, 2)`` map units at the start and end of the
    step (``...``: copies of the game, as the vector env steps them);
    each pair's offset moves linearly, so the capture time is the first root of a
    quadratic. Returns ``(..., M, N)`` fractions of the step in ``[0, 1]``, ``inf`` where the
    pair never comes within ``capture_radius``.
    """
    offsets = attackers_old[..., :, None, :] - defenders_old[..., None, :, :]
    motions = ((attackers_new - attackers_old)[..., :, None, :]
               - (defenders_new - defenders_old)[..., None, :, :])
    return quadratic_entry_time(offsets, motions, capture_radius)


@dataclass(eq=False, slots=True)
class StepEvents:
    """What happened to the attackers during one step (arrays ``(M,)``).

    ``captured`` / ``arrived``: bool; ``times``: the fraction of the step at which the
    attacker left the game (``inf`` for those that stay); ``captor``: the index of the
    capturing defender, ``-1`` where none.
    """

    captured: np.ndarray
    arrived: np.ndarray
    times: np.ndarray
    captor: np.ndarray
    left: np.ndarray
    """Attackers that left the game this step (captured or arrived)."""
    stops: np.ndarray
    """``(M, 2)``: where each attacker that left was at its event (on its path; the new
    position for the others)."""


def longest_move(fastest: float, dt: float) -> float:
    """The longest move anyone can ask for in a step (``Moves.longest``): the largest speed
    (map units per second) times ``dt`` (seconds), rounded up by a relative 1e-9."""
    return (1.0 + 1e-9) * fastest * dt


SLIDE_TOLERANCE = 1e-9
"""A player slid when its step ended farther than this (relative to the step's length
plus one map unit) from where its velocity alone would have taken it."""


class Moves(NamedTuple):
    """How the world moved the players this step, for judging slid players on their path.

    ``velocities``: ``(M + N, 2)`` what the players asked for (map units per second),
    attackers first; ``dt``: the step (seconds). ``replay(players)``: the sub-step
    positions ``(S + 1, P, 2)`` of ``players`` (indices into the ``M + N``) from their old
    positions (``world.World.replay`` of their velocities). ``longest``: the longest move
    anyone can ask for (largest speed times ``dt``, rounded up; no path is longer)."""

    velocities: np.ndarray
    dt: float
    replay: Callable[[np.ndarray], np.ndarray]
    longest: float


class _Slides(NamedTuple):
    arrival: np.ndarray
    bent: np.ndarray
    """Indices of the attackers judged on their path."""
    paths: np.ndarray
    """``(S + 1, len(bent), 2)``: their paths."""


def slid(old: np.ndarray, new: np.ndarray, desired: np.ndarray) -> np.ndarray:
    """``(...)`` bool: the players (``(..., 2)`` positions and asked moves) whose step did
    not end where their asked move would have taken them: a wall turned or stopped them."""
    miss = np.abs(new - old - desired).max(axis=-1)
    return miss > SLIDE_TOLERANCE * (1.0 + np.abs(desired).max(axis=-1))


def straight_path(old: np.ndarray, new: np.ndarray, substeps: int) -> np.ndarray:
    """``(substeps + 1, ..., 2)``: points evenly along the segments from ``old`` to ``new``
    (the sub-step positions of players that did not slide)."""
    fractions = np.linspace(0.0, 1.0, substeps + 1).reshape(-1, *([1] * old.ndim))
    return old + fractions * (new - old)


def path_entry_time(game_map: GameMap, path: np.ndarray) -> np.ndarray:
    """First time (fraction of the step) at which each path ``(S + 1, ..., 2)`` touches the
    target: ``(...)``, ``inf`` where it never does."""
    times = game_map.target_entry_time(path[:-1], path[1:])
    return _first(times)


def _first(times: np.ndarray) -> np.ndarray:
    """Earliest ``(k + t_k) / S`` over the sub-steps (axis 0) of per-sub-step times."""
    substeps = times.shape[0]
    whole = times + np.arange(substeps).reshape(-1, *([1] * (times.ndim - 1)))
    return whole.min(axis=0) / substeps


def path_capture_times(attackers: np.ndarray, defenders: np.ndarray,
                       capture_radius: float) -> np.ndarray:
    """``capture_times`` along paths: ``(S + 1, M, 2)`` and ``(S + 1, N, 2)`` sub-step
    positions; ``(M, N)`` fractions of the step, ``inf`` where a pair never meets."""
    offsets = attackers[:-1, :, None, :] - defenders[:-1, None, :, :]
    motions = (np.diff(attackers, axis=0)[:, :, None, :]
               - np.diff(defenders, axis=0)[:, None, :, :])
    return _first(quadratic_entry_time(offsets, motions, capture_radius))


def position_on_path(path: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Positions ``(P, 2)`` at ``times`` ``(P,)`` (fractions of the step, in ``[0, 1]``) on
    paths ``(S + 1, P, 2)``."""
    substeps = path.shape[0] - 1
    scaled = np.clip(times, 0.0, 1.0) * substeps
    k = np.minimum(np.floor(scaled).astype(np.intp), substeps - 1)
    players = np.arange(path.shape[1])
    start, end = path[k, players], path[k + 1, players]
    return start + (scaled - k)[:, None] * (end - start)


def target_bounds(game_map: GameMap) -> tuple[float, float, float, float]:
    """Bounding box ``(xmin, xmax, ymin, ymax)`` of the target union (map units)."""
    bounds = np.array([shape.bounds() for shape in game_map.target])
    return (float(bounds[:, 0].min()), float(bounds[:, 1].max()), float(bounds[:, 2].min()),
            float(bounds[:, 3].max()))


def target_box(bounds: tuple[float, float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """The centre ``(2,)`` and half extent ``(2,)`` (map units, x then y) of a bounding box
    ``(xmin, xmax, ymin, ymax)`` (``target_bounds``)."""
    xmin, xmax, ymin, ymax = bounds
    return (np.array([(xmin + xmax) / 2, (ymin + ymax) / 2]),
            np.array([(xmax - xmin) / 2, (ymax - ymin) / 2]))


class BatchMoves(NamedTuple):
    """``Moves`` of ``K`` copies: ``velocities`` ``(K, M + N, 2)``, ``dt``, ``longest``, and
    ``replay(copy, players)``, the sub-step positions ``(S + 1, P, 2)`` of ``players`` of
    copy ``copy`` (``world.World.replay``)."""

    velocities: np.ndarray
    dt: float
    replay: Callable[[int, np.ndarray], np.ndarray]
    longest: float


def resolve_events(game_map: GameMap, capture_radius: float, active: np.ndarray,
                   attackers_old: np.ndarray, attackers_new: np.ndarray,
                   defenders_old: np.ndarray, defenders_new: np.ndarray,
                   bounds: tuple[float, float, float, float] | None = None,
                   moves: Moves | None = None) -> StepEvents:
    """``resolve_batch`` of one game: ``active`` ``(M,)``, positions ``(M, 2)`` and
    ``(N, 2)`` map units; events ``(M,)``."""
    batch = None if moves is None else BatchMoves(
        moves.velocities[None], moves.dt, lambda _copy, players: moves.replay(players),
        moves.longest)
    events = resolve_batch((game_map,), _ONE_COPY, capture_radius, active[None],
                           attackers_old[None], attackers_new[None], defenders_old[None],
                           defenders_new[None], batch, None if bounds is None else (bounds,))
    return StepEvents(events.captured[0], events.arrived[0], events.times[0],
                      events.captor[0], events.left[0], events.stops[0])


_ONE_COPY = np.zeros(1, dtype=np.intp)


def resolve_batch(maps: Sequence[GameMap], map_of: np.ndarray, capture_radius: float,
                  active: np.ndarray, attackers_old: np.ndarray, attackers_new: np.ndarray,
                  defenders_old: np.ndarray, defenders_new: np.ndarray,
                  moves: BatchMoves | None = None,
                  bounds: Sequence[tuple[float, float, float, float]] | None = None,
                  ) -> StepEvents:
    """Which of the ``active`` attackers of ``K`` copies are captured or arrive in one step.

    Args:
        maps: the maps the copies play; copy ``k`` plays ``maps[map_of[k]]``.
        map_of: ``(K,)`` int.
        capture_radius: map units.
        active: ``(K, M)`` bool, the attackers in play.
        attackers_old, attackers_new: ``(K, M, 2)`` positions (map units) at the start and
            the end of the step.
        defenders_old, defenders_new: ``(K, N, 2)`` the same.
        moves: judge the players that slid on their paths (``BatchMoves``); without it
            every player is judged on its straight segment.
        bounds: ``target_bounds`` of every map (only saves work).

    Returns:
        ``StepEvents`` of arrays ``(K, M)`` (``stops`` ``(K, M, 2)``). Each attacker's
        earliest event wins; a tie goes to capture (module docstring). Two cheap filters
        skip the exact tests for pairs too far apart to meet and attackers too far from
        the target; every copy's events are those of the copy alone.
    """
    k, m = active.shape
    t_capture, t_arrival = np.full((k, m), np.inf), np.full((k, m), np.inf)
    captor = np.full((k, m), -1)
    # Nobody moves farther than sqrt(2) times its largest coordinate change (nor along a
    # path farther than the longest asked move), so a pair farther apart than
    # capture_radius plus two such moves cannot meet this step.
    if moves is None:
        a_move = np.abs(attackers_new - attackers_old)
        longest = math.sqrt(2.0) * np.maximum(
            a_move.max(axis=(1, 2)),
            np.abs(defenders_new - defenders_old).max(axis=(1, 2)))[:, None, None]
    else:
        a_move = longest = moves.longest
    reach = capture_radius + 2.0 * longest
    gaps = attackers_old[:, :, None, :] - defenders_old[:, None, :, :]
    meeting = (np.einsum("kijd,kijd->kij", gaps, gaps) <= reach * reach) & active[..., None]
    pair_times = None
    if meeting.any():
        pair_times = capture_times(attackers_old, attackers_new, defenders_old, defenders_new,
                                   capture_radius)
    # Only attackers whose move spans the target's bounding box on both axes can enter it.
    boxes = [target_box(b) for b in (bounds or [target_bounds(g) for g in maps])]
    if len(maps) == 1:
        centre, half = boxes[0]
    else:
        centre = np.array([box[0] for box in boxes])[map_of][:, None]
        half = np.array([box[1] for box in boxes])[map_of][:, None]
    near = (np.abs(attackers_old - centre) <= half + a_move).all(axis=2) & active
    if near.any():
        for index in np.unique(map_of[near.any(axis=1)]).tolist():
            here = near if len(maps) == 1 else near & (map_of == index)[:, None]
            t_arrival[here] = maps[index].target_entry_time(attackers_old[here],
                                                            attackers_new[here])
    slides: dict[int, _Slides] = {}
    if moves is not None and (near.any() or pair_times is not None):
        old = np.concatenate([attackers_old, defenders_old], axis=1)
        new = np.concatenate([attackers_new, defenders_new], axis=1)
        involved = np.concatenate([near | meeting.any(axis=2), meeting.any(axis=1)], axis=1)
        moved = slid(old, new, moves.velocities * moves.dt) & involved
        for c in np.flatnonzero(moved.any(axis=1)).tolist():
            slides[c] = _judge_slides(maps[map_of[c]], capture_radius, moved[c],
                                      functools.partial(moves.replay, c), near[c], meeting[c],
                                      None if pair_times is None else pair_times[c],
                                      t_arrival[c], old[c], new[c])
            t_arrival[c] = slides[c].arrival
    if pair_times is not None:
        captor = pair_times.argmin(axis=2)
        t_capture = np.take_along_axis(pair_times, captor[..., None], axis=2)[..., 0]
    captured = active & (t_capture <= 1.0) & (t_capture <= t_arrival)
    arrived = active & ~captured & (t_arrival <= 1.0)
    left = captured | arrived
    times = np.where(captured, t_capture, np.where(arrived, t_arrival, np.inf))
    stops = attackers_new
    if left.any():
        stops = attackers_new.copy()
        t = times[left][:, None]
        stops[left] = attackers_old[left] + t * (attackers_new[left] - attackers_old[left])
        for c, bent in slides.items():
            which = left[c, bent.bent]
            if which.any():
                stops[c, bent.bent[which]] = position_on_path(bent.paths[:, which],
                                                              times[c, bent.bent[which]])
    return StepEvents(captured, arrived, times, np.where(captured, captor, -1), left, stops)


def _judge_slides(game_map: GameMap, capture_radius: float, moved: np.ndarray,
                  replay: Callable[[np.ndarray], np.ndarray], near: np.ndarray,
                  meeting: np.ndarray, pair_times: np.ndarray | None, arrival: np.ndarray,
                  old: np.ndarray, new: np.ndarray) -> _Slides:
    """``resolve_batch``' times of one copy again, on the players' paths (``replay``), for
    the attackers near the target that slid and the pairs that may meet where either
    slid; ``moved`` ``(M + N,)`` marks the players near an event that slid (some do).
    ``pair_times`` ``(M, N)`` is updated in place."""
    m = len(near)
    players = np.flatnonzero(moved)
    replayed = replay(players)
    replayed[0], replayed[-1] = old[players], new[players]   # the world's own ends
    path = straight_path(old, new, replayed.shape[0] - 1)
    path[:, players] = replayed
    bent = np.flatnonzero(moved[:m])
    arrival = arrival.copy()
    turned = bent[near[bent]]
    arrival[turned] = path_entry_time(game_map, path[:, turned])
    pairs = meeting & (moved[:m, None] | moved[None, m:])
    if pairs.any():
        rows = np.flatnonzero(pairs.any(axis=1))
        bent_times = path_capture_times(path[:, rows], path[:, m:], capture_radius)
        pair_times[rows] = np.where(pairs[rows], bent_times, pair_times[rows])  # computed
    return _Slides(arrival, bent, path[:, bent])


class EventWatch:
    """Tells, cheaply, steps in which ``resolve_events`` can find no event (most steps).

    No player's path in a step is longer than ``longest`` (``Moves.longest``, the premise
    of ``resolve_events``' filters). ``anchor`` takes the positions at the start of a step
    and measures the slack before any active attacker could pass either filter: its
    distance to the nearest defender less ``capture_radius``, over 2 (both players move),
    and its distance to the target's bounding box along the farther axis. ``quiet`` spends
    ``longest`` per step; while the steps since the anchor (this one included) spend less
    than the slack, neither filter can pass, so the step has no event. The slack is shrunk
    by ``1e-9`` (relative, and absolute at the coordinates' scale) so that rounding can
    only make the watch more careful. Before the first anchor no step is quiet.
    """

    def __init__(self, capture_radius: float, bounds: tuple[float, float, float, float],
                 longest: float) -> None:
        self._radius, self._longest = capture_radius, longest
        self._centre, self._half = target_box(bounds)
        self._slack = -math.inf
        self._spent = 0.0

    def anchor(self, active: np.ndarray, attackers: np.ndarray, defenders: np.ndarray) -> None:
        """Measure the slack from these positions, the start of the next step.

        Args:
            active: ``(M,)`` bool, the attackers in play.
            attackers: ``(M, 2)`` map units.
            defenders: ``(N, 2)`` map units.
        """
        self._spent = 0.0
        attackers = attackers[active]
        if not len(attackers):
            self._slack = math.inf  # no attacker in play: no event can happen
            return
        gaps = attackers[:, None, :] - defenders[None, :, :]
        meet = (math.sqrt(np.einsum("ijk,ijk->ij", gaps, gaps).min()) - self._radius) / 2.0
        enter = float((np.abs(attackers - self._centre) - self._half).max(axis=1).min())
        slack = min(meet, enter)
        scale = max(float(np.abs(attackers).max()), float(np.abs(defenders).max()), 1.0)
        self._slack = slack - 1e-9 * (abs(slack) + scale)

    def quiet(self) -> bool:
        """Spend one step: whether it certainly has no event."""
        self._spent += self._longest
        return self._spent < self._slack


def no_events(stops: np.ndarray) -> StepEvents:
    """The events of a step in which no attacker left: ``stops`` ``(..., M, 2)`` their new
    positions (map units); arrays ``(..., M)``."""
    shape = stops.shape[:-1]
    return StepEvents(np.zeros(shape, dtype=bool), np.zeros(shape, dtype=bool),
                      np.full(shape, np.inf), np.full(shape, -1), np.zeros(shape, dtype=bool),
                      stops)

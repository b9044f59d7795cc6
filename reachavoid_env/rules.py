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
  goes to capture (``resolve_events``). Players that did not slide are judged on their
  straight segment exactly as without ``Moves``; paths are replayed only for slid players
  that are near an event, so an ordinary step costs nothing more.
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
    pair_times: np.ndarray | None
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


def resolve_events(game_map: GameMap, capture_radius: float, active: np.ndarray,
                   attackers_old: np.ndarray, attackers_new: np.ndarray,
                   defenders_old: np.ndarray, defenders_new: np.ndarray,
                   bounds: tuple[float, float, float, float] | None = None,
                   moves: Moves | None = None) -> StepEvents:
    """Which of the ``active`` ``(M,)`` attackers are captured or arrive during one step.

    Each attacker's earliest event wins; a tie goes to capture (module docstring).
    ``bounds`` (``target_bounds(game_map)``) only saves work: two cheap filters skip the
    exact tests for pairs too far apart to meet and attackers too far from the target.
    ``moves``: judge the players that slid on their paths (``Moves``); without it every
    player is judged on its straight segment.
    """
    m = len(active)
    never = np.full(m, np.inf)
    t_capture, t_arrival, captor = never, never, np.full(m, -1)
    # Nobody moves farther than sqrt(2) times its largest coordinate change (nor along a
    # path farther than the longest asked move), so a pair farther apart than
    # capture_radius plus two such moves cannot meet this step.
    if moves is None:
        a_move = np.abs(attackers_new - attackers_old)
        longest = math.sqrt(2.0) * max(a_move.max(),
                                       np.abs(defenders_new - defenders_old).max())
    else:
        a_move = longest = moves.longest
    reach = capture_radius + 2.0 * longest
    gaps = attackers_old[:, None, :] - defenders_old[None, :, :]
    distances = np.einsum("ijk,ijk->ij", gaps, gaps)
    meeting = distances <= reach * reach
    pair_times = None
    if meeting[active].any():
        pair_times = capture_times(attackers_old, attackers_new, defenders_old, defenders_new,
                                   capture_radius)
    # Only attackers whose move spans the target's bounding box on both axes can enter it.
    xmin, xmax, ymin, ymax = bounds or target_bounds(game_map)
    centre = np.array([(xmin + xmax) / 2, (ymin + ymax) / 2])
    half = np.array([(xmax - xmin) / 2, (ymax - ymin) / 2])
    near = (np.abs(attackers_old - centre) <= half + a_move).all(axis=1) & active
    if near.any():
        t_arrival = never.copy()
        t_arrival[near] = game_map.target_entry_time(attackers_old[near], attackers_new[near])
    slides = None
    if moves is not None and (near.any() or pair_times is not None):
        slides = _judge_slides(game_map, capture_radius, moves, near,
                               meeting & active[:, None], pair_times, t_arrival,
                               np.concatenate([attackers_old, defenders_old]),
                               np.concatenate([attackers_new, defenders_new]))
        if slides is not None:
            pair_times, t_arrival = slides.pair_times, slides.arrival
    if pair_times is not None:
        captor = pair_times.argmin(axis=1)
        t_capture = pair_times[np.arange(m), captor]
    captured = active & (t_capture <= 1.0) & (t_capture <= t_arrival)
    arrived = active & ~captured & (t_arrival <= 1.0)
    left = captured | arrived
    times = np.where(captured, t_capture, np.where(arrived, t_arrival, np.inf))
    stops = attackers_new
    if left.any():
        stops = attackers_new.copy()
        t = times[left][:, None]
        stops[left] = attackers_old[left] + t * (attackers_new[left] - attackers_old[left])
        if slides is not None and left[slides.bent].any():
            which = left[slides.bent]
            stops[slides.bent[which]] = position_on_path(slides.paths[:, which],
                                                         times[slides.bent[which]])
    return StepEvents(captured, arrived, times, np.where(captured, captor, -1), left, stops)


def _judge_slides(game_map: GameMap, capture_radius: float, moves: Moves, near: np.ndarray,
                  meeting: np.ndarray, pair_times: np.ndarray | None, arrival: np.ndarray,
                  old: np.ndarray, new: np.ndarray) -> _Slides | None:
    """``resolve_events``' times again, on the players' paths (``Moves.replay``), for the
    attackers near the target that slid and the pairs that may meet where either slid;
    ``None`` when nobody near an event slid."""
    m = len(near)
    involved = np.zeros(len(old), dtype=bool)
    involved[:m] = near | meeting.any(axis=1)
    involved[m:] = meeting.any(axis=0)
    moved = np.zeros(len(old), dtype=bool)
    moved[involved] = slid(old[involved], new[involved], moves.velocities[involved] * moves.dt)
    if not moved.any():
        return None
    players = np.flatnonzero(moved)
    replayed = moves.replay(players)
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
        pair_times = pair_times.copy()   # computed: some pair may meet
        pair_times[rows] = np.where(pairs[rows], bent_times, pair_times[rows])
    return _Slides(pair_times, arrival, bent, path[:, bent])


class BatchMoves(NamedTuple):
    """``Moves`` of ``K`` copies: ``velocities`` ``(K, M + N, 2)``, ``dt``, ``longest``, and
    ``replay(copy, players)``, the sub-step positions ``(S + 1, P, 2)`` of ``players`` of
    copy ``copy`` (``world.World.replay``)."""

    velocities: np.ndarray
    dt: float
    replay: Callable[[int, np.ndarray], np.ndarray]
    longest: float


def resolve_batch(maps: Sequence[GameMap], map_of: np.ndarray, capture_radius: float,
                  active: np.ndarray, attackers_old: np.ndarray, attackers_new: np.ndarray,
                  defenders_old: np.ndarray, defenders_new: np.ndarray,
                  moves: BatchMoves) -> StepEvents:
    """``resolve_events`` of ``K`` copies at once: arrays ``(K, M)`` / ``(K, M, 2)`` /
    ``(K, N, 2)``, copy ``k`` on map ``maps[map_of[k]]``. Each copy's events are exactly
    those ``resolve_events`` (with its ``Moves``) finds for it: the straight segments with
    the same arithmetic, element by element, and ``resolve_events`` itself for the few
    copies where a player near an event slid (the rule that judges it on its path)."""
    k, m = active.shape
    pair_times = capture_times(attackers_old, attackers_new, defenders_old, defenders_new,
                               capture_radius)
    captor = pair_times.argmin(axis=2)
    t_capture = np.take_along_axis(pair_times, captor[..., None], axis=2)[..., 0]
    t_arrival = np.full((k, m), np.inf)
    # The copies to hand to resolve_events: where a player near an event (a superset of
    # what resolve_events calls near, by a relative 1e-6) slid.
    wide = moves.longest * (1.0 + 1e-6)
    near = np.zeros((k, m), dtype=bool)
    for index in np.unique(map_of).tolist():
        xmin, xmax, ymin, ymax = target_bounds(maps[index])
        centre = np.array([(xmin + xmax) / 2, (ymin + ymax) / 2])
        half = np.array([(xmax - xmin) / 2, (ymax - ymin) / 2])
        here = (map_of == index)[:, None] & active
        near |= (np.abs(attackers_old - centre) <= half + wide).all(axis=2) & here
        if near.any():
            t_arrival[near & here] = maps[index].target_entry_time(
                attackers_old[near & here], attackers_new[near & here])
    captured = active & (t_capture <= 1.0) & (t_capture <= t_arrival)
    arrived = active & ~captured & (t_arrival <= 1.0)
    left = captured | arrived
    times = np.where(captured, t_capture, np.where(arrived, t_arrival, np.inf))
    stops = attackers_new.copy()
    stops[left] = attackers_old[left] + times[left][:, None] * (attackers_new[left]
                                                               - attackers_old[left])
    events = StepEvents(captured, arrived, times, np.where(captured, captor, -1), left, stops)
    reach = (capture_radius + 2.0 * moves.longest) * (1.0 + 1e-6)
    gaps = attackers_old[:, :, None, :] - defenders_old[:, None, :, :]
    meeting = (np.einsum("kijd,kijd->kij", gaps, gaps) <= reach * reach) & active[..., None]
    old = np.concatenate([attackers_old, defenders_old], axis=1)
    new = np.concatenate([attackers_new, defenders_new], axis=1)
    moved = slid(old, new, moves.velocities * moves.dt)
    involved = np.concatenate([near | meeting.any(axis=2), meeting.any(axis=1)], axis=1)
    for c in np.flatnonzero((moved & involved).any(axis=1)).tolist():
        one = resolve_events(maps[map_of[c]], capture_radius, active[c], attackers_old[c],
                             attackers_new[c], defenders_old[c], defenders_new[c],
                             target_bounds(maps[map_of[c]]),
                             Moves(moves.velocities[c], moves.dt,
                                   functools.partial(moves.replay, c), moves.longest))
        for field in ("captured", "arrived", "times", "captor", "left", "stops"):
            getattr(events, field)[c] = getattr(one, field)
    return events


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
        xmin, xmax, ymin, ymax = bounds
        self._centre = np.array([(xmin + xmax) / 2, (ymin + ymax) / 2])
        self._half = np.array([(xmax - xmin) / 2, (ymax - ymin) / 2])
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


def no_events(m: int, stops: np.ndarray) -> StepEvents:
    """The events of a step in which none of ``m`` attackers left; ``stops`` ``(M, 2)``
    their new positions."""
    return StepEvents(np.zeros(m, dtype=bool), np.zeros(m, dtype=bool), np.full(m, np.inf),
                      np.full(m, -1), np.zeros(m, dtype=bool), stops)

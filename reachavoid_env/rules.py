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
- **Within one step** every player moves along the straight segment from its old to its
  new position. An active attacker's earliest event wins: capture at the first instant a
  defender is within ``capture_radius``, arrival at the first instant its segment touches
  the target; a tie goes to capture (``resolve_events``).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from reachavoid_env.shapes import quadratic_entry_time

if TYPE_CHECKING:
    from reachavoid_env.game_map import GameMap

_SQRT2 = math.sqrt(2.0)


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
    any_left: bool
    """``left.any()``, kept so that the env's phases do not reduce ``left`` again."""


def target_bounds(game_map: GameMap) -> tuple[float, float, float, float]:
    """Bounding box ``(xmin, xmax, ymin, ymax)`` of the target union (map units)."""
    bounds = np.array([shape.bounds() for shape in game_map.target])
    return (float(bounds[:, 0].min()), float(bounds[:, 1].max()), float(bounds[:, 2].min()),
            float(bounds[:, 3].max()))


def resolve_events(game_map: GameMap, capture_radius: float, active: np.ndarray,
                   attackers_old: np.ndarray, attackers_new: np.ndarray,
                   defenders_old: np.ndarray, defenders_new: np.ndarray,
                   bounds: tuple[float, float, float, float] | None = None) -> StepEvents:
    """Which of the ``active`` ``(M,)`` attackers are captured or arrive during one step.

    Each attacker's earliest event wins; a tie goes to capture (module docstring).
    ``bounds`` (``target_bounds(game_map)``) only saves work: two cheap filters skip the
    exact tests for pairs too far apart to meet and attackers too far from the target; a
    step in which no active attacker passes either filter (most steps) returns at once.
    """
    m = len(active)
    # Nobody moves farther than sqrt(2) times its largest coordinate change, so a pair
    # farther apart than capture_radius plus two such moves cannot meet this step.
    a_move = np.abs(attackers_new - attackers_old)
    longest = _SQRT2 * max(a_move.max(), np.abs(defenders_new - defenders_old).max())
    reach = capture_radius + 2.0 * longest
    gaps = attackers_old[:, None, :] - defenders_old[None, :, :]
    may_meet = np.einsum("ijk,ijk->ij", gaps, gaps).min(axis=1) <= reach * reach
    # Only attackers whose move spans the target's bounding box on both axes can enter it.
    centre, half = _centre_and_half(bounds or target_bounds(game_map))
    near = (np.abs(attackers_old - centre) <= half + a_move).all(axis=1)
    if not ((may_meet | near) & active).any():
        return StepEvents(np.zeros(m, dtype=bool), np.zeros(m, dtype=bool),
                          np.full(m, np.inf), np.full(m, -1), np.zeros(m, dtype=bool), False)
    never = np.full(m, np.inf)
    t_capture, t_arrival, captor = never, never, np.full(m, -1)
    if (may_meet & active).any():
        pair_times = capture_times(attackers_old, attackers_new, defenders_old, defenders_new,
                                   capture_radius)
        captor = pair_times.argmin(axis=1)
        t_capture = pair_times[np.arange(m), captor]
    near &= active
    if near.any():
        t_arrival = never.copy()
        t_arrival[near] = game_map.target_entry_time(attackers_old[near], attackers_new[near])
    captured = active & (t_capture <= 1.0) & (t_capture <= t_arrival)
    arrived = active & ~captured & (t_arrival <= 1.0)
    times = np.where(captured, t_capture, np.where(arrived, t_arrival, np.inf))
    left = captured | arrived
    return StepEvents(captured, arrived, times, np.where(captured, captor, -1), left,
                      bool(left.any()))


def resolve_batch(maps: Sequence[GameMap], map_of: np.ndarray, capture_radius: float,
                  active: np.ndarray, attackers_old: np.ndarray, attackers_new: np.ndarray,
                  defenders_old: np.ndarray, defenders_new: np.ndarray) -> StepEvents:
    """``resolve_events`` of ``K`` copies at once: arrays ``(K, M)`` / ``(K, M, 2)`` /
    ``(K, N, 2)``, copy ``k`` on map ``maps[map_of[k]]``. Each copy's events are exactly
    those ``resolve_events`` finds for it (the same arithmetic, element by element)."""
    k, m = active.shape
    pair_times = capture_times(attackers_old, attackers_new, defenders_old, defenders_new,
                               capture_radius)
    captor = pair_times.argmin(axis=2)
    t_capture = np.take_along_axis(pair_times, captor[..., None], axis=2)[..., 0]
    t_arrival = np.full((k, m), np.inf)
    a_move = np.abs(attackers_new - attackers_old)
    for index in np.unique(map_of).tolist():
        game_map = maps[index]
        xmin, xmax, ymin, ymax = target_bounds(game_map)
        centre = np.array([(xmin + xmax) / 2, (ymin + ymax) / 2])
        half = np.array([(xmax - xmin) / 2, (ymax - ymin) / 2])
        near = ((np.abs(attackers_old - centre) <= half + a_move).all(axis=2) & active
                & (map_of == index)[:, None])
        if near.any():
            t_arrival[near] = game_map.target_entry_time(attackers_old[near],
                                                         attackers_new[near])
    captured = active & (t_capture <= 1.0) & (t_capture <= t_arrival)
    arrived = active & ~captured & (t_arrival <= 1.0)
    times = np.where(captured, t_capture, np.where(arrived, t_arrival, np.inf))
    left = captured | arrived
    return StepEvents(captured, arrived, times, np.where(captured, captor, -1), left,
                      bool(left.any()))


@functools.lru_cache(maxsize=64)
def _centre_and_half(bounds: tuple[float, float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Centre and half extent ``(2,)`` of the box ``bounds`` (read-only, cached per box)."""
    xmin, xmax, ymin, ymax = bounds
    centre = np.array([(xmin + xmax) / 2, (ymin + ymax) / 2])
    half = np.array([(xmax - xmin) / 2, (ymax - ymin) / 2])
    centre.flags.writeable = half.flags.writeable = False
    return centre, half


class EventWatch:
    """Tells, cheaply, steps in which ``resolve_events`` can find no event (most steps).

    ``anchor`` takes the positions at the start of a step and measures the slack before any
    active attacker could pass either of ``resolve_events``' filters: its distance to the
    nearest defender less ``capture_radius``, over ``2 sqrt(2)`` (each of the two players
    moves at most ``sqrt(2)`` times the largest coordinate change of the steps since), and
    its distance to the target's bounding box along the farther axis. ``quiet`` spends each
    following step's largest coordinate change (any player, either axis); while the sum
    since the anchor stays under the slack, neither filter can pass, so the step has no
    event. The slack is shrunk by ``1e-9`` (relative, and absolute at the coordinates'
    scale) so that rounding can only make the watch more careful. Before the first anchor
    no step is quiet.
    """

    def __init__(self, capture_radius: float,
                 bounds: tuple[float, float, float, float]) -> None:
        self._radius = capture_radius
        self._centre, self._half = _centre_and_half(bounds)
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
        meet = (math.sqrt(np.einsum("ijk,ijk->ij", gaps, gaps).min()) - self._radius) / (
            2.0 * _SQRT2)
        enter = float((np.abs(attackers - self._centre) - self._half).max(axis=1).min())
        slack = min(meet, enter)
        scale = max(float(np.abs(attackers).max()), float(np.abs(defenders).max()), 1.0)
        self._slack = slack - 1e-9 * (abs(slack) + scale)

    def quiet(self, move: float) -> bool:
        """Spend a step whose largest coordinate change is ``move`` (map units): whether it
        certainly has no event."""
        self._spent += move
        return self._spent < self._slack


@functools.lru_cache(maxsize=16)
def no_events(m: int) -> StepEvents:
    """The events of a step in which none of ``m`` attackers left (shared, read-only)."""
    arrays = (np.zeros(m, dtype=bool), np.zeros(m, dtype=bool), np.full(m, np.inf),
              np.full(m, -1), np.zeros(m, dtype=bool))
    for array in arrays:
        array.flags.writeable = False
    return StepEvents(*arrays, False)

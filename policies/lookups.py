"""Batched tube lookups of one defender decision: two numba calls, one before the
assignment program and one after it.

``decision_tables`` reads the whole 1 vs 1 table of a step, checks the certified games
and builds the program's tables, reading the 2 vs 1 value of exactly the triples these
need; ``decision_controls`` every 1 vs 1 and 2 vs 1 defender control of the step with
its fallback heading, and the certificate slacks of the step's new games. Both evaluate
each point with the interpolation kernels' own per-point helpers
(``solvers.hj.kernels``), so they return exactly (bit for bit) what
``ValueFunction.value`` and ``defender_control`` give point by point;
``lookups_reference`` holds their pure-numpy twins, built on those calls.

A tube goes to the kernels as ``TubeArrays``: its stored rows, ``stored_of``, the grid's
kernel arrays and the defender's two axes (plain arrays, made once per policy).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from solvers.hj import ValueFunction
from solvers.hj.kernels import (
    corner_offsets,
    gradient_point,
    locate_cell,
    row_strides,
    value_at,
)

HEADING_FLOOR = 1e-9
"""A gradient no longer than this has no direction (``ValueFunction``'s floor)."""


class TubeArrays(NamedTuple):
    """What the kernels read of a tube (``ValueFunction``)."""

    rows: np.ndarray
    stored_of: np.ndarray
    shape: np.ndarray
    lo: np.ndarray
    spacing: np.ndarray
    defender_axes: np.ndarray

    @classmethod
    def of(cls, vf: ValueFunction) -> TubeArrays:
        """``vf``'s arrays (views, not copies: the tube stays memory-mapped), the axes
        those of its first defender."""
        k = vf.players.index(vf.defenders[0])
        return cls(np.asarray(vf.stored_values()), vf.stored_of, *vf.grid.kernel_arrays,
                   np.array([2 * k, 2 * k + 1], dtype=np.int64))


class _Scratch(NamedTuple):
    """A tube's arrays (``TubeArrays``), its ``(row, element)`` strides (``row_strides``)
    and corner offsets (``corner_offsets``), and scratch arrays for one point: ``lower``
    node index, corner ``weights``, ``point`` coordinates."""

    rows: np.ndarray
    stored_of: np.ndarray
    shape: np.ndarray
    lo: np.ndarray
    spacing: np.ndarray
    axes: np.ndarray
    strides: tuple
    corners: tuple
    lower: np.ndarray
    weights: np.ndarray
    point: np.ndarray


@njit(cache=True)
def _scratch(tube):
    """``_Scratch`` of ``tube`` (a ``TubeArrays``)."""
    strides = row_strides(tube.shape, tube.rows.shape[1])
    corners = corner_offsets(strides[0], strides[1])
    ndim = tube.shape.size
    return _Scratch(tube.rows, tube.stored_of, tube.shape, tube.lo, tube.spacing,
                    tube.defender_axes, strides, corners, np.empty(ndim, dtype=np.int64),
                    np.empty(1 << ndim, dtype=np.float64), np.empty(ndim, dtype=np.float64))


class DecisionTables(NamedTuple):
    """One step's tables (``decision_tables``)."""

    values11: np.ndarray
    values21: np.ndarray
    kept: np.ndarray
    left: np.ndarray
    beats: np.ndarray
    beats_2v1: np.ndarray
    active: np.ndarray
    busy: np.ndarray




@njit(cache=True)
def _fill_pairs(tube21, attackers, defenders, triples, count, values21):
    """Look up the 2 vs 1 value of the first ``count`` rows ``(i, k, j)`` of ``triples``
    (attackers ``i < k``, defender ``j``) where ``values21`` has none yet, into both of
    its orders. One call per batch: the per-point work calls the interpolation helpers
    directly (a helper per point costs as much again)."""
    sc = _scratch(tube21)
    lower, weights, point = sc.lower, sc.weights, sc.point
    for t in range(count):
        i, k, j = triples[t, 0], triples[t, 1], triples[t, 2]
        if not np.isnan(values21[i, k, j]):
            continue
        point[0], point[1] = attackers[i, 0], attackers[i, 1]
        point[2], point[3] = attackers[k, 0], attackers[k, 1]
        point[4], point[5] = defenders[j, 0], defenders[j, 1]
        row, col = locate_cell(point, sc.shape, sc.lo, sc.spacing, sc.strides[0],
                               sc.strides[1], lower, weights)
        value = value_at(sc.rows, sc.stored_of, row, col, sc.corners[0], sc.corners[1], weights)
        values21[i, k, j] = value
        values21[k, i, j] = value


@njit(cache=True)
def _decision_tables(attackers, defenders, active, certified, team_values, held, wins, tube11,
                     tube21, with_pairs):
    m, n = attackers.shape[0], defenders.shape[0]
    sc = _scratch(tube11)
    lower, weights, point = sc.lower, sc.weights, sc.point
    values11 = np.empty((m, n), dtype=np.float64)
    for i in range(m):
        for j in range(n):
            point[0], point[1] = attackers[i, 0], attackers[i, 1]
            point[2], point[3] = defenders[j, 0], defenders[j, 1]
            row, col = locate_cell(point, sc.shape, sc.lo, sc.spacing, sc.strides[0],
                                   sc.strides[1], lower, weights)
            values11[i, j] = value_at(sc.rows, sc.stored_of, row, col, sc.corners[0], sc.corners[1],
                                       weights)
    values21 = np.full((m, m, n), np.nan)
    triples = np.empty((max(certified.shape[0], m * (m - 1) // 2 * n), 3), dtype=np.int64)
    count = 0
    for g in range(certified.shape[0]):
        if certified[g, 1] < 0 and certified[g, 3] >= 0 and active[certified[g, 2]] \
                and active[certified[g, 3]]:
            triples[count, 0], triples[count, 1] = certified[g, 2], certified[g, 3]
            triples[count, 2] = certified[g, 0]
            count += 1
    _fill_pairs(tube21, attackers, defenders, triples, count, values21)
    left = np.zeros((certified.shape[0], 2), dtype=np.bool_)
    kept = np.zeros(certified.shape[0], dtype=np.bool_)
    program_active = active.copy()
    busy = np.zeros(n, dtype=np.bool_)
    for g in range(certified.shape[0]):
        d1, d2, a1, a2 = certified[g, 0], certified[g, 1], certified[g, 2], certified[g, 3]
        left[g, 0] = active[a1]
        left[g, 1] = a2 >= 0 and active[a2]
        if not (left[g, 0] or left[g, 1]):
            continue
        if d2 >= 0:
            value = team_values[g]
        else:
            value = np.inf
            for a in range(2):
                if left[g, a]:
                    value = min(value, values11[certified[g, 2 + a], d1])
            if left[g, 0] and left[g, 1]:
                value = min(value, values21[a1, a2, d1])
        if value > 0.0 or held[g]:
            kept[g] = True
            for a in range(2):
                if left[g, a]:
                    program_active[certified[g, 2 + a]] = False
            busy[d1] = True
            if d2 >= 0:
                busy[d2] = True
    beats = np.empty((m, n), dtype=np.bool_)
    for i in range(m):
        for j in range(n):
            beats[i, j] = (values11[i, j] <= 0.0 and not wins[i, j]) or busy[j]
    beats_2v1 = np.zeros((m, m, n), dtype=np.bool_)
    if not with_pairs:
        return DecisionTables(values11, values21, kept, left, beats, beats_2v1, program_active,
                              busy)
    count = 0
    for i in range(m):
        for k in range(i + 1, m):
            if program_active[i] and program_active[k]:
                for j in range(n):
                    if not (beats[i, j] or beats[k, j]):
                        triples[count, 0], triples[count, 1], triples[count, 2] = i, k, j
                        count += 1
    _fill_pairs(tube21, attackers, defenders, triples, count, values21)
    for t in range(count):
        i, k, j = triples[t, 0], triples[t, 1], triples[t, 2]
        beats_2v1[i, k, j] = beats_2v1[k, i, j] = values21[i, k, j] <= 0.0
    return DecisionTables(values11, values21, kept, left, beats, beats_2v1, program_active,
                          busy)


def decision_tables(attackers: np.ndarray, defenders: np.ndarray, active: np.ndarray,
                    certified: np.ndarray, team_values: np.ndarray, held: np.ndarray,
                    wins: np.ndarray, tube11: TubeArrays, tube21: TubeArrays | None
                    ) -> DecisionTables:
    """Everything one decision reads of the tubes before its program, in one call.

    ``values11 (M, N)``: the 1 vs 1 value of every attacker (positions ``(M, 2)``,
    ``active`` ``(M,)``) against every defender (``(N, 2)``). The last decision's
    ``certified`` games, int64 rows ``(j, k, i, l)`` (defenders ``j`` and ``k``, attackers
    ``i < l``; -1 where a game has one), ``team_values`` their 1 vs 2 values (read for
    teams only): ``left (G, 2)`` which of each game's attackers are still active, ``kept
    (G,)`` the games still on (an attacker left, and the game's value over those left
    > 0 or the game ``held`` ``(G,)`` by the open-space certificate;
    ``lookups_reference.still_winning``). The program without the kept games' players
    (``lookups_reference.restrict``): ``beats (M, N)`` (``values11 <= 0`` except where
    the open-space certificate ``wins (M, N)`` says the defender wins, every attacker
    beating a ``busy`` defender), ``active``, ``busy (N,)``, and
    ``beats_2v1 (M, M, N)``: the 2 vs 1 table where (c5) binds, the pairs of attackers
    that a defender beats one by one (false elsewhere). ``values21 (M, M, N)``: the
    2 vs 1 values read for these (state order ``i < k``, both entries filled), NaN
    elsewhere (``values21_at`` reads more). Without ``tube21`` no 2 vs 1 value is read:
    no certified game may have two attackers."""
    return _decision_tables(attackers, defenders, active, certified, team_values, held, wins,
                            tube11, tube11 if tube21 is None else tube21, tube21 is not None)


def values21_at(values21: np.ndarray, first: np.ndarray, second: np.ndarray,
                alone: np.ndarray, vf21: ValueFunction, attackers: np.ndarray,
                defenders: np.ndarray) -> np.ndarray:
    """``values21[first, second, alone]`` (index arrays, ``first < second``), the entries
    ``decision_tables`` left NaN looked up (in one batch) and stored into ``values21``."""
    values = values21[first, second, alone]
    missing = np.isnan(values)
    if missing.any():
        one, two, j = first[missing], second[missing], alone[missing]
        values[missing] = vf21.value(np.concatenate([attackers[one], attackers[two],
                                                     defenders[j]], axis=1))
        values21[one, two, j] = values[missing]
        values21[two, one, j] = values[missing]
    return values


@njit(cache=True, inline="always")
def _heading(gx, gy, fx, fy, out):
    """``(gx, gy)`` scaled to length 1, or where it is no longer than the floor the
    fallback ``(fx, fy)`` scaled to length 1 (zero where that is zero), into ``out``."""
    length = math.hypot(gx, gy)
    if length > HEADING_FLOOR:
        out[0], out[1] = gx / length, gy / length
        return
    length = math.hypot(fx, fy)
    if length > 0.0:
        out[0], out[1] = fx / length, fy / length
    else:
        out[0], out[1] = 0.0, 0.0


@njit(cache=True)
def _defender_headings(attackers, defenders, singles, doubles, tube11, tube21, actions):
    gradient = np.empty(2, dtype=np.float64)
    sc = _scratch(tube11)
    lower, weights, point = sc.lower, sc.weights, sc.point
    for s in range(singles.shape[0]):
        j, i = singles[s, 0], singles[s, 1]
        point[0], point[1] = attackers[i, 0], attackers[i, 1]
        point[2], point[3] = defenders[j, 0], defenders[j, 1]
        gradient_point(sc.rows, sc.stored_of, sc.shape, sc.lo, sc.spacing, sc.strides,
                       sc.corners, point, sc.axes, lower, weights, gradient, False)
        _heading(gradient[0], gradient[1], attackers[i, 0] - defenders[j, 0],
                 attackers[i, 1] - defenders[j, 1], actions[j])
    sc = _scratch(tube21)
    lower, weights, point = sc.lower, sc.weights, sc.point
    for d in range(doubles.shape[0]):
        j, first, second = doubles[d, 0], doubles[d, 1], doubles[d, 2]
        point[0], point[1] = attackers[first, 0], attackers[first, 1]
        point[2], point[3] = attackers[second, 0], attackers[second, 1]
        point[4], point[5] = defenders[j, 0], defenders[j, 1]
        gradient_point(sc.rows, sc.stored_of, sc.shape, sc.lo, sc.spacing, sc.strides,
                       sc.corners, point, sc.axes, lower, weights, gradient, False)
        fx, fy = attackers[first, 0] - defenders[j, 0], attackers[first, 1] - defenders[j, 1]
        sx, sy = attackers[second, 0] - defenders[j, 0], attackers[second, 1] - defenders[j, 1]
        if math.hypot(sx, sy) < math.hypot(fx, fy):
            fx, fy = sx, sy
        _heading(gradient[0], gradient[1], fx, fy, actions[j])


@njit(cache=True)
def _game_slacks(attackers, defenders, games, margins, values11, values21, tube21):
    triples = np.empty((games.shape[0], 3), dtype=np.int64)
    count = 0
    for g in range(games.shape[0]):
        if games[g, 1] < 0 and games[g, 3] >= 0:
            triples[count, 0], triples[count, 1] = games[g, 2], games[g, 3]
            triples[count, 2] = games[g, 0]
            count += 1
    _fill_pairs(tube21, attackers, defenders, triples, count, values21)
    slack = np.empty(games.shape[0], dtype=np.float64)
    for g in range(games.shape[0]):
        j, k, i, other = games[g, 0], games[g, 1], games[g, 2], games[g, 3]
        if k >= 0:
            slack[g] = np.nan
            continue
        second = i if other < 0 else other
        slack[g] = min(values11[i, j], values11[second, j]) - margins[0]
        if other >= 0:
            slack[g] = min(slack[g], values21[i, other, j] - margins[1])
    return slack


@njit(cache=True)
def _decision_controls(attackers, defenders, singles, doubles, games, margins, values11,
                       values21, tube11, tube21, actions):
    _defender_headings(attackers, defenders, singles, doubles, tube11, tube21, actions)
    return _game_slacks(attackers, defenders, games, margins, values11, values21, tube21)


def decision_controls(attackers: np.ndarray, defenders: np.ndarray, singles: np.ndarray,
                      doubles: np.ndarray, games: np.ndarray, margins: np.ndarray,
                      values11: np.ndarray, values21: np.ndarray, tube11: TubeArrays,
                      tube21: TubeArrays | None, actions: np.ndarray) -> np.ndarray:
    """Everything one decision reads of the tubes after its program, in one call.

    Writes into ``actions (N, 2)`` (float32) the optimal heading of every defender of
    ``singles`` (int64 rows ``(defender, attacker)``: its 1 vs 1 control) and ``doubles``
    (rows ``(defender, first, second)``: its 2 vs 1 control); where the control vanishes,
    the heading straight at its attacker (the nearer of the two, the first on a tie).
    Returns the certificate slack of each of ``games`` (rows as ``decision_tables``' games,
    ``policies.certificate.Tubes.slack``) with ``margins`` ``(3,)`` and the step's tables
    ``values11``, ``values21`` (its missing 2 vs 1 values looked up and stored); NaN for
    teams (the 1 vs 2 tube is not read here)."""
    return _decision_controls(attackers, defenders, singles, doubles, games, margins, values11,
                              values21, tube11, tube11 if tube21 is None else tube21, actions)

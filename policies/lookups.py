"""Batched tube lookups of one defender decision: two numba calls, one before the
assignment program and one after it.

``batch_decision_tables`` reads the whole 1 vs 1 table of a step, checks the certified
games and builds the program's tables, reading the 2 vs 1 value of exactly the triples
these need; ``batch_decision_controls`` every 1 vs 1 and 2 vs 1 defender control of the
step with its fallback heading, and the certificate slacks of the step's new games. Each
takes K copies of a game (``Ragged`` rows), one game being one copy. The
certificate's rule, what a game's value is, has its one home here: ``match_value``,
read by both over games carried as ``Matches``. Both evaluate
each point with the interpolation kernels' own per-point helpers
(``solvers.hj.kernels``), so they return exactly (bit for bit) what
``ValueFunction.value`` and ``defender_control`` give point by point;
``lookups_reference`` holds their pure-numpy twins, built on those calls.

A tube goes to the kernels as ``TubeArrays``: its stored rows, ``stored_of``, the grid's
kernel arrays and the defender's two axes (plain arrays, made once per policy).
"""

from __future__ import annotations

import itertools
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


class Matches(NamedTuple):
    """Assigned games (``policies.certificate.Match``) as the kernels read them: game ``g``
    is defenders ``defenders[g]`` against attackers ``attackers[g]`` (int64 ``(G, 2)``); a
    game of one defender (one attacker) names it in both columns, so the rule below reads
    every game alike: a team is a game whose two defenders differ, a pair one whose two
    attackers differ."""

    defenders: np.ndarray
    attackers: np.ndarray


@njit(cache=True)
def match_value(j, k, i, other, values11, values21, team_value, margins):
    """The certificate's rule: the smallest ``value - margin`` over what makes defenders
    ``j``, ``k`` win attackers ``i``, ``other`` (a ``Matches`` row). A team (``j != k``):
    its 1 vs 2 value ``team_value`` less ``margins[2]``; else the 1 vs 1 values
    ``values11[i, j]`` and ``values11[other, j]`` less ``margins[0]``, and for a pair
    (``i != other``) its 2 vs 1 value ``values21[i, other, j]`` less ``margins[1]``
    (constraints c4 and c5). ``margins (3,)`` in map units; zeros: "still winning"."""
    if j != k:
        return team_value - margins[2]
    value = min(values11[i, j], values11[other, j]) - margins[0]
    if i != other:
        value = min(value, values21[i, other, j] - margins[1])
    return value


@njit(cache=True)
def _pairs_of(games, active, tube21, attackers, defenders, values21):
    """Look up the 2 vs 1 value of every pair of ``games`` (a ``Matches``) whose two
    attackers are both ``active`` into ``values21`` (``_fill_pairs``)."""
    count = games.defenders.shape[0]
    triples = np.empty((count, 3), dtype=np.int64)
    pairs = 0
    for g in range(count):
        j, k = games.defenders[g, 0], games.defenders[g, 1]
        i, other = games.attackers[g, 0], games.attackers[g, 1]
        if j == k and i != other and active[i] and active[other]:
            triples[pairs, 0], triples[pairs, 1], triples[pairs, 2] = i, other, j
            pairs += 1
    _fill_pairs(tube21, attackers, defenders, triples, pairs, values21)


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
    _pairs_of(certified, active, tube21, attackers, defenders, values21)
    games = certified.defenders.shape[0]
    left = np.zeros((games, 2), dtype=np.bool_)
    kept = np.zeros(games, dtype=np.bool_)
    program_active = active.copy()
    busy = np.zeros(n, dtype=np.bool_)
    still = np.zeros(3, dtype=np.float64)
    for g in range(games):
        j, k = certified.defenders[g, 0], certified.defenders[g, 1]
        i, other = certified.attackers[g, 0], certified.attackers[g, 1]
        left[g, 0] = active[i]
        left[g, 1] = other != i and active[other]
        if not (left[g, 0] or left[g, 1]):
            continue
        first = i if left[g, 0] else other
        second = other if left[g, 1] else first
        value = match_value(j, k, first, second, values11, values21, team_values[g], still)
        if value > 0.0 or held[g]:
            kept[g] = True
            program_active[i] = program_active[i] and not left[g, 0]
            program_active[other] = program_active[other] and not left[g, 1]
            busy[j] = busy[k] = True
    beats = np.empty((m, n), dtype=np.bool_)
    for i in range(m):
        for j in range(n):
            beats[i, j] = (values11[i, j] <= 0.0 and not wins[i, j]) or busy[j]
    beats_2v1 = np.zeros((m, m, n), dtype=np.bool_)
    if not with_pairs:
        return DecisionTables(values11, values21, kept, left, beats, beats_2v1, program_active,
                              busy)
    triples = np.empty((m * (m - 1) // 2 * n, 3), dtype=np.int64)
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
        i, j = singles[s, 0], singles[s, 1]
        point[0], point[1] = attackers[i, 0], attackers[i, 1]
        point[2], point[3] = defenders[j, 0], defenders[j, 1]
        gradient_point(sc.rows, sc.stored_of, sc.shape, sc.lo, sc.spacing, sc.strides,
                       sc.corners, point, sc.axes, lower, weights, gradient, False)
        _heading(gradient[0], gradient[1], attackers[i, 0] - defenders[j, 0],
                 attackers[i, 1] - defenders[j, 1], actions[j])
    sc = _scratch(tube21)
    lower, weights, point = sc.lower, sc.weights, sc.point
    for d in range(doubles.shape[0]):
        first, second, j = doubles[d, 0], doubles[d, 1], doubles[d, 2]
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
def _game_slacks(attackers, defenders, games, team_values, margins, values11, values21, tube21):
    _pairs_of(games, np.ones(attackers.shape[0], dtype=np.bool_), tube21, attackers, defenders,
              values21)
    slack = np.empty(games.defenders.shape[0], dtype=np.float64)
    for g in range(slack.size):
        slack[g] = match_value(games.defenders[g, 0], games.defenders[g, 1],
                               games.attackers[g, 0], games.attackers[g, 1], values11, values21,
                               team_values[g], margins)
    return slack


@njit(cache=True)
def _decision_controls(attackers, defenders, singles, doubles, games, team_values, margins,
                       values11, values21, tube11, tube21, actions):
    _defender_headings(attackers, defenders, singles, doubles, tube11, tube21, actions)
    return _game_slacks(attackers, defenders, games, team_values, margins, values11, values21,
                        tube21)


class Ragged(NamedTuple):
    """Rows of several copies in one array: copy ``c``'s are ``rows[offsets[c]:offsets[c + 1]]``."""

    rows: np.ndarray
    offsets: np.ndarray

    @classmethod
    def of(cls, parts: list[np.ndarray]) -> Ragged:
        """``parts`` (one array per copy, at least one, of one dtype) joined on axis 0
        (one part, the common case of a game played alone, is taken as it is where it is
        a writeable C-contiguous array: the kernels only read it)."""
        offsets = np.array([0, *itertools.accumulate(map(len, parts))], dtype=np.int64)
        if len(parts) == 1 and parts[0].flags.writeable and parts[0].flags.c_contiguous:
            return cls(parts[0], offsets)
        return cls(np.concatenate(parts), offsets)


@njit(cache=True)
def _batch_tables(attackers, defenders, active, game_defenders, game_attackers, offsets,
                  team_values, held, wins, tube11, tube21, with_pairs):
    copies, m = active.shape
    n = defenders.shape[1]
    games = game_defenders.shape[0]
    values11 = np.empty((copies, m, n))
    values21 = np.empty((copies, m, m, n))
    kept = np.zeros(games, dtype=np.bool_)
    left = np.zeros((games, 2), dtype=np.bool_)
    beats = np.empty((copies, m, n), dtype=np.bool_)
    beats_2v1 = np.empty((copies, m, m, n), dtype=np.bool_)
    program_active = np.empty((copies, m), dtype=np.bool_)
    busy = np.empty((copies, n), dtype=np.bool_)
    for c in range(copies):
        lo, hi = offsets[c], offsets[c + 1]
        tables = _decision_tables(attackers[c], defenders[c], active[c],
                                  Matches(game_defenders[lo:hi], game_attackers[lo:hi]),
                                  team_values[lo:hi], held[lo:hi], wins[c], tube11, tube21,
                                  with_pairs)
        values11[c], values21[c] = tables.values11, tables.values21
        kept[lo:hi], left[lo:hi] = tables.kept, tables.left
        beats[c], beats_2v1[c] = tables.beats, tables.beats_2v1
        program_active[c], busy[c] = tables.active, tables.busy
    return DecisionTables(values11, values21, kept, left, beats, beats_2v1, program_active,
                          busy)


def batch_decision_tables(attackers: np.ndarray, defenders: np.ndarray, active: np.ndarray,
                          certified: tuple[Ragged, Ragged], team_values: np.ndarray,
                          held: np.ndarray, wins: np.ndarray, tube11: TubeArrays,
                          tube21: TubeArrays | None) -> DecisionTables:
    """Everything one decision reads of the tubes before its program, in one call for
    ``L`` copies of a game (each copy through the same kernel, as if alone).

    Positions ``(L, M, 2)`` and ``(L, N, 2)``, ``active (L, M)``. ``values11 (L, M,
    N)``: the 1 vs 1 value of every attacker against every defender. The last decision's
    ``certified`` games, as the ``Matches`` columns ``(defenders, attackers)`` ragged over
    the copies (same offsets), ``team_values`` their 1 vs 2 values (read for teams only)
    and ``held`` by the open-space certificate (ragged alike, rows only): ``left (G,
    2)`` which of each game's attackers are still active (the second: false where the
    game has one), ``kept (G,)`` the games still on (an attacker left, and
    ``match_value`` over those left, with zero margins, > 0, or the game ``held``). The
    program without the kept games' players: ``beats (L, M, N)`` (``values11 <= 0``
    except where the open-space certificate ``wins (L, M, N)`` says the defender wins,
    every attacker beating a ``busy (L, N)`` defender), ``active (L, M)``, and
    ``beats_2v1 (L, M, M, N)``: the 2 vs 1 table where (c5) binds, the pairs of
    attackers that a defender beats one by one (false elsewhere). ``values21 (L, M, M,
    N)``: the 2 vs 1 values read for these (state order ``i < k``, both entries filled),
    NaN elsewhere. Without ``tube21`` no 2 vs 1 value is read: no certified game may be
    a pair. Returns the tables with a leading copy axis, ``kept`` and ``left`` ragged as
    the games."""
    games_d, games_a = certified
    return _batch_tables(attackers, defenders, active, games_d.rows, games_a.rows,
                         games_d.offsets, team_values, held, wins, tube11,
                         tube11 if tube21 is None else tube21, tube21 is not None)


@njit(cache=True)
def _batch_controls(attackers, defenders, singles, single_offsets, doubles, double_offsets,
                    game_defenders, game_attackers, game_offsets, team_values, margins,
                    values11, values21, tube11, tube21, actions):
    slack = np.empty(game_defenders.shape[0])
    for c in range(attackers.shape[0]):
        lo, hi = game_offsets[c], game_offsets[c + 1]
        slack[lo:hi] = _decision_controls(
            attackers[c], defenders[c], singles[single_offsets[c]:single_offsets[c + 1]],
            doubles[double_offsets[c]:double_offsets[c + 1]],
            Matches(game_defenders[lo:hi], game_attackers[lo:hi]), team_values[lo:hi],
            margins, values11[c], values21[c], tube11, tube21, actions[c])
    return slack


def batch_decision_controls(attackers: np.ndarray, defenders: np.ndarray, singles: Ragged,
                            doubles: Ragged, games: tuple[Ragged, Ragged],
                            team_values: np.ndarray, margins: np.ndarray,
                            values11: np.ndarray, values21: np.ndarray, tube11: TubeArrays,
                            tube21: TubeArrays | None, actions: np.ndarray) -> np.ndarray:
    """Everything one decision reads of the tubes after its program, in one call for
    ``L`` copies (each copy through the same kernel, as if alone).

    Writes into ``actions (L, N, 2)`` (float32) the optimal heading of every defender of
    ``singles`` (int64 rows ``(attacker, defender)``: its 1 vs 1 control) and ``doubles``
    (rows ``(first, second, defender)``: its 2 vs 1 control), both ragged over the
    copies; where the control vanishes, the heading straight at its attacker (the nearer
    of the two, the first on a tie). Returns the certificate slack (``match_value``) of
    each of ``games`` (the ``Matches`` columns, ragged) with their ``team_values``
    (ragged alike), ``margins`` ``(3,)`` and the step's tables ``values11 (L, M, N)``,
    ``values21 (L, M, M, N)`` (its missing 2 vs 1 values looked up and stored), ragged
    as ``games``."""
    games_d, games_a = games
    return _batch_controls(attackers, defenders, singles.rows, singles.offsets, doubles.rows,
                           doubles.offsets, games_d.rows, games_a.rows, games_d.offsets,
                           team_values, margins, values11, values21, tube11,
                           tube11 if tube21 is None else tube21, actions)

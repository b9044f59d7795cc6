"""Pure-numpy twins of ``policies.lookups``, for the tests: the same tables and headings
from ``ValueFunction.value`` and ``defender_control`` called per batch of points and the
certificate's rule written step by step (``slack``, ``still_winning``, ``restrict``): the
defenders' computation before the batched kernels."""

from __future__ import annotations

import numpy as np

from policies import lookups
from policies.batch_defenders import BatchAssignmentDefenders
from policies.certificate import Margins, Match, Tubes
from policies.lookups import DecisionTables, Matches, Ragged, TubeArrays
from policies.tube_states import control_headings
from reachavoid_env import GameState
from solvers.hj import ValueFunction


def slack(tubes: Tubes, games: list[Match], state: GameState, values11: np.ndarray,
          margins: Margins | None = None, values21: np.ndarray | None = None) -> np.ndarray:
    """``(len(games),)``: the smallest ``value - margin`` over what makes each game a
    defender win (``margins`` default: the tubes'; zeros for "still winning"); the 2 vs 1
    values from the step's table ``values21 (M, M, N)`` where it holds them (the NaN ones
    looked up and stored), the rest in one lookup per 6D tube."""
    if not games:
        return np.empty(0)
    m11, m21, m12 = tubes.margins if margins is None else margins
    slacks = np.empty(len(games))
    pairs, teams = [], []
    for g, game in enumerate(games):
        if len(game.defenders) == 2:
            teams.append(g)
            continue
        slacks[g] = min(values11[i, game.defenders[0]] for i in game.attackers) - m11
        if len(game.attackers) == 2:
            pairs.append(g)
    attackers, defenders = state.attacker_positions, state.defender_positions
    if pairs:
        first, second, alone = np.array([(*games[g].attackers, games[g].defenders[0])
                                         for g in pairs]).T
        if values21 is None:
            values21 = np.full((len(attackers), len(attackers), len(defenders)), np.nan)
        values = _values21_at(values21, first, second, alone, tubes.vf21, attackers, defenders)
        slacks[pairs] = np.minimum(slacks[pairs], values - m21)
    if teams:
        one, two, attacker = np.array([(*games[g].defenders, games[g].attackers[0])
                                       for g in teams]).T
        slacks[teams] = tubes.vf12.value(np.concatenate([defenders[one], defenders[two],
                                                         attackers[attacker]], axis=1)) - m12
    return slacks


def _values21_at(values21: np.ndarray, first: np.ndarray, second: np.ndarray,
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


def still_winning(certified: list[Match], state: GameState, values11: np.ndarray,
                  tubes: Tubes, values21: np.ndarray | None = None,
                  held: np.ndarray | None = None) -> list[Match]:
    """The certified games of the last decision that are still on: attackers that left
    (captured) are dropped from their game, and a game stays while its value is > 0
    (``values21`` as in ``slack``) or the open-space certificate ``held`` it
    (``(G,)`` bool, one per certified game; none by default)."""
    if not certified:
        return []
    if held is None:
        held = np.zeros(len(certified), dtype=bool)
    active = state.active_attackers
    games, holds = [], []
    for game, open_ in zip(certified, held, strict=True):
        left = tuple(i for i in game.attackers if active[i])
        if left:
            games.append(Match(game.defenders, left))
            holds.append(open_)
    keep = slack(tubes, games, state, values11, Margins(0.0, 0.0, 0.0), values21) > 0.0
    return [game for game, on, open_ in zip(games, keep, holds, strict=True) if on or open_]


def restrict(beats: np.ndarray, active: np.ndarray, fixed: list[Match]
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The program without the ``fixed`` games' players: their attackers inactive, their
    defenders beaten by everyone (so they take nothing); returns ``beats``, ``active`` and
    ``busy`` (the fixed defenders, which no team may use)."""
    busy = np.zeros(beats.shape[1], dtype=bool)
    if not fixed:
        return beats, active, busy
    active = active.copy()
    active[[i for game in fixed for i in game.attackers]] = False
    busy[[j for game in fixed for j in game.defenders]] = True
    return beats | busy, active, busy


def decision_tables(state: GameState, certified: list[Match], tubes: Tubes,
                    wins: np.ndarray, held: np.ndarray | None = None) -> DecisionTables:
    """``lookups.batch_decision_tables`` of one game (``one_game_tables``) the
    step-by-step way: the 1 vs 1 table from the tube's
    ``value``, ``still_winning`` and ``restrict``, the open-space ``wins (M, N)`` counted
    as defender wins, and the 2 vs 1 value of every candidate pair of the restricted
    program in one lookup."""
    attackers, defenders = state.attacker_positions, state.defender_positions
    active = state.active_attackers
    m, n = len(attackers), len(defenders)
    states = np.concatenate([np.repeat(attackers, n, axis=0), np.tile(defenders, (m, 1))],
                            axis=1)
    values11 = tubes.vf11.value(states).reshape(m, n)
    values21 = np.full((m, m, n), np.nan)
    kept = (still_winning(certified, state, values11, tubes, values21, held) if certified
            else [])
    left = np.zeros((len(certified), 2), dtype=bool)
    on = np.zeros(len(certified), dtype=bool)
    for g, game in enumerate(certified):
        left[g, :len(game.attackers)] = active[list(game.attackers)]
        still = tuple(i for i in game.attackers if active[i])
        on[g] = Match(game.defenders, still) in kept
    beats, program_active, busy = restrict((values11 <= 0.0) & ~wins, active, kept)
    beats_2v1 = np.zeros((m, m, n), dtype=bool)
    candidates = program_active[:, None] & ~beats
    first, second = np.triu_indices(m, k=1)
    pair, j = np.nonzero(candidates[first] & candidates[second])
    if len(j) and tubes.vf21 is not None:
        one, two = first[pair], second[pair]
        values = tubes.vf21.value(np.concatenate([attackers[one], attackers[two],
                                                  defenders[j]], axis=1))
        values21[one, two, j] = values21[two, one, j] = values
        beats_2v1[one, two, j] = beats_2v1[two, one, j] = values <= 0.0
    return DecisionTables(values11, values21, on, left, beats, beats_2v1, program_active,
                          busy)


def decision_controls(attackers: np.ndarray, defenders: np.ndarray, singles: np.ndarray,
                      doubles: np.ndarray, games: Matches, team_values: np.ndarray,
                      margins: np.ndarray, values11: np.ndarray, values21: np.ndarray,
                      vf11: ValueFunction, vf21: ValueFunction | None,
                      actions: np.ndarray) -> np.ndarray:
    """``lookups.batch_decision_controls`` of one game (``one_game_controls``) from the
    tubes' ``defender_control`` and ``value``."""
    _defendercontrol_headings(attackers, defenders, singles, doubles, vf11, vf21, actions)
    slacks = np.empty(len(games.defenders))
    for g, ((j, k), (i, other)) in enumerate(zip(games.defenders, games.attackers,
                                                 strict=True)):
        if j != k:
            slacks[g] = team_values[g] - margins[2]
            continue
        slacks[g] = np.minimum(values11[i, j], values11[other, j]) - margins[0]
        if other != i:
            value = values21[i, other, j]
            if np.isnan(value):
                value = vf21.value(np.concatenate([attackers[i], attackers[other],
                                                   defenders[j]]))
                values21[i, other, j] = values21[other, i, j] = value
            slacks[g] = np.minimum(slacks[g], value - margins[1])
    return slacks


def _defendercontrol_headings(attackers: np.ndarray, defenders: np.ndarray, singles: np.ndarray,
                       doubles: np.ndarray, vf11: ValueFunction, vf21: ValueFunction | None,
                       actions: np.ndarray) -> None:
    if len(singles):
        i, j = singles.T
        controls = vf11.defender_control(np.concatenate([attackers[i], defenders[j]], axis=1))
        actions[j] = control_headings(controls, attackers[i] - defenders[j])
    if len(doubles):
        first, second, j = doubles.T
        states = np.concatenate([attackers[first], attackers[second], defenders[j]], axis=1)
        controls = vf21.defender_control(states)
        gaps = np.stack([attackers[first] - defenders[j], attackers[second] - defenders[j]])
        nearer = gaps[np.argmin(np.hypot(gaps[..., 0], gaps[..., 1]), axis=0),
                      np.arange(len(j))]
        actions[j] = control_headings(controls, nearer)


def assert_same_tables(ours: DecisionTables, theirs: DecisionTables) -> None:
    """Every table of ``ours`` equals ``theirs`` bit for bit: dtype, shape and values (NaN
    where NaN)."""
    for name, mine, expected in zip(ours._fields, ours, theirs, strict=True):
        assert mine.dtype == expected.dtype and mine.shape == expected.shape, name
        assert np.array_equal(mine, expected, equal_nan=True), name


def one_game_tables(attackers: np.ndarray, defenders: np.ndarray, active: np.ndarray,
                    certified: Matches, team_values: np.ndarray, held: np.ndarray,
                    wins: np.ndarray, tube11: TubeArrays,
                    tube21: TubeArrays | None) -> DecisionTables:
    """``lookups.batch_decision_tables`` of one game (one copy), without the copy axis."""
    tables = lookups.batch_decision_tables(
        attackers[None], defenders[None], active[None],
        (Ragged.of([certified.defenders]), Ragged.of([certified.attackers])), team_values,
        held, wins[None], tube11, tube21)
    return DecisionTables(*(table if name in ("kept", "left") else table[0]
                            for name, table in zip(DecisionTables._fields, tables,
                                                   strict=True)))


def one_game_controls(attackers: np.ndarray, defenders: np.ndarray, singles: np.ndarray,
                      doubles: np.ndarray, games: Matches, team_values: np.ndarray,
                      margins: np.ndarray, values11: np.ndarray, values21: np.ndarray,
                      tube11: TubeArrays, tube21: TubeArrays | None,
                      actions: np.ndarray) -> np.ndarray:
    """``lookups.batch_decision_controls`` of one game (one copy): ``values21 (M, M, N)``
    and ``actions (N, 2)`` written in place."""
    return lookups.batch_decision_controls(
        attackers[None], defenders[None], Ragged.of([singles]), Ragged.of([doubles]),
        (Ragged.of([games.defenders]), Ragged.of([games.attackers])), team_values, margins,
        values11[None], values21[None], tube11, tube21, actions[None])


class StepByStepDefenders(BatchAssignmentDefenders):
    """The engine with each copy's tables made step by step (``decision_tables``)."""

    def _tables(self, game, certified, held, wins):
        tables = [decision_tables(game.state(c), certified[c], self.tubes, wins[c], held[c])
                  for c in range(len(certified))]
        return DecisionTables(*(
            np.concatenate(columns) if name in ("kept", "left") else np.stack(columns)
            for name, columns in zip(DecisionTables._fields, zip(*tables, strict=True),
                                     strict=True)))


def step_by_step_controls(vf11: ValueFunction, vf21: ValueFunction | None):
    """A stand-in for ``lookups.batch_decision_controls`` that plays each copy through
    ``decision_controls`` (the tubes' own calls)."""
    def controls(attackers, defenders, singles, doubles, games, team_values, margins,
                 values11, values21, tube11, tube21, actions):
        game_defenders, game_attackers = games
        slacks = []
        for c in range(len(attackers)):
            rows = [slice(*ragged.offsets[c:c + 2]) for ragged in (singles, doubles,
                                                                   game_defenders)]
            slacks.append(decision_controls(
                attackers[c], defenders[c], singles.rows[rows[0]], doubles.rows[rows[1]],
                Matches(game_defenders.rows[rows[2]], game_attackers.rows[rows[2]]),
                team_values[rows[2]], margins, values11[c], values21[c], vf11, vf21,
                actions[c]))
        return np.concatenate(slacks)
    return controls

"""The certificate of the assignment defenders: which assigned games are guaranteed wins.

A tube's value is a numerical solution: near the decision boundary its sign can be wrong
(tube error), and along a played trajectory it drifts. A game of the assignment becomes
*certified* when its value clears the tube's margin (``margin`` per tube, above the
measured error), and stays certified while its value is > 0 (hysteresis: a game taken
with a clear margin is not given up for drifting into the band). The defenders keep
every certified game (their players are taken out of the next program and ``joined``
puts the game back), so the certified count falls only when a game's value reaches 0.
The check and the restriction run inside the batched lookups
(``policies.lookups.decision_tables``; their step-by-step numpy twins are in
``tests/lookups_reference.py``); ``game_rows`` and ``kept_games`` carry the games there
and back.

A game's value is what the program reads: ``V11`` for one defender against one attacker;
the smallest of ``V21`` and both ``V11`` for one defender against a pair (constraints c4
and c5); ``V12`` for a team of two defenders against one attacker.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from policies.lookups import values21_at
from reachavoid_env import GameState
from solvers.assignment import Assignment
from solvers.hj import ValueFunction


@dataclass(frozen=True)
class Game:
    """One assigned game: ``defenders`` (one, or a team ``j < k``) against ``attackers``
    (one, or a pair ``i < k`` taken by one defender), as indices."""

    defenders: tuple[int, ...]
    attackers: tuple[int, ...]


def games_of(assignment: Assignment) -> list[Game]:
    """The games of ``assignment``: every defender's own attackers, then every team."""
    alone = [Game((j,), mine) for j, mine in enumerate(assignment.by_defender) if mine]
    return alone + [Game((j, k), (i,)) for i, j, k in assignment.shared]


class Margins(NamedTuple):
    """The margin each tube's value must clear to certify a game (map units)."""

    m11: float
    m21: float
    m12: float


@dataclass(frozen=True)
class Tubes:
    """The tubes a game's value is read from (``vf21`` / ``vf12`` ``None`` where the policy
    plays no such game) and the margin each must clear (map units)."""

    vf11: ValueFunction
    vf21: ValueFunction | None
    vf12: ValueFunction | None
    margins: Margins

    def slack(self, games: list[Game], state: GameState, values11: np.ndarray,
              margins: Margins | None = None,
              values21: np.ndarray | None = None) -> np.ndarray:
        """``(len(games),)``: the smallest ``value - margin`` over what makes each game a
        defender win (``margins`` default: the tubes'; zeros for "still winning"); the
        2 vs 1 values from the step's table ``values21 (M, M, N)`` where it holds them
        (``policies.lookups.decision_tables``; the NaN ones looked up and stored), the rest
        in one lookup per 6D tube."""
        if not games:
            return np.empty(0)
        m11, m21, m12 = self.margins if margins is None else margins
        slack = np.empty(len(games))
        pairs, teams = [], []
        for g, game in enumerate(games):
            if len(game.defenders) == 2:
                teams.append(g)
                continue
            slack[g] = min(values11[i, game.defenders[0]] for i in game.attackers) - m11
            if len(game.attackers) == 2:
                pairs.append(g)
        attackers, defenders = state.attacker_positions, state.defender_positions
        if pairs:
            first, second, alone = np.array([(*games[g].attackers, games[g].defenders[0])
                                             for g in pairs]).T
            if values21 is None:
                values21 = np.full((len(attackers), len(attackers), len(defenders)), np.nan)
            values = values21_at(values21, first, second, alone, self.vf21, attackers,
                                 defenders)
            slack[pairs] = np.minimum(slack[pairs], values - m21)
        if teams:
            one, two, attacker = np.array([(*games[g].defenders, games[g].attackers[0])
                                           for g in teams]).T
            slack[teams] = self.vf12.value(np.concatenate([defenders[one], defenders[two],
                                                           attackers[attacker]], axis=1)) - m12
        return slack


@functools.cache
def no_team_values(games: int) -> np.ndarray:
    """The team values (``policies.lookups.decision_tables``) of ``games`` certified
    games none of which is a team: read for none (read-only)."""
    values = np.full(games, np.nan)
    values.setflags(write=False)
    return values


@functools.lru_cache(maxsize=1024)
def game_rows(games: tuple[Game, ...]) -> tuple[np.ndarray, np.ndarray]:
    """``games`` as ``policies.lookups.decision_tables`` takes them: int64 rows
    ``(j, k, i, l)``, -1 for a second defender or attacker a game does not have; and the
    positions of the teams (made once per distinct list, read-only)."""
    rows = np.full((len(games), 4), -1, dtype=np.int64)
    for g, game in enumerate(games):
        rows[g, :len(game.defenders)] = game.defenders
        rows[g, 2:2 + len(game.attackers)] = game.attackers
    teams = np.flatnonzero(rows[:, 1] >= 0)
    rows.setflags(write=False)
    teams.setflags(write=False)
    return rows, teams


def kept_games(certified: list[Game], kept: np.ndarray, left: np.ndarray) -> list[Game]:
    """The ``certified`` games still on (``kept`` and ``left`` from
    ``policies.lookups.decision_tables``), without the attackers that left."""
    games = []
    for game, on, present in zip(certified, kept.tolist(), left.tolist(), strict=True):
        here = present[:len(game.attackers)]
        if on:
            games.append(game if all(here) else Game(game.defenders, tuple(
                i for i, stays in zip(game.attackers, here, strict=True) if stays)))
    return games


def joined(rest: Assignment, fixed: list[Game], num_defenders: int) -> Assignment:
    """``rest`` (an answer of the restricted program) with the ``fixed`` games put back."""
    pairs = list(rest.pairs) + [(i, game.defenders[0]) for game in fixed
                                if len(game.defenders) == 1 for i in game.attackers]
    teams = list(rest.shared) + [(game.attackers[0], *game.defenders) for game in fixed
                                 if len(game.defenders) == 2]
    return Assignment.from_pairs(pairs, num_defenders, teams)

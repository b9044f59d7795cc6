"""The states at which the defenders read their tubes, the heading a vanished control
falls back to, and the teams' 1 vs 2 controls.

Index pairs here, as everywhere in the defenders, are ``(attacker, defender)``: the axes
``(M, N)`` of the step's tables (``solvers.assignment`` states the order).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from policies.certificate import no_team_values
from policies.lookups import Matches
from reachavoid_env import GameState
from reachavoid_env.rules import unit_vectors
from solvers.hj import ValueFunction


def pair_states(attackers: np.ndarray, defenders: np.ndarray) -> np.ndarray:
    """1 vs 1 states ``(M, N, 4)``: every attacker against every defender, axes
    ``(xA, yA, xD, yD)``."""
    states = np.empty((len(attackers), len(defenders), 4))
    states[..., :2] = attackers[:, None, :]
    states[..., 2:] = defenders[None, :, :]
    return states


def triple_states(attackers: np.ndarray, pairs: np.ndarray, defenders: np.ndarray) -> np.ndarray:
    """2 vs 1 states ``(P, N, 6)`` for attacker index pairs ``(P, 2)`` against every defender,
    axes ``(xA1, yA1, xA2, yA2, xD, yD)``."""
    p, n = len(pairs), len(defenders)
    first = np.broadcast_to(attackers[pairs[:, 0]][:, None, :], (p, n, 2))
    second = np.broadcast_to(attackers[pairs[:, 1]][:, None, :], (p, n, 2))
    return np.concatenate([first, second, np.broadcast_to(defenders[None], (p, n, 2))], axis=-1)


def team_states(attackers: np.ndarray, defenders: np.ndarray, teams: np.ndarray) -> np.ndarray:
    """1 vs 2 states ``(T, 6)`` for ``teams (T, 3)`` rows ``(attacker, j, k)``: defenders
    ``j`` and ``k`` against the attacker, axes ``(xD1, yD1, xD2, yD2, xA, yA)``."""
    return np.concatenate([defenders[teams[:, 1]], defenders[teams[:, 2]],
                           attackers[teams[:, 0]]], axis=1)


def control_headings(controls: np.ndarray, fallbacks: np.ndarray) -> np.ndarray:
    """``controls (K, 2)`` where non-zero, else the unit vectors along ``fallbacks``."""
    still = ~controls.any(axis=1)
    controls = controls.astype(np.float32)
    if still.any():
        controls[still] = unit_vectors(fallbacks[still])
    return controls


def team_values(vf12: ValueFunction | None, state: GameState, games: Matches) -> np.ndarray:
    """``(G,)``: the 1 vs 2 value of every team of ``games`` (two defenders), NaN for the
    other games (read-only where there is no team; without a 1 vs 2 tube, none is)."""
    if vf12 is None:
        return no_team_values(len(games.defenders))
    teams = np.flatnonzero(games.defenders[:, 0] != games.defenders[:, 1])
    if not len(teams):
        return no_team_values(len(games.defenders))
    values = np.full(len(games.defenders), np.nan)
    values[teams] = vf12.value(team_states(
        state.attacker_positions, state.defender_positions,
        np.column_stack([games.attackers[teams, 0], games.defenders[teams]])))
    return values


def play_teams(vf12: ValueFunction | None, teams: Sequence[tuple[int, int, int]],
               attackers: np.ndarray, defenders: np.ndarray, actions: np.ndarray) -> None:
    """Both defenders of every team ``(attacker, defender 1, defender 2)`` of one copy play
    the 1 vs 2 optimal controls: written into ``actions`` ``(N, 2)`` (headings, fractions
    of the defenders' speed); nothing without teams."""
    if not teams:
        return
    shared = np.array(teams)
    states = team_states(attackers, defenders, shared)
    for column, player in ((1, "D1"), (2, "D2")):
        j = shared[:, column]
        actions[j] = control_headings(vf12.control(states, player),
                                      attackers[shared[:, 0]] - defenders[j])

"""Observations of the game: the one code path of ``ReachAvoidEnv`` and of policies that
act on observations (a trained network as a ``Policy``, ``policies.learned``).

Every agent observes ``Box(-1, 1, (2 + 3 (M + N),), float32)``, positions normalised to
the domain (``-1`` at ``xmin``/``ymin``, ``+1`` at ``xmax``/``ymax``)::

    [own x, own y,
     attacker_0 x, attacker_0 y, attacker_0 active, ..., (every attacker)
     defender_0 x, defender_0 y, defender_0 active, ...] (every defender)

``active`` is 1.0 for a player still in the game (an attacker neither captured nor
arrived; a defender while some attacker is active), else 0.0.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from reachavoid_env.game_map import GameMap
from reachavoid_env.game_state import GameState


class Normaliser(NamedTuple):
    """The affine map from map units to ``[-1, 1]`` per axis: ``(p - centre) / half``."""

    centre: np.ndarray   # (2,) map units
    half: np.ndarray     # (2,) half the domain's extent per axis, map units

    @classmethod
    def of(cls, game_map: GameMap) -> Normaliser:
        xmin, xmax, ymin, ymax = game_map.domain
        return cls(np.array([(xmin + xmax) / 2, (ymin + ymax) / 2]),
                   np.array([(xmax - xmin) / 2, (ymax - ymin) / 2]))


def player_table(positions: np.ndarray, active: np.ndarray,
                 normaliser: Normaliser) -> np.ndarray:
    """``(P, 3)`` float32: every player's normalised x, y (clipped to ``[-1, 1]``) and
    active flag.

    Args:
        positions: ``(P, 2)`` map units, attackers then defenders.
        active: ``(P,)`` bool.
        normaliser: the domain's ``Normaliser``.
    """
    table = np.empty((len(positions), 3), dtype=np.float32)
    normalised = (positions - normaliser.centre) / normaliser.half
    table[:, :2] = np.minimum(np.maximum(normalised, -1.0, out=normalised), 1.0,
                              out=normalised)
    table[:, 2] = active
    return table


def agent_rows(table: np.ndarray, rows: slice | list[int]) -> np.ndarray:
    """``(L, 2 + table.size)`` float32: the observations of the players ``rows`` of
    ``table`` (``player_table``), one fresh array."""
    own = table[rows, :2]
    observations = np.empty((len(own), 2 + table.size), dtype=np.float32)
    observations[:, :2] = own
    observations[:, 2:] = table.reshape(-1)
    return observations


def observe(state: GameState, game_map: GameMap) -> dict[str, np.ndarray]:
    """Every player's observation of ``state`` on ``game_map``, keyed by agent name
    (``attacker_0..M-1``, ``defender_0..N-1``): what ``ReachAvoidEnv`` returns for the
    same state, bit for bit."""
    attackers = state.active_attackers
    active = np.concatenate([attackers, np.full(len(state.defender_positions),
                                                attackers.any())])
    positions = np.concatenate([state.attacker_positions, state.defender_positions])
    table = player_table(positions, active, Normaliser.of(game_map))
    names = state.attacker_names + state.defender_names
    return dict(zip(names, agent_rows(table, slice(None)), strict=True))

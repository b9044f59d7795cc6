"""Scripted and solver-backed defender policies.

Each follows ``policies.base.Policy``: ``reset(scenario)`` then ``act(state)``, which
returns a float32 ``(2,)`` action in ``[-1, 1]`` (a velocity as a fraction of the
defender's speed) for every defender.
"""

from __future__ import annotations

import numpy as np

from reachavoid_env import GameState, Overlay, Scenario


class IdleDefender:
    """Every defender stands still."""

    def reset(self, scenario: Scenario) -> None:
        """Nothing to prepare: the defender names come with each state."""

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        return {name: np.zeros(2, dtype=np.float32) for name in state.defender_names}


class GreedyDefender:
    """Every defender runs at full speed straight at the nearest active attacker.

    Defenders stand still once no attacker is left. ``overlay()`` shows each defender's
    current quarry as an edge.
    """

    def __init__(self) -> None:
        self._edges: tuple[tuple[str, str], ...] = ()

    def reset(self, scenario: Scenario) -> None:
        self._edges = ()

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        active = np.flatnonzero(state.active_attackers)
        names = state.defender_names
        if len(active) == 0:
            self._edges = ()
            return {name: np.zeros(2, dtype=np.float32) for name in names}
        gaps = state.attacker_positions[active][None, :, :] - state.defender_positions[:, None, :]
        distances = np.linalg.norm(gaps, axis=-1)
        nearest = np.argmin(distances, axis=1)
        rows = np.arange(len(names))
        chase, length = gaps[rows, nearest], distances[rows, nearest][:, None]
        actions = np.divide(chase, length, out=np.zeros_like(chase), where=length > 0)
        self._edges = tuple((name, f"attacker_{active[k]}") for name, k in zip(names, nearest,
                                                                                 strict=True))
        return {name: actions[j].astype(np.float32) for j, name in enumerate(names)}

    def overlay(self) -> Overlay:
        return Overlay(edges=self._edges)

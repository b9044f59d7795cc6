"""Numpy twins of the defenders' one implementations, as they were written before the
batched and the single forms were merged (issue 52): the tests hold the merged code to
them bit for bit."""

from __future__ import annotations

import numpy as np

from reachavoid_env import GameState, Overlay, Scenario


class ReferenceGreedyDefender:
    """The single-game greedy defenders of before ``policies.greedy``: every defender runs
    at full speed straight at the nearest active attacker; ``overlay()`` the quarries."""

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
        self._edges = tuple((name, f"attacker_{active[k]}")
                            for name, k in zip(names, nearest, strict=True))
        return {name: actions[j].astype(np.float32) for j, name in enumerate(names)}

    def overlay(self) -> Overlay:
        return Overlay(edges=self._edges)

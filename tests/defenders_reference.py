"""Numpy twins of the defenders' one implementations, as they were written before the
batched and the single forms were merged (issue 52): the tests hold the merged code to
them bit for bit."""

from __future__ import annotations

import numpy as np

from policies.intercept import Plan, Races
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


def reference_plan(race: Races, free: np.ndarray, open_: np.ndarray) -> Plan:
    """``policies.intercept.plan_intercepts`` as numpy (one game, ``(M, N)`` races), as it
    was written before the plan became one numba kernel (``plan_copies``)."""
    n = len(free)
    targets = np.full(n, -1, dtype=np.int64)
    aims = np.zeros((n, 2))
    left = free.copy()
    order = [int(i) for i in np.argsort(race.threat, kind="stable") if open_[i]]
    if not order:
        return Plan(targets, aims)
    for i in order:
        able = np.flatnonzero(left & race.wins[i])
        if len(able):
            j = int(able[np.argmin(race.times[i, able])])
            targets[j], aims[j], left[j] = i, race.aims[i, j], False
    for j in np.flatnonzero(left):
        able = [i for i in order if race.wins[i, j]]
        i = min(able, key=lambda i: race.times[i, j]) if able else order[0]
        targets[j], aims[j] = i, race.aims[i, j]
    return Plan(targets, aims)

"""The greedy defenders: every defender runs at full speed straight at the nearest active
attacker (the first of equals), and stands still once none is left.

``BatchGreedyDefenders`` is the one implementation, a ``reachavoid_env.BatchPolicy`` on K
copies in numpy (registry name ``greedy``, batched); ``GreedyDefender`` is it played as
one ``Policy`` (``reachavoid_env.Single``, copy 0).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from reachavoid_env import BatchState, Overlay, Scenario
from reachavoid_env.game_state import AttackerStatus
from reachavoid_env.policy import Single, checked_copies

ACTIVE = AttackerStatus.ACTIVE.code


class BatchGreedyDefenders:
    """Greedy defenders on K copies (module docstring). ``overlay(copy)`` shows each of
    copy ``copy``'s defenders' current quarry as an edge (none before its first step or
    once no attacker is left)."""

    def __init__(self) -> None:
        self._targets = np.zeros((0, 0), dtype=np.int64)   # (K, N) quarry, -1 for none

    def reset_copies(self, copies: np.ndarray, scenarios: Sequence[Scenario]) -> None:
        """Forget the quarries of ``copies`` (greedy defenders keep no other state)."""
        copies = checked_copies(copies, scenarios)
        self._targets[copies[copies < len(self._targets)]] = -1

    def act_batch(self, states: BatchState) -> np.ndarray:
        """Unit headings ``(K, N, 2)`` float32 at each defender's nearest active attacker
        (map units in, fractions of the defender's speed out); zeros in a copy without
        active attackers."""
        attackers = np.asarray(states.attacker_positions, dtype=np.float64)
        defenders = np.asarray(states.defender_positions, dtype=np.float64)
        active = np.asarray(states.attacker_status) == ACTIVE
        gaps = attackers[:, None, :, :] - defenders[:, :, None, :]              # (K, N, M, 2)
        distances = np.linalg.norm(gaps, axis=-1)
        nearest = np.argmin(np.where(active[:, None, :], distances, np.inf), axis=2)
        k, j = np.indices(nearest.shape)
        chase, length = gaps[k, j, nearest], distances[k, j, nearest][..., None]
        actions = np.divide(chase, length, out=np.zeros_like(chase), where=length > 0)
        idle = ~active.any(axis=1)
        actions[idle] = 0.0
        nearest[idle] = -1
        self._targets = nearest
        return actions.astype(np.float32)

    def overlay(self, copy: int) -> Overlay:
        """Copy ``copy``'s edges ``(defender, quarry)`` of the last step."""
        targets = self._targets[copy].tolist() if copy < len(self._targets) else []
        return Overlay(edges=tuple((f"defender_{j}", f"attacker_{i}")
                                   for j, i in enumerate(targets) if i >= 0))


class GreedyDefender(Single):
    """Greedy defenders in one game (module docstring): ``BatchGreedyDefenders`` at one
    copy. ``overlay()`` shows each defender's current quarry as an edge."""

    def __init__(self) -> None:
        super().__init__(BatchGreedyDefenders())

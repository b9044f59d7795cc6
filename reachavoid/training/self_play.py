"""Self-play with the learner's own past policies: teammates played by frozen snapshots.

``PastSelves`` is a ``reachavoid_env.BatchPolicy`` for the attackers of K copies. It holds
a pool of snapshots (``add``: functions from observations ``(B, D)`` to actions ``(B, 2)``,
as ``model.predict`` gives them; the oldest leaves when ``pool`` are held). At each reset
a copy draws one snapshot from the pool, uniformly, and every attacker of that copy plays
it for the whole episode on its own observation (``reachavoid_env.observations.Observer``
with the learner's layout ``observation``), deciding every ``action_repeat`` env steps
and holding the action in between, as ``policies.learned.ObservationPolicy`` does. In
``reachavoid.training.views.make_attacker_vector_env`` (``teammates=``) the learner's own rows
are its own: one attacker per copy learns, its teammates are past selves.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence

import numpy as np

from policies.learned import DEFAULT_OBSERVATION, Predict
from reachavoid_env import BatchState, ObservationConfig, Scenario, checks
from reachavoid_env.observations import Observer
from reachavoid_env.policy import checked_copies, map_key
from reachavoid_env.rules import unit_vectors

MAX_POOL = 10_000
"""The most snapshots a pool holds."""


class PastSelves:
    """Attackers played by snapshots drawn from a pool (module docstring).

    Args:
        observation: the snapshots' observation layout.
        pool: snapshots held, at least 1 (the newest ``pool`` of those added).
        action_repeat: env steps each decision is held for.
        full_speed: scale every action to length 1 (as ``--full-speed`` trained them);
            else clip to ``[-1, 1]``.
        seed: the generator of the draws.
    """

    def __init__(self, observation: ObservationConfig = DEFAULT_OBSERVATION, pool: int = 8,
                 action_repeat: int = 1, full_speed: bool = False,
                 seed: int | None = None) -> None:
        self.observation = observation
        self.snapshots: deque[Predict] = deque(maxlen=checks.integer(pool, "pool", 1, MAX_POOL))
        self.action_repeat = checks.integer(action_repeat, "action_repeat", 1, 1_000_000)
        self.full_speed = bool(full_speed)
        self._rng = np.random.default_rng(seed)
        self._observers: dict[Scenario, Observer] = {}
        self._copy_observer: list[Observer | None] = []
        self._copy_snapshot: list[Predict | None] = []
        self._held = np.zeros((0, 0, 2), dtype=np.float32)
        self._fresh = np.zeros(0, dtype=bool)

    def add(self, predict: Predict) -> None:
        """Put a snapshot in the pool; copies draw it from their next reset on."""
        self.snapshots.append(predict)

    def reset_copies(self, copies: np.ndarray, scenarios: Sequence[Scenario]) -> None:
        copies = checked_copies(copies, scenarios)
        if not self.snapshots:
            raise RuntimeError("PastSelves: add a snapshot before the first reset")
        if len(copies) and copies.max() >= len(self._fresh):
            grow = copies.max() + 1 - len(self._fresh)
            self._copy_observer += [None] * grow
            self._copy_snapshot += [None] * grow
            self._fresh = np.concatenate([self._fresh, np.zeros(grow, dtype=bool)])
        draws = self._rng.integers(len(self.snapshots), size=len(copies))
        for copy, scenario, draw in zip(copies.tolist(), scenarios, draws.tolist(), strict=True):
            key = map_key(scenario)
            if key not in self._observers:
                self._observers[key] = Observer(
                    self.observation, scenario.map, scenario.num_attackers,
                    scenario.num_defenders, max(scenario.attacker_speed,
                                                scenario.defender_speed), scenario.max_steps)
            self._copy_observer[copy] = self._observers[key]
            self._copy_snapshot[copy] = self.snapshots[draw]
        self._fresh[copies] = True

    def act_batch(self, states: BatchState) -> np.ndarray:
        """``(K, M, 2)`` float32: each copy's attackers by its snapshot."""
        k, m = states.attacker_positions.shape[:2]
        if self._held.shape[:2] != (k, m):
            self._held = np.zeros((k, m, 2), dtype=np.float32)
        deciding = np.flatnonzero(self._fresh[:k] | (states.step % self.action_repeat == 0))
        self._fresh[deciding] = False
        groups: dict[tuple[int, int], list[int]] = {}
        for copy in deciding.tolist():
            observer, snapshot = self._copy_observer[copy], self._copy_snapshot[copy]
            if observer is None or snapshot is None:
                raise RuntimeError("PastSelves.act_batch: copy without reset_copies")
            groups.setdefault((id(observer), id(snapshot)), []).append(copy)
        for members in groups.values():
            rows = np.asarray(members)
            observer, snapshot = self._copy_observer[members[0]], self._copy_snapshot[members[0]]
            self._held[rows] = self._decide(observer, snapshot, states, rows)
        return self._held.copy()

    def _decide(self, observer: Observer, snapshot: Predict, states: BatchState,
                rows: np.ndarray) -> np.ndarray:
        """The attackers' actions ``(len(rows), M, 2)`` in copies ``rows``."""
        attackers = states.attacker_status[rows] == 0
        positions = np.concatenate([states.attacker_positions[rows],
                                    states.defender_positions[rows]], axis=1)
        n = states.defender_positions.shape[1]
        active = np.concatenate([attackers, np.repeat(attackers.any(axis=1, keepdims=True),
                                                      n, axis=1)], axis=1)
        velocities = (states.velocities[rows] if states.velocities is not None
                      else np.zeros_like(positions))
        table = observer(positions, velocities, active, states.step[rows])
        m = attackers.shape[1]
        batch = table[:, :m].reshape(len(rows) * m, -1)
        actions = np.asarray(snapshot(batch), dtype=np.float64).reshape(len(rows) * m, 2)
        actions = unit_vectors(actions) if self.full_speed else np.clip(actions, -1.0, 1.0)
        return actions.reshape(len(rows), m, 2).astype(np.float32)

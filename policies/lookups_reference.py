"""Pure-numpy twins of ``lookups``, for tests: the same tables and headings from
``ValueFunction.value`` and ``defender_control`` called per batch of points (the defenders'
step-by-step computation before the batched kernels)."""

from __future__ import annotations

import numpy as np

from reachavoid_env.rules import unit_vectors
from solvers.hj import ValueFunction


def step_values(attackers: np.ndarray, defenders: np.ndarray, active: np.ndarray,
                settled: np.ndarray, vf11: ValueFunction, vf21: ValueFunction | None
                ) -> tuple[np.ndarray, np.ndarray]:
    """``lookups.step_values`` from the tubes' ``value``."""
    m, n = len(attackers), len(defenders)
    states = np.concatenate([np.repeat(attackers, n, axis=0), np.tile(defenders, (m, 1))],
                            axis=1)
    values11 = vf11.value(states).reshape(m, n)
    values21 = np.full((m, m, n), np.nan)
    if vf21 is None:
        return values11, values21
    first, second = np.triu_indices(m, k=1)
    loses = active[:, None] & (values11 > 0.0) & ~settled
    pair, j = np.nonzero(loses[first] & loses[second])
    if len(j):
        one, two = first[pair], second[pair]
        values = vf21.value(np.concatenate([attackers[one], attackers[two], defenders[j]],
                                           axis=1))
        values21[one, two, j] = values
        values21[two, one, j] = values
    return values11, values21


def _headings(controls: np.ndarray, fallbacks: np.ndarray) -> np.ndarray:
    still = ~controls.any(axis=1)
    controls = controls.astype(np.float32)
    if still.any():
        controls[still] = unit_vectors(fallbacks[still])
    return controls


def defender_headings(attackers: np.ndarray, defenders: np.ndarray, singles: np.ndarray,
                      doubles: np.ndarray, vf11: ValueFunction, vf21: ValueFunction | None,
                      actions: np.ndarray) -> None:
    """``lookups.defender_headings`` from the tubes' ``defender_control``."""
    if len(singles):
        j, i = singles.T
        controls = vf11.defender_control(np.concatenate([attackers[i], defenders[j]], axis=1))
        actions[j] = _headings(controls, attackers[i] - defenders[j])
    if len(doubles):
        j, first, second = doubles.T
        states = np.concatenate([attackers[first], attackers[second], defenders[j]], axis=1)
        controls = vf21.defender_control(states)
        gaps = np.stack([attackers[first] - defenders[j], attackers[second] - defenders[j]])
        nearer = gaps[np.argmin(np.hypot(gaps[..., 0], gaps[..., 1]), axis=0),
                      np.arange(len(j))]
        actions[j] = _headings(controls, nearer)

"""Slow pure-numpy twins of ``kernels``, written from the formulas, for tests.

They work on whole arrays of the game's full shape ``(xA1, yA1[, xA2, yA2], xD, yD)`` in
float64 and materialise everything; use them on small grids only.
"""

from __future__ import annotations

import itertools

import numpy as np


def _one_sided(values: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """Raw forward and backward differences along ``axis`` with a zero-gradient edge."""
    padded = np.concatenate([values.take([0], axis=axis), values,
                             values.take([-1], axis=axis)], axis=axis)
    n = values.shape[axis]
    ahead = padded.take(np.arange(2, n + 2), axis=axis)
    behind = padded.take(np.arange(0, n), axis=axis)
    return ahead - values, values - behind


def hamiltonian(values: np.ndarray, spacing: tuple[float, ...], speeds: tuple[float, float],
                scheme: str) -> tuple[np.ndarray, np.ndarray]:
    """Numerical Hamiltonian and the largest neighbour jump at every node.

    Players are the consecutive axis pairs; all but the last pair are attackers (minimise,
    speed ``speeds[0]``), the last pair is the defender (maximises, ``speeds[1]``).
    """
    values = values.astype(np.float64)
    ndim = values.ndim
    ham = np.zeros_like(values)
    jump = np.zeros_like(values)
    for player in range(ndim // 2):
        defender = player == ndim // 2 - 1
        speed = speeds[1] if defender else speeds[0]
        norm2 = np.zeros_like(values)
        diss = np.zeros_like(values)
        for axis in (2 * player, 2 * player + 1):
            forward, backward = _one_sided(values, axis)
            jump = np.maximum(jump, np.maximum(np.abs(forward), np.abs(backward)))
            dp, dm = forward / spacing[axis], backward / spacing[axis]
            if scheme == "godunov":
                if defender:
                    q = np.maximum(np.maximum(dp, -dm), 0.0)
                else:
                    q = np.maximum(np.maximum(-dp, dm), 0.0)
                norm2 += q**2
            else:
                norm2 += ((dp + dm) / 2) ** 2
                diss += (dp - dm) / 2
        sign = 1.0 if defender else -1.0
        ham += speed * (sign * np.sqrt(norm2) + diss)
    return ham, jump


def game_sets(target: np.ndarray, attacker_free: np.ndarray, defender_free: np.ndarray,
              attacker_points: np.ndarray, defender_points: np.ndarray, capture_radius: float,
              survive: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Full target ``l`` and avoid ``g`` arrays of the 1 vs 1 (``survive is None``) or
    2 vs 1 game from the planar tables.

    ``target``, ``attacker_free``: ``(nxA, nyA)``; ``defender_free``: ``(nxD, nyD)``;
    ``attacker_points`` ``(nxA, nyA, 2)`` and ``defender_points`` ``(nxD, nyD, 2)``: node
    coordinates; ``survive``: ``(nxA, nyA, nxD, nyD)``.
    """
    nx, ny = target.shape
    dx, dy = defender_free.shape
    a = attacker_points.reshape(nx, ny, 1, 1, 2).astype(np.float64)
    d = defender_points.reshape(1, 1, dx, dy, 2).astype(np.float64)
    gap = capture_radius - np.linalg.norm(a - d, axis=-1)
    reach = np.maximum(target[:, :, None, None], gap)
    lost = np.maximum(gap, -attacker_free[:, :, None, None].astype(np.float64))
    if survive is None:
        return np.minimum(reach, defender_free), lost

    def first(table: np.ndarray) -> np.ndarray:
        return table.reshape(nx, ny, 1, 1, dx, dy)

    def second(table: np.ndarray) -> np.ndarray:
        return table.reshape(1, 1, nx, ny, dx, dy)

    target_set = np.minimum(np.minimum(first(reach), second(reach)), defender_free)
    avoid = np.maximum(np.minimum(first(lost), second(survive)),
                       np.minimum(second(lost), first(survive)))
    return target_set, avoid


def sweep(values: np.ndarray, spacing: tuple[float, ...], speeds: tuple[float, float],
          dt: float, scheme: str, target: np.ndarray,
          avoid: np.ndarray) -> tuple[np.ndarray, float]:
    """One update ``max(min(V + dt H, l), g)`` and the largest change near the zero level set."""
    ham, jump = hamiltonian(values, spacing, speeds, scheme)
    new = np.maximum(np.minimum(values + dt * ham, target), avoid)
    near = np.abs(values) <= jump
    change = np.abs(new - values)
    residual = float(change[near].max()) if near.any() else 0.0
    return new, residual


def interpolate(values: np.ndarray, lo: np.ndarray, spacing: np.ndarray,
                points: np.ndarray) -> np.ndarray:
    """Multilinear interpolation, clamped into the grid."""
    shape = np.asarray(values.shape)
    s = np.clip((points - lo) / spacing, 0, shape - 1)
    lower = np.minimum(np.floor(s).astype(int), shape - 2)
    frac = s - lower
    total = np.zeros(len(points))
    for corner in itertools.product((0, 1), repeat=values.ndim):
        c = np.asarray(corner)
        weight = np.prod(np.where(c == 1, frac, 1 - frac), axis=1)
        total += weight * values[tuple((lower + c).T)]
    return total


def nodal_gradient(values: np.ndarray, spacing: np.ndarray) -> np.ndarray:
    """Central differences inside, one-sided on the edges: ``values.shape + (ndim,)``."""
    return np.stack([np.gradient(values.astype(np.float64), spacing[k], axis=k, edge_order=1)
                     for k in range(values.ndim)], axis=-1)


def interpolate_gradient(values: np.ndarray, lo: np.ndarray, spacing: np.ndarray,
                         points: np.ndarray) -> np.ndarray:
    """The nodal gradient interpolated multilinearly."""
    nodal = nodal_gradient(values, spacing)
    return np.stack([interpolate(nodal[..., k], lo, spacing, points)
                     for k in range(values.ndim)], axis=-1)

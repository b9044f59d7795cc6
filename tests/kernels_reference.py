"""Slow pure-numpy twins of ``solvers.hj.kernels`` and of the generated iteration
(``solvers/hj/iteration.py``), written from the formulas, for the tests; ``paper_sets``
writes out the paper's sets by hand to check the games' declarations (``games.py``).

They work on whole arrays of a game's full shape (each player's ``x``, ``y`` axes in
order) in float64 and materialise everything; use them on small grids only.
"""

from __future__ import annotations

import itertools

import numpy as np


def _differences(values: np.ndarray, axis: int, width: int) -> list[np.ndarray]:
    """Raw forward differences ``u[i+k+1] - u[i+k]`` for ``k = -width..width-1`` at every
    node, with a zero-gradient edge ``width`` nodes deep."""
    pad = [(0, 0)] * values.ndim
    pad[axis] = (width, width)
    padded = np.pad(values, pad, mode="edge")
    n = values.shape[axis]
    forward = np.diff(padded, axis=axis)
    return [forward.take(np.arange(k + width, k + width + n), axis=axis)
            for k in range(-width, width)]


def _minmod(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.where(a * b > 0, np.sign(a) * np.minimum(np.abs(a), np.abs(b)), 0.0)


def hamiltonian(values: np.ndarray, spacing: tuple[float, ...],
                players: list[tuple[float, bool]], scheme: str) -> tuple[np.ndarray, np.ndarray]:
    """Numerical Hamiltonian and the largest neighbour jump at every node.

    Players are the consecutive axis pairs, ``(speed, maximise)`` each (a defender
    maximises, an attacker minimises).
    """
    values = values.astype(np.float64)
    ham = np.zeros_like(values)
    jump = np.zeros_like(values)
    for player, (speed, maximise) in enumerate(players):
        sign = 1.0 if maximise else -1.0
        norm2 = np.zeros_like(values)
        diss = np.zeros_like(values)
        for axis in (2 * player, 2 * player + 1):
            h = spacing[axis]
            if scheme == "eno2":
                f_mm, f_m, f_p, f_pp = _differences(values, axis, 2)
                centre = f_p - f_m
                plus = (f_p - 0.5 * _minmod(centre, f_pp - f_p)) / h
                minus = (f_m + 0.5 * _minmod(centre, f_m - f_mm)) / h
            else:
                f_m, f_p = _differences(values, axis, 1)
                plus, minus = f_p / h, f_m / h
            jump = np.maximum(jump, np.maximum(np.abs(f_p), np.abs(f_m)))
            if scheme == "lax_friedrichs":
                norm2 += ((plus + minus) / 2) ** 2
                diss += (plus - minus) / 2
            else:
                q = np.maximum(np.maximum(sign * plus, -sign * minus), 0.0)
                norm2 += q**2
        ham += speed * (sign * np.sqrt(norm2) + diss)
    return ham, jump


def paper_sets(target: np.ndarray, attacker_free: np.ndarray, defender_free: np.ndarray,
               attacker_points: np.ndarray, defender_points: np.ndarray, capture_radius: float,
               survive: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """The paper's target ``l`` and avoid ``g`` of 1 vs 1 (``survive is None``) or 2 vs 1,
    written out by hand from eqs. (RA_11), (RA_21), (L) (checks the declarations).

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


def iterate(values: np.ndarray, spacing: tuple[float, ...], players: list[tuple[float, bool]],
          dt: float, scheme: str, target: np.ndarray,
          avoid: np.ndarray) -> tuple[np.ndarray, float]:
    """One update ``max(min(V + dt H, l), g)`` and the largest change near the zero level set."""
    ham, jump = hamiltonian(values, spacing, players, scheme)
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

"""The lidar's casting kernel (numba): every ray from every origin against every segment
and circle of a scene (``lidar.Lidar`` holds the arrays; ``tests/lidar_reference.py`` is
the numpy twin). Its own module so that numba loads only when a lidar casts."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from reachavoid_env.jit_cache import check_numba_config

check_numba_config()   # numba loads pickled code: only from a folder of ours

@njit(cache=True)
def cast(origins: np.ndarray, directions: np.ndarray, segments: np.ndarray,
         inverse: np.ndarray, circles: np.ndarray, max_range: float,
         out: np.ndarray) -> None:  # pragma: no cover - compiled
    """Fill ``out`` ``(Q, R)`` with the first hit along each ray, at most ``max_range``.

    Args:
        origins: ``(Q, 2)`` map units.
        directions: ``(R, 2)`` unit vectors.
        segments: ``(S, 4)`` ``x0, y0, x1, y1``.
        inverse: ``(R, S)`` ``1 / cross(direction, x1 - x0)``, 0 for parallel pairs.
        circles: ``(C, 3)`` ``cx, cy, radius``.
        max_range: map units.
        out: ``(Q, R)``, written.
    """
    for q in range(origins.shape[0]):
        px, py = origins[q, 0], origins[q, 1]
        for r in range(directions.shape[0]):
            dx, dy = directions[r, 0], directions[r, 1]
            best = max_range
            for s in range(segments.shape[0]):
                inv = inverse[r, s]
                if inv == 0.0:
                    continue
                wx, wy = segments[s, 0] - px, segments[s, 1] - py
                ex, ey = segments[s, 2] - segments[s, 0], segments[s, 3] - segments[s, 1]
                t = (wx * ey - wy * ex) * inv
                if t < 0.0 or t >= best:
                    continue
                u = (wx * dy - wy * dx) * inv
                if 0.0 <= u <= 1.0:
                    best = t
            for c in range(circles.shape[0]):
                ox, oy = px - circles[c, 0], py - circles[c, 1]
                b = ox * dx + oy * dy
                disc = b * b - (ox * ox + oy * oy - circles[c, 2] * circles[c, 2])
                if disc < 0.0:
                    continue
                root = math.sqrt(disc)
                t = -b - root
                if t < 0.0:
                    t = -b + root
                if 0.0 <= t < best:
                    best = t
            out[q, r] = best


@njit(cache=True)
def egocentric(positions: np.ndarray, velocities: np.ndarray, active: np.ndarray,
               time_left: np.ndarray, target_offsets: np.ndarray,
               target_distances: np.ndarray, others: np.ndarray, centre: np.ndarray,
               half: np.ndarray, diagonal: float, fastest: float, with_velocities: bool,
               with_time: bool, directions: np.ndarray, segments: np.ndarray,
               inverse: np.ndarray, circles: np.ndarray, lidar_range: float,
               out: np.ndarray) -> None:  # pragma: no cover - compiled
    """Fill ``out`` ``(K, P, D)`` float32 with the egocentric observations
    (``observations`` module docstring), every entry clipped to ``[-1, 1]``.

    Args:
        positions, velocities: ``(K, P, 2)`` map units, map units per second.
        active: ``(K, P)`` bool.
        time_left: ``(K,)`` fraction of the episode left.
        target_offsets: ``(K, P, 2)`` the target's nearest point minus the position.
        target_distances: ``(K, P)`` signed distance to the target, map units.
        others: ``(P, P - 1)`` the teammates then opponents of each player.
        centre, half: ``(2,)`` the domain's normaliser, map units.
        diagonal, fastest, lidar_range: the units of offsets, velocities and rays.
        directions, segments, inverse, circles: the lidar (``cast``); ``R = 0``: none.
    """
    rays = directions.shape[0]
    row = np.empty(out.shape[2])
    hits = np.empty((1, rays))
    for k in range(positions.shape[0]):
        for i in range(positions.shape[1]):
            px, py = positions[k, i, 0], positions[k, i, 1]
            row[0] = (px - centre[0]) / half[0]
            row[1] = (py - centre[1]) / half[1]
            n = 2
            if with_velocities:
                row[2] = velocities[k, i, 0] / fastest
                row[3] = velocities[k, i, 1] / fastest
                n = 4
            row[n] = target_offsets[k, i, 0] / diagonal
            row[n + 1] = target_offsets[k, i, 1] / diagonal
            row[n + 2] = target_distances[k, i] / diagonal
            n += 3
            if rays:
                cast(positions[k, i:i + 1], directions, segments, inverse, circles,
                     lidar_range, hits)
                for r in range(rays):
                    row[n + r] = hits[0, r] / lidar_range
                n += rays
            for o in range(others.shape[1]):
                j = others[i, o]
                row[n] = (positions[k, j, 0] - px) / diagonal
                row[n + 1] = (positions[k, j, 1] - py) / diagonal
                n += 2
                if with_velocities:
                    row[n] = velocities[k, j, 0] / fastest
                    row[n + 1] = velocities[k, j, 1] / fastest
                    n += 2
                row[n] = 1.0 if active[k, j] else 0.0
                n += 1
            if with_time:
                row[n] = time_left[k]
            for e in range(out.shape[2]):
                out[k, i, e] = min(max(row[e], -1.0), 1.0)

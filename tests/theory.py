"""Open-map certificates of who wins a 1 vs 1 game (simple motion, ``vD > vA``)."""

from __future__ import annotations

import numpy as np


def segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from points ``p`` to the segments ``a``-``b`` (all ``(K, 2)``)."""
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, -1) / np.maximum(np.sum(ab * ab, -1), 1e-12), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)


def disc_target_margins(a: np.ndarray, d: np.ndarray, target_radius: float,
                        speeds: tuple[float, float], capture_radius: float
                        ) -> tuple[np.ndarray, np.ndarray]:
    """For attackers ``a`` and defenders ``d`` ``(K, 2)`` and a disc target at the origin:

    - ``slack`` (seconds): the best, over 128 target points, of the defender's time to come
      within the capture radius of the attacker's straight path minus the attacker's time
      along it; > 0: the attacker wins;
    - ``miss`` (map units): how far the Apollonius disc (capture radius 0) misses the
      target; > 0: the defender wins.
    """
    va, vd = speeds
    angles = np.linspace(0.0, 2 * np.pi, 128, endpoint=False)
    slack = np.full(len(a), -np.inf)
    for z in target_radius * np.stack([np.cos(angles), np.sin(angles)], axis=1):
        z = np.broadcast_to(z, a.shape)
        slack = np.maximum(slack, (segment_distance(d, a, z) - capture_radius) / vd
                           - np.linalg.norm(a - z, axis=1) / va)
    k = va / vd
    centre = (a - k * k * d) / (1 - k * k)
    apollonius = k * np.linalg.norm(a - d, axis=1) / (1 - k * k)
    return slack, np.linalg.norm(centre, axis=1) - apollonius - target_radius

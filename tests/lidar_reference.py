"""The numpy twin of the lidar's numba kernel (``reachavoid_env.lidar_kernel.cast``): the
same exact intersections, every origin, ray and shape at once."""

from __future__ import annotations

import numpy as np

from reachavoid_env.lidar import Lidar


def cast(lidar: Lidar, origins: np.ndarray) -> np.ndarray:
    """``(..., R)`` first hits along ``lidar``'s rays from ``origins`` ``(..., 2)``."""
    p = np.asarray(origins, dtype=np.float64)
    d = lidar.directions
    segments, circles = lidar.scene.segments, lidar.scene.circles
    a, e = segments[:, :2], segments[:, 2:] - segments[:, :2]
    denominators = d[:, :1] * e[:, 1] - d[:, 1:] * e[:, 0]                      # (R, S)
    with np.errstate(divide="ignore", invalid="ignore"):
        inverse = np.where(denominators != 0.0, 1.0 / denominators, np.nan)
        w = a - p[..., None, :]                                                 # (..., S, 2)
        t = (w[..., 0] * e[:, 1] - w[..., 1] * e[:, 0])[..., None, :] * inverse
        u = (w[..., None, :, 0] * d[:, 1:] - w[..., None, :, 1] * d[:, :1]) * inverse
        hits = np.where((t >= 0.0) & (u >= 0.0) & (u <= 1.0), t, np.inf)
    nearest = hits.min(axis=-1, initial=lidar.max_range)
    if len(circles):
        offsets = p[..., None, :] - circles[:, :2]                               # (..., C, 2)
        b = np.einsum("...ck,rk->...rc", offsets, d)
        c = np.einsum("...ck,...ck->...c", offsets, offsets) - circles[:, 2] ** 2
        discriminant = b * b - c[..., None, :]
        root = np.sqrt(np.maximum(discriminant, 0.0))
        t = np.where(-b - root >= 0.0, -b - root, -b + root)
        t = np.where((discriminant >= 0.0) & (t >= 0.0), t, np.inf)
        nearest = np.minimum(nearest, t.min(axis=-1))
    return nearest

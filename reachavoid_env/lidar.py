"""Lidar: exact distances along rays to the walls and obstacles of a map.

A map's solid geometry, as the rays see it, is a ``RayScene``: straight segments (the
domain's four sides and every edge of a box or polygon) and circles. ``Lidar`` casts
``rays`` rays from each of many origins at the fixed world angles ``2 pi r / rays``
(``r = 0..rays-1``, counter-clockwise from ``+x``) and returns the distance to the first
segment or circle each ray meets, capped at ``max_range`` (map units). The ray-segment and
ray-circle intersections are exact (closed forms), computed for every origin, ray and
shape at once in numpy; what depends on the rays and shapes alone is computed once.

A new shape kind, to be seen by the lidar, registers its ``ray_geometry`` here (as it
registers ``world.static_shapes`` to be solid).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from reachavoid_env.game_map import GameMap
from reachavoid_env.shapes import Box, Circle, Polygon, Shape


class RayScene(NamedTuple):
    """What rays can hit: ``segments`` ``(S, 4)`` as ``x0, y0, x1, y1`` and ``circles``
    ``(C, 3)`` as ``cx, cy, radius`` (map units)."""

    segments: np.ndarray
    circles: np.ndarray

    @classmethod
    def of(cls, game_map: GameMap) -> RayScene:
        """The domain's sides and every obstacle of ``game_map``."""
        xmin, xmax, ymin, ymax = game_map.domain
        corners = np.array([(xmin, ymin), (xmax, ymin), (xmax, ymax), (xmin, ymax)])
        parts = [ring_segments(corners)]
        circles = []
        for obstacle in game_map.obstacles:
            segments, discs = ray_geometry(obstacle)
            parts.append(segments)
            circles.append(discs)
        return cls(np.concatenate(parts), np.concatenate(circles) if circles
                   else np.zeros((0, 3)))


def ring_segments(vertices: np.ndarray) -> np.ndarray:
    """The edges ``(V, 4)`` of the closed ring ``vertices`` ``(V, 2)``."""
    return np.concatenate([vertices, np.roll(vertices, -1, axis=0)], axis=1)


@functools.singledispatch
def ray_geometry(shape: Shape) -> tuple[np.ndarray, np.ndarray]:
    """The segments ``(S, 4)`` and circles ``(C, 3)`` of an obstacle ``shape``."""
    raise TypeError(f"no lidar geometry for {type(shape).__name__} shapes")


@ray_geometry.register(Box)
@ray_geometry.register(Polygon)
def _(shape: Box | Polygon) -> tuple[np.ndarray, np.ndarray]:
    vertices = np.asarray(shape.outline() if isinstance(shape, Box) else shape.vertices,
                          dtype=np.float64)
    return ring_segments(vertices), np.zeros((0, 3))


@ray_geometry.register
def _(shape: Circle) -> tuple[np.ndarray, np.ndarray]:
    return np.zeros((0, 4)), np.array([[*shape.center, shape.radius]], dtype=np.float64)


class Lidar:
    """``rays`` rays at fixed world angles over one ``RayScene``, capped at ``max_range``.

    The casting kernel is numba's (compiled on the first lidar made in a process, cached
    like the solvers' kernels); ``tests/lidar_reference.py`` is its numpy twin.
    """

    def __init__(self, scene: RayScene, rays: int, max_range: float) -> None:
        self.max_range = float(max_range)
        angles = 2.0 * np.pi * np.arange(rays) / rays
        self.directions = np.stack([np.cos(angles), np.sin(angles)], axis=1)    # (R, 2)
        self.scene = scene
        d, e = self.directions, scene.segments[:, 2:] - scene.segments[:, :2]
        denominators = d[:, :1] * e[:, 1] - d[:, 1:] * e[:, 0]                  # (R, S)
        with np.errstate(divide="ignore"):
            self._inverse = np.where(denominators != 0.0, 1.0 / denominators, 0.0)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
        """The kernel's arguments: directions, segments, inverse, circles, max_range."""
        return (self.directions, self.scene.segments, self._inverse, self.scene.circles,
                self.max_range)

    def __call__(self, origins: np.ndarray) -> np.ndarray:
        """Distances along every ray from every origin.

        Args:
            origins: ``(..., 2)`` map units.

        Returns:
            ``(..., R)`` map units: the distance to the first segment or circle the ray
            meets, ``max_range`` where it meets none nearer.
        """
        from reachavoid_env.lidar_kernel import cast

        p = np.ascontiguousarray(origins, dtype=np.float64)
        flat = p.reshape(-1, 2)
        out = np.empty((len(flat), len(self.directions)))
        cast(flat, *self.arrays(), out)
        return out.reshape(*p.shape[:-1], len(self.directions))

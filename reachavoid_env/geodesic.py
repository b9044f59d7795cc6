"""Geodesic distance-to-target fields: the shortest way to the target around obstacles.

``distance_field(game_map, clearance)`` solves the eikonal equation ``|grad T| = 1`` on a
grid over the map's domain by second-order fast marching (scikit-fmm), with ``T = 0`` on
the target's boundary. Obstacles grown by ``clearance`` (map units; the player radius, so
that the paths are ones a player's disc can follow) and a band of that width inside the
domain's walls are impassable. ``T`` is in map units: the length of the shortest path to
the target (negative inside the target: minus the distance to its boundary), so the time
to the target at speed ``v`` is ``T / v``. Fields are cached per map in memory.

The grid values inside obstacles (and in free pockets with no way to the target) are
extrapolated linearly, ring by ring, from the free side, so that the bilinear gradient
in the cells that straddle an obstacle's edge is the free side's gradient.
``DistanceField.descent`` adds the rule for the walls: near an obstacle the part of the
direction pointing into it is removed, so players slide along walls and round corners.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import skfmm

from reachavoid_env.game_map import GameMap
from reachavoid_env.rules import unit_vectors
from reachavoid_env.scenario import ScenarioError

DEFAULT_CELLS = 256
"""Grid cells along the longer side of the domain (the paper map: spacing 2/256)."""

_PROBES = np.stack([np.cos(np.linspace(0, 2 * np.pi, 32, endpoint=False)),
                    np.sin(np.linspace(0, 2 * np.pi, 32, endpoint=False))], axis=-1)


@dataclass(frozen=True, eq=False)
class DistanceField:
    """Geodesic distance to a map's target on a grid, with bilinear interpolation.

    ``xs`` ``(nx,)`` and ``ys`` ``(ny,)`` are the node coordinates (both ends of the
    domain included), ``values`` ``(nx, ny)`` the distances (map units, ``ij`` order),
    ``reachable`` ``(nx, ny)`` the free nodes that have a path to the target.
    Points outside the domain are clamped to it.
    """

    game_map: GameMap
    clearance: float
    xs: np.ndarray
    ys: np.ndarray
    values: np.ndarray
    reachable: np.ndarray

    @property
    def spacing(self) -> tuple[float, float]:
        """Node spacing ``(hx, hy)``, map units."""
        return (float(self.xs[1] - self.xs[0]), float(self.ys[1] - self.ys[0]))

    def _corners(self, points: np.ndarray) -> tuple[np.ndarray, ...]:
        p = np.asarray(points, dtype=np.float64)
        if p.shape[-1:] != (2,):
            raise ValueError(f"points: expected shape (..., 2), got {p.shape}")
        hx, hy = self.spacing
        u = (p[..., 0] - self.xs[0]) / hx
        w = (p[..., 1] - self.ys[0]) / hy
        i = np.clip(np.floor(u).astype(np.int64), 0, len(self.xs) - 2)
        j = np.clip(np.floor(w).astype(np.int64), 0, len(self.ys) - 2)
        tx, ty = np.clip(u - i, 0.0, 1.0), np.clip(w - j, 0.0, 1.0)
        v = self.values
        return tx, ty, v[i, j], v[i + 1, j], v[i, j + 1], v[i + 1, j + 1]

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Shortest-path length to the target ``(...,)`` at ``points`` ``(..., 2)``."""
        tx, ty, v00, v10, v01, v11 = self._corners(points)
        return (v00 * (1 - tx) * (1 - ty) + v10 * tx * (1 - ty)
                + v01 * (1 - tx) * ty + v11 * tx * ty)

    def gradient(self, points: np.ndarray) -> np.ndarray:
        """Gradient ``(..., 2)`` of the bilinear interpolant (about unit length)."""
        tx, ty, v00, v10, v01, v11 = self._corners(points)
        hx, hy = self.spacing
        return np.stack([((v10 - v00) * (1 - ty) + (v11 - v01) * ty) / hx,
                         ((v01 - v00) * (1 - tx) + (v11 - v10) * tx) / hy], axis=-1)

    def descent(self, points: np.ndarray) -> np.ndarray:
        """Unit headings ``(K, 2)`` down the field at ``points`` ``(K, 2)``, never into walls.

        The heading is ``-gradient``. Within two cells of the grown obstacles (or the
        domain's walls) its part pointing into them is removed, so a player slides along
        a wall and round its corners. Where that leaves (almost) nothing, on the ridge
        behind an obstacle or where the field is flat, the heading is the one of 32
        directions, not into a wall, whose point one cell ahead has the smallest distance.
        """
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        step = min(self.spacing)
        heading = unit_vectors(-self.gradient(p))
        gap, normal = _clearance_and_normal(self.game_map, p, step)
        near = gap < self.clearance + 2 * step
        inward = np.minimum(np.einsum("kd,kd->k", heading, normal), 0.0) * near
        heading -= inward[:, None] * normal
        length = np.linalg.norm(heading, axis=-1)
        for k in np.flatnonzero(length < 0.2):
            allowed = _PROBES @ normal[k] >= 0.0 if near[k] else np.ones(len(_PROBES), bool)
            ahead = self.distance(p[k] + step * _PROBES[allowed])
            heading[k] = _PROBES[allowed][np.argmin(ahead)]
            length[k] = 1.0
        return heading / length[:, None]


def _clearance_and_normal(game_map: GameMap, points: np.ndarray,
                          step: float) -> tuple[np.ndarray, np.ndarray]:
    """Distance to obstacles / walls ``(K,)`` and its unit gradient ``(K, 2)`` (outward)."""
    eps = 1e-4 * step
    offsets = np.array([[0.0, 0.0], [eps, 0.0], [-eps, 0.0], [0.0, eps], [0.0, -eps]])
    sd = game_map.obstacle_signed_distance(points[:, None, :] + offsets[None])
    normal = np.stack([sd[:, 1] - sd[:, 2], sd[:, 3] - sd[:, 4]], axis=-1)
    return sd[:, 0], unit_vectors(normal)


def _fill_unknown(values: np.ndarray, known: np.ndarray) -> np.ndarray:
    """``values`` extended, ring by ring, from the known nodes into the unknown ones.

    A node next to a known node ``a`` along a grid axis gets the linear extrapolation
    ``2 T(a) - T(b)`` (``b`` the node beyond ``a``) or, where ``b`` is unknown, ``T(a)``;
    the mean over the directions that offer one, linear ones first.
    """
    nx, ny = values.shape
    padded = np.zeros((nx + 4, ny + 4))
    is_known = np.zeros((nx + 4, ny + 4), dtype=bool)
    padded[2:-2, 2:-2] = np.where(known, values, 0.0)
    is_known[2:-2, 2:-2] = known
    inner_values, inner_known = padded[2:-2, 2:-2], is_known[2:-2, 2:-2]

    def at(array: np.ndarray, dx: int, dy: int) -> np.ndarray:
        return array[2 + dx:nx + 2 + dx, 2 + dy:ny + 2 + dy]

    while not inner_known.all():
        linear, linear_count = np.zeros((nx, ny)), np.zeros((nx, ny))
        flat, flat_count = np.zeros((nx, ny)), np.zeros((nx, ny))
        for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            a, a_known = at(padded, dx, dy), at(is_known, dx, dy)
            b_known = a_known & at(is_known, 2 * dx, 2 * dy)
            linear += np.where(b_known, 2 * a - at(padded, 2 * dx, 2 * dy), 0.0)
            linear_count += b_known
            flat += np.where(a_known, a, 0.0)
            flat_count += a_known
        ring = ~inner_known & (flat_count > 0)
        inner_values[ring] = np.where(linear_count > 0, linear / np.maximum(linear_count, 1),
                                      flat / np.maximum(flat_count, 1))[ring]
        inner_known |= ring
    return inner_values.copy()


@functools.lru_cache(maxsize=32)
def distance_field(game_map: GameMap, clearance: float = 0.0,
                   cells: int = DEFAULT_CELLS) -> DistanceField:
    """The geodesic distance-to-target field of ``game_map`` (cached per arguments).

    ``clearance``: how far (map units) paths keep from obstacles and the domain's walls,
    normally the player radius. ``cells``: grid cells along the longer side of the domain.
    """
    grid = _grid(game_map, clearance, cells)
    phi = game_map.target_signed_distance(grid.nodes)
    if not np.any(grid.free & (phi <= 0)):
        raise ScenarioError(f"map.target: no free grid node lies in the target (clearance "
                         f"{clearance:g}, spacing {grid.size:.3g}); use more cells")
    if np.all(phi[grid.free] <= 0):
        raise ValueError("map: the free space lies inside the target; nothing to reach")
    return _solved(game_map, clearance, grid, phi)


def distance_to(game_map: GameMap, clearance: float, goal: np.ndarray,
                cells: int = DEFAULT_CELLS // 2) -> DistanceField | None:
    """The geodesic distance field to the point ``goal`` ``(2,)`` (a disc of one and a half
    cells around it) instead of the target, as ``distance_field`` makes it; ``None``
    where no free grid node lies in that disc (a goal in a grown obstacle)."""
    grid = _grid(game_map, clearance, cells)
    phi = np.hypot(grid.nodes[..., 0] - goal[0], grid.nodes[..., 1] - goal[1]) - 1.5 * grid.size
    if not np.any(grid.free & (phi <= 0)) or np.all(phi[grid.free] <= 0):
        return None
    return _solved(game_map, clearance, grid, phi)


class _Grid(NamedTuple):
    """A field's nodes ``xs``, ``ys``, ``nodes (nx, ny, 2)``, the ``free`` ones and the
    cell ``size`` asked for (map units)."""

    xs: np.ndarray
    ys: np.ndarray
    nodes: np.ndarray
    free: np.ndarray
    size: float


@functools.lru_cache(maxsize=8)
def _grid(game_map: GameMap, clearance: float, cells: int) -> _Grid:
    """The nodes of a field with ``cells`` cells along the longer side of the domain, free
    ``clearance`` from obstacles and walls (cached: ``distance_to`` asks again and again)."""
    if clearance < 0:
        raise ValueError(f"clearance: must be >= 0 map units, got {clearance}")
    if cells < 8:
        raise ValueError(f"cells: need at least 8 grid cells, got {cells}")
    xmin, xmax, ymin, ymax = game_map.domain
    size = max(xmax - xmin, ymax - ymin) / cells
    xs = np.linspace(xmin, xmax, int(np.ceil((xmax - xmin) / size - 1e-9)) + 1)
    ys = np.linspace(ymin, ymax, int(np.ceil((ymax - ymin) / size - 1e-9)) + 1)
    nodes = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1)
    free = game_map.obstacle_signed_distance(nodes) > clearance
    for array in (xs, ys, nodes, free):
        array.setflags(write=False)
    return _Grid(xs, ys, nodes, free, size)


def _solved(game_map: GameMap, clearance: float, grid: _Grid, phi: np.ndarray) -> DistanceField:
    """The field of zero level set ``phi`` over the grid's free nodes, by fast marching,
    filled in elsewhere (``_fill_unknown``)."""
    xs, ys, free = grid.xs, grid.ys, grid.free
    solved = skfmm.distance(np.ma.MaskedArray(phi, mask=~free),
                            dx=[float(xs[1] - xs[0]), float(ys[1] - ys[0])], order=2)
    reachable = ~np.ma.getmaskarray(solved)
    values = _fill_unknown(np.ma.getdata(solved).astype(np.float64), reachable)
    for array in (values, reachable):
        array.setflags(write=False)
    return DistanceField(game_map, float(clearance), xs, ys, values, reachable)

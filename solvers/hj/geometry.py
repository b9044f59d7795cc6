"""The map's target and obstacles sampled on a player's planar grid.

Distances are exact Euclidean signed distances from the map's shapes (``GameMap``), in map
units, float32, indexed ``[ix, iy]`` of the player's 2-D grid.

Domain edge: the grid's outermost nodes lie on the domain's edge, where players slide along
the wall in the game. The exterior of the domain is therefore measured against the domain
grown by half a cell on every side: every grid node is free of the "outside" obstacle (edge
nodes sit half a cell inside it), so a player on the wall is never read as being in an
obstacle, while the zero-gradient boundary of the solver keeps everyone inside the domain.
Real obstacles use their exact signed distance.
"""

from __future__ import annotations

import numpy as np

from reachavoid_env import Box, GameMap
from solvers.hj.grid import Grid


def _planar(grid: Grid) -> np.ndarray:
    if grid.ndim != 2:
        raise ValueError(f"expected a planar (2-D) player grid, got {grid.ndim} axes")
    return grid.mesh()


def target_distance(game_map: GameMap, grid: Grid) -> np.ndarray:
    """Signed distance to the target union on ``grid`` (negative inside), ``(nx, ny)``."""
    return game_map.target_signed_distance(_planar(grid)).astype(np.float32)


def free_distance(game_map: GameMap, grid: Grid) -> np.ndarray:
    """Signed distance to the obstacles and to the domain's exterior on ``grid``.

    Positive in free space, negative inside an obstacle; the exterior is the outside of the
    domain grown by half a cell (module docstring). ``(nx, ny)``.
    """
    points = _planar(grid)
    hx, hy = grid.spacing
    xmin, xmax, ymin, ymax = game_map.domain
    grown = Box((xmin - hx / 2, ymin - hy / 2), (xmax + hx / 2, ymax + hy / 2))
    distance = -grown.signed_distance(points)
    for obstacle in game_map.obstacles:
        distance = np.minimum(distance, obstacle.signed_distance(points))
    return distance.astype(np.float32)


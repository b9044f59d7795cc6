"""The playing field: a rectangular domain, a target (union of shapes) and obstacles.

Coordinates are map units, ``x`` then ``y``; point arrays have shape ``(..., 2)``. This
module and ``shapes`` import numpy alone, so the solvers can stand on the map without the
simulator. The TOML ``[map]`` table is design.md section 5.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from reachavoid_env import checks
from reachavoid_env.shapes import Box, Shape, ShapeError, shape_from_dict

MAX_COORDINATE = 1e4
"""Largest absolute map coordinate (map units) a domain may have."""
MIN_EXTENT = 1e-3
"""Smallest width and height of a domain (map units)."""


class ScenarioError(checks.FieldError):
    """A scenario or map is invalid; ``field`` names the offending field."""


@dataclass(frozen=True)
class GameMap:
    """The playing field: a rectangular domain, a target (union of shapes) and obstacles.

    ``domain`` is ``(xmin, xmax, ymin, ymax)``. Leaving the domain counts as entering an
    obstacle wherever the game's sets are concerned.
    """

    domain: tuple[float, float, float, float]
    target: tuple[Shape, ...]
    obstacles: tuple[Shape, ...] = ()

    def __post_init__(self) -> None:
        for i, value in enumerate(self.domain):
            checks.real(value, f"map.domain[{i}]", -MAX_COORDINATE, MAX_COORDINATE,
                        error=ScenarioError)
        xmin, xmax, ymin, ymax = self.domain
        if not (xmax - xmin >= MIN_EXTENT and ymax - ymin >= MIN_EXTENT):
            raise ScenarioError(f"map.domain: need xmin < xmax and ymin < ymax, each extent at "
                                f"least {MIN_EXTENT:g}, got {self.domain}", field="map.domain")
        if not self.target:
            raise ScenarioError("map.target: at least one target shape is required",
                                field="map.target")
        for i, shape in enumerate(self.target):
            name = "map.target" if len(self.target) == 1 else f"map.target[{i}]"
            bx0, bx1, by0, by1 = shape.bounds()
            if bx0 < xmin or bx1 > xmax or by0 < ymin or by1 > ymax:
                raise ScenarioError(f"{name}: extends outside the domain {self.domain}", field=name)
            for k, obstacle in enumerate(self.obstacles):
                if _shapes_overlap(shape, obstacle):
                    raise ScenarioError(f"{name}: overlaps obstacle {k}", field=name)

    @property
    def size(self) -> tuple[float, float]:
        """Width and height of the domain (map units)."""
        xmin, xmax, ymin, ymax = self.domain
        return (xmax - xmin, ymax - ymin)

    def target_signed_distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance to the target union (negative inside)."""
        return np.min([s.signed_distance(points) for s in self.target], axis=0)

    def obstacle_signed_distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance to the obstacle union and the outside of the domain.

        Negative inside an obstacle or outside the domain, positive in free space.
        """
        xmin, xmax, ymin, ymax = self.domain
        outside = -Box((xmin, ymin), (xmax, ymax)).signed_distance(points)
        if not self.obstacles:
            return outside
        inside = np.min([s.signed_distance(points) for s in self.obstacles], axis=0)
        return np.minimum(inside, outside)

    def target_entry_time(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """First ``t`` in ``[0, 1]`` at which ``start + t (end - start)`` is in the target.

        ``starts`` and ``ends`` are ``(..., 2)``; the result is ``(...)``, ``inf`` for
        segments that never touch the target (boundary inclusive).
        """
        return np.min([s.segment_entry_time(starts, ends) for s in self.target], axis=0)

    def in_target(self, points: np.ndarray) -> np.ndarray:
        """Inside the target (inclusive of its boundary)."""
        return np.any([s.contains(points) for s in self.target], axis=0)

    def in_obstacle(self, points: np.ndarray) -> np.ndarray:
        """Inside an obstacle (inclusive) or outside the domain."""
        return self.obstacle_signed_distance(points) <= 0.0

    def to_dict(self) -> dict[str, Any]:
        return {
            "domain": list(self.domain),
            "target": _shapes_to_toml(self.target),
            "obstacles": [s.to_dict() for s in self.obstacles],
        }

    @classmethod
    def from_dict(cls, data: Any, field_name: str = "map") -> GameMap:
        if not isinstance(data, dict):
            raise ScenarioError(f"{field_name}: expected a table", field=field_name)
        unknown = set(data) - {"domain", "target", "obstacles"}
        if unknown:
            raise ScenarioError(f"{field_name}: unknown keys {sorted(unknown)}", field=field_name)
        if "domain" not in data:
            raise ScenarioError(f"{field_name}.domain: missing", field=f"{field_name}.domain")
        domain = data["domain"]
        if not isinstance(domain, list) or len(domain) != 4:
            raise ScenarioError(
                f"{field_name}.domain: expected [xmin, xmax, ymin, ymax], got {domain!r}"
            , field=f"{field_name}.domain")
        domain_t = tuple(checks.real(v, f"{field_name}.domain[{i}]", -MAX_COORDINATE,
                                     MAX_COORDINATE, error=ScenarioError)
                         for i, v in enumerate(domain))
        if "target" not in data:
            raise ScenarioError(f"{field_name}.target: missing", field=f"{field_name}.target")
        target = data["target"]
        targets = target if isinstance(target, list) else [target]
        obstacles = data.get("obstacles", [])
        if not isinstance(obstacles, list):
            raise ScenarioError(f"{field_name}.obstacles: expected a list of shape tables",
                                field=f"{field_name}.obstacles")
        try:
            target_shapes = tuple(
                shape_from_dict(t, f"{field_name}.target" + (f"[{i}]" if isinstance(target, list)
                                                              else ""))
                for i, t in enumerate(targets)
            )
            obstacle_shapes = tuple(
                shape_from_dict(o, f"{field_name}.obstacles[{i}]") for i, o in enumerate(obstacles)
            )
        except ShapeError as err:
            raise ScenarioError(str(err), err.field) from None
        return cls(domain_t, target_shapes, obstacle_shapes)  # type: ignore[arg-type]


def _shapes_to_toml(shapes: tuple[Shape, ...]) -> Any:
    return shapes[0].to_dict() if len(shapes) == 1 else [s.to_dict() for s in shapes]


def _shapes_overlap(a: Shape, b: Shape, samples: int = 64) -> bool:
    """Whether two shapes share interior points (checked on boundary and grid samples)."""
    ax0, ax1, ay0, ay1 = a.bounds()
    bx0, bx1, by0, by1 = b.bounds()
    x0, x1, y0, y1 = max(ax0, bx0), min(ax1, bx1), max(ay0, by0), min(ay1, by1)
    if x0 >= x1 or y0 >= y1:
        return False
    xs, ys = np.linspace(x0, x1, samples), np.linspace(y0, y1, samples)
    grid = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1)
    return bool(np.any((a.signed_distance(grid) < 0) & (b.signed_distance(grid) < 0)))


def flood_fill(passable: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """The cells of a planar boolean grid ``passable`` joined to ``seeds`` by a path of
    4-neighbours through passable cells (seeds outside ``passable`` are dropped).

    Args:
        passable: ``(nx, ny)`` bool, the cells a path may use.
        seeds: ``(nx, ny)`` bool, where paths start.

    Returns:
        ``(nx, ny)`` bool, the reached cells.
    """
    from scipy import ndimage  # only where a fill is made

    passable = np.asarray(passable, dtype=bool)
    # the default structure joins 4-neighbours; seeds outside the mask would stay set
    return ndimage.binary_propagation(passable & np.asarray(seeds, dtype=bool), mask=passable)

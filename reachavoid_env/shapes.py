"""Planar shapes of a game map: boxes, circles and simple polygons (concave allowed).

Every shape answers, for points given as an array of shape ``(..., 2)`` in map units
(``x`` then ``y``):

- ``signed_distance(points)``: exact Euclidean signed distance, negative inside,
  zero on the boundary, positive outside;
- ``contains(points)``: inside or on the boundary (inclusive);
- ``segment_entry_time(starts, ends)``: for straight segments ``start + t (end - start)``,
  ``t`` in ``[0, 1]``, the first ``t`` at which the segment is in the shape (boundary
  included), ``inf`` where it never is (exact for every shape kind);
- ``to_dict()`` / ``from_dict(table, field)``: the shape's TOML table, whose ``type`` is
  the class's ``type``;
- ``outline()``: the boundary as a closed ring of vertices ``(K, 2)`` for drawing;
- ``nearest_point(points)``: the shape's closest point to each point (the point itself
  where it is inside), ``(..., 2)`` -> ``(..., 2)`` (the observations' target direction).

``SHAPES`` is the registry (TOML ``type`` -> class) that the loader uses and that
``register`` fills, so a new shape kind is one class here (and, to be an obstacle in the
simulator, one ``world.static_shapes`` conversion). This module imports numpy alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

import numpy as np

from reachavoid_env.checks import FieldError


class ShapeError(FieldError):
    """A shape definition is malformed; ``field`` names the field (``None`` from the shape's
    own checks, which ``shape_from_dict`` prefixes with the table's field)."""


class Shape(Protocol):
    type: ClassVar[str]

    def signed_distance(self, points: np.ndarray) -> np.ndarray: ...
    def contains(self, points: np.ndarray) -> np.ndarray: ...
    def segment_entry_time(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray: ...
    def bounds(self) -> tuple[float, float, float, float]: ...
    def outline(self) -> np.ndarray: ...
    def nearest_point(self, points: np.ndarray) -> np.ndarray: ...
    def to_dict(self) -> dict[str, Any]: ...
    @classmethod
    def from_dict(cls, data: dict[str, Any], field: str) -> Shape: ...


SHAPES: dict[str, type[Shape]] = {}
"""TOML ``type`` -> shape class."""


def register(cls: type[Shape]) -> type[Shape]:
    """Class decorator: make ``cls`` loadable from TOML tables of ``type = cls.type``."""
    SHAPES[cls.type] = cls
    return cls


def _points(points: np.ndarray) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)
    if p.shape[-1:] != (2,):
        raise ValueError(f"points must have shape (..., 2), got {p.shape}")
    return p


def _settle(t: np.ndarray, start_in: np.ndarray, end_in: np.ndarray) -> np.ndarray:
    """Make entry times agree with the inclusive ``contains`` at both ends of a segment.

    A segment that starts inside enters at 0; one that ends inside enters by 1 (guards
    against rounding when the end lies exactly on the boundary).
    """
    t = np.where(end_in, np.minimum(t, 1.0), t)
    return np.where(start_in, 0.0, t)


@register
@dataclass(frozen=True)
class Box:
    """Axis-aligned box ``[min[0], max[0]] x [min[1], max[1]]``.

    TOML: ``{type = "box", min = [x, y], max = [x, y]}``.
    """

    type: ClassVar[str] = "box"
    min: tuple[float, float]
    max: tuple[float, float]

    @classmethod
    def from_dict(cls, data: dict[str, Any], field: str) -> Box:
        _keys(data, field, {"min", "max"})
        return cls(_vector(data["min"], f"{field}.min"), _vector(data["max"], f"{field}.max"))

    def __post_init__(self) -> None:
        if not (self.max[0] > self.min[0] and self.max[1] > self.min[1]):
            raise ShapeError(f"box max {self.max} must exceed min {self.min} on both axes")

    def signed_distance(self, points: np.ndarray) -> np.ndarray:
        p = _points(points)
        lo, hi = np.asarray(self.min), np.asarray(self.max)
        center, half = (lo + hi) / 2, (hi - lo) / 2
        q = np.abs(p - center) - half
        outside = np.linalg.norm(np.maximum(q, 0.0), axis=-1)
        inside = np.minimum(q.max(axis=-1), 0.0)
        return outside + inside

    def contains(self, points: np.ndarray) -> np.ndarray:
        p = _points(points)
        return np.all((p >= self.min) & (p <= self.max), axis=-1)

    def segment_entry_time(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """First ``t`` in ``[0, 1]`` where ``start + t (end - start)`` is in the box, else inf.

        Slab method (Liang-Barsky), inclusive bounds. Shapes ``(..., 2)`` -> ``(...)``.
        """
        p0, p1 = _points(starts), _points(ends)
        d = p1 - p0
        lo, hi = np.asarray(self.min), np.asarray(self.max)
        with np.errstate(divide="ignore", invalid="ignore"):
            t_lo, t_hi = (lo - p0) / d, (hi - p0) / d
        still = d == 0.0
        in_slab = (p0 >= lo) & (p0 <= hi)
        t_near = np.where(still, np.where(in_slab, -np.inf, np.inf), np.minimum(t_lo, t_hi))
        t_far = np.where(still, np.where(in_slab, np.inf, -np.inf), np.maximum(t_lo, t_hi))
        enter = np.maximum(t_near.max(axis=-1), 0.0)
        leave = np.minimum(t_far.min(axis=-1), 1.0)
        t = np.where(enter <= leave, enter, np.inf)
        return _settle(t, self.contains(p0), self.contains(p1))

    def bounds(self) -> tuple[float, float, float, float]:
        return (self.min[0], self.max[0], self.min[1], self.max[1])

    def outline(self) -> np.ndarray:
        (x0, y0), (x1, y1) = self.min, self.max
        return np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])

    def nearest_point(self, points: np.ndarray) -> np.ndarray:
        return np.clip(_points(points), self.min, self.max)

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.type, "min": list(self.min), "max": list(self.max)}


@register
@dataclass(frozen=True)
class Circle:
    """Disc of ``radius`` around ``center``.

    TOML: ``{type = "circle", center = [x, y], radius = r}``.
    """

    type: ClassVar[str] = "circle"
    center: tuple[float, float]
    radius: float

    @classmethod
    def from_dict(cls, data: dict[str, Any], field: str) -> Circle:
        _keys(data, field, {"center", "radius"})
        radius = data["radius"]
        if isinstance(radius, bool) or not isinstance(radius, (int, float)) \
                or not math.isfinite(radius):
            raise ShapeError(f"{field}.radius: expected a finite number, got {radius!r}",
                             field=f"{field}.radius")
        return cls(_vector(data["center"], f"{field}.center"), float(radius))

    def __post_init__(self) -> None:
        if not self.radius > 0:
            raise ShapeError(f"circle radius must be positive, got {self.radius}")

    def signed_distance(self, points: np.ndarray) -> np.ndarray:
        p = _points(points)
        return np.linalg.norm(p - np.asarray(self.center), axis=-1) - self.radius

    def contains(self, points: np.ndarray) -> np.ndarray:
        return self.signed_distance(points) <= 0.0

    def segment_entry_time(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """First ``t`` in ``[0, 1]`` where ``start + t (end - start)`` is in the disc, else inf.

        The smaller root of ``|start - center + t d|^2 = radius^2``. Shapes ``(..., 2)`` ->
        ``(...)``.
        """
        p0, p1 = _points(starts), _points(ends)
        return quadratic_entry_time(p0 - np.asarray(self.center), p1 - p0, self.radius)

    def bounds(self) -> tuple[float, float, float, float]:
        (cx, cy), r = self.center, self.radius
        return (cx - r, cx + r, cy - r, cy + r)

    def outline(self, vertices: int = 96) -> np.ndarray:
        angles = np.linspace(0.0, 2.0 * np.pi, vertices, endpoint=False)
        return np.asarray(self.center) + self.radius * np.stack([np.cos(angles),
                                                                 np.sin(angles)], axis=-1)

    def nearest_point(self, points: np.ndarray) -> np.ndarray:
        p = _points(points)
        offsets = p - np.asarray(self.center)
        lengths = np.linalg.norm(offsets, axis=-1, keepdims=True)
        with np.errstate(divide="ignore", invalid="ignore"):
            rim = np.asarray(self.center) + offsets * (self.radius / lengths)
        return np.where(lengths <= self.radius, p, rim)

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.type, "center": list(self.center), "radius": self.radius}


def _edges_meet(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray,
                adjacent: bool) -> bool:
    """Whether edges ``ab`` and ``cd`` share a point they should not: any point for edges
    that are not neighbours, more than the shared vertex for neighbours (a fold back)."""
    def cross(o: np.ndarray, p: np.ndarray, q: np.ndarray) -> float:
        return float((p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0]))

    def on_segment(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> bool:
        return bool(min(p[0], q[0]) <= r[0] <= max(p[0], q[0])
                    and min(p[1], q[1]) <= r[1] <= max(p[1], q[1]))

    d1, d2 = cross(c, d, a), cross(c, d, b)
    d3, d4 = cross(a, b, c), cross(a, b, d)
    if adjacent:
        # Neighbours share one vertex; they overlap only when collinear and folding back.
        shared_first = np.array_equal(b, c)
        p, q, r = (a, b, d) if shared_first else (c, d, b)
        return cross(p, q, r) == 0.0 and float(np.dot(p - q, r - q)) > 0.0
    if (d1 * d2 < 0) and (d3 * d4 < 0):
        return True
    return any(value == 0.0 and on_segment(p, q, r) for value, p, q, r in
               ((d1, c, d, a), (d2, c, d, b), (d3, a, b, c), (d4, a, b, d)))


def _first_crossing(v: np.ndarray) -> tuple[int, int] | None:
    """The first pair of edges ``(i, j)`` of the ring ``v`` that meet where they should not
    (``_edges_meet``), or ``None``: neighbours one by one, the others one edge against all
    later ones at once (the same arithmetic, vectorised)."""
    n = len(v)
    for i in range(n):
        j = (i + 1) % n
        first, second = (i, j) if i < j else (j, i)
        if _edges_meet(v[first], v[(first + 1) % n], v[second], v[(second + 1) % n], True):
            return first, second
    a_all, b_all = v, np.roll(v, -1, axis=0)

    def cross(o: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        return (p[..., 0] - o[..., 0]) * (q[..., 1] - o[..., 1]) - (
            p[..., 1] - o[..., 1]) * (q[..., 0] - o[..., 0])

    def on_segment(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:
        return ((np.minimum(p[..., 0], q[..., 0]) <= r[..., 0])
                & (r[..., 0] <= np.maximum(p[..., 0], q[..., 0]))
                & (np.minimum(p[..., 1], q[..., 1]) <= r[..., 1])
                & (r[..., 1] <= np.maximum(p[..., 1], q[..., 1])))

    for i in range(n - 2):
        js = np.arange(i + 2, n - 1 if i == 0 else n)
        if js.size == 0:
            continue
        a, b, c, d = a_all[i], b_all[i], a_all[js], b_all[js]
        d1, d2, d3, d4 = cross(c, d, a), cross(c, d, b), cross(a, b, c), cross(a, b, d)
        meet = (((d1 * d2 < 0) & (d3 * d4 < 0))
                | ((d1 == 0) & on_segment(c, d, a)) | ((d2 == 0) & on_segment(c, d, b))
                | ((d3 == 0) & on_segment(a, b, c)) | ((d4 == 0) & on_segment(a, b, d)))
        if meet.any():
            return i, int(js[np.argmax(meet)])
    return None


MAX_POLYGON_VERTICES = 1000
"""The most vertices a polygon may have: the self-intersection check is quadratic, and
takes under 1 s at the limit (BENCHMARKS.md, "Polygon validation")."""


@register
@dataclass(frozen=True)
class Polygon:
    """Simple polygon (convex or concave, not self-intersecting) given by its vertices.

    TOML: ``{type = "polygon", vertices = [[x, y], ...]}``, in either orientation. Repeated
    vertices are dropped (a closed ring whose last vertex repeats the first, or two equal
    consecutive vertices); what remains needs at least 3 vertices (at most
    ``MAX_POLYGON_VERTICES`` given), a non-zero area and no two edges that cross or touch
    other than at their shared vertex.
    """

    type: ClassVar[str] = "polygon"
    vertices: tuple[tuple[float, float], ...]

    @classmethod
    def from_dict(cls, data: dict[str, Any], field: str) -> Polygon:
        _keys(data, field, {"vertices"})
        vertices = data["vertices"]
        if not isinstance(vertices, list):
            raise ShapeError(f"{field}.vertices: expected a list of [x, y] pairs",
                             field=f"{field}.vertices")
        try:
            return cls(tuple(_vector(v, f"{field}.vertices[{i}]")
                             for i, v in enumerate(vertices)))
        except ShapeError as err:
            raise _named(err, field) from None

    def __post_init__(self) -> None:
        v = np.asarray(self.vertices, dtype=np.float64)
        if v.ndim != 2 or v.shape[1] != 2:
            raise ShapeError("polygon vertices must be a list of [x, y] pairs")
        if len(v) > MAX_POLYGON_VERTICES:
            raise ShapeError(f"polygon has {len(v)} vertices; at most {MAX_POLYGON_VERTICES} "
                             "are accepted")
        distinct = v[np.any(v != np.roll(v, -1, axis=0), axis=1)] if len(v) > 1 else v
        object.__setattr__(self, "vertices", tuple((float(x), float(y)) for x, y in distinct))
        v = distinct
        if len(v) < 3:
            raise ShapeError(f"polygon needs at least 3 distinct vertices, got {len(v)}")
        if abs(self.area) < 1e-12:
            raise ShapeError("polygon has zero area")
        crossing = _first_crossing(v)
        if crossing is not None:
            raise ShapeError(f"polygon edges {crossing[0]} and {crossing[1]} cross or overlap "
                             f"(self-intersecting)")

    @property
    def area(self) -> float:
        """Signed area (positive for counter-clockwise vertices)."""
        v = np.asarray(self.vertices, dtype=np.float64)
        x, y = v[:, 0], v[:, 1]
        return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))

    def _edge_points(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The closest point of every edge to ``p`` ``(..., E, 2)`` and its distance
        ``(..., E)``."""
        a = np.asarray(self.vertices, dtype=np.float64)
        b = np.roll(a, -1, axis=0)
        ab = b - a
        ap = p[..., None, :] - a
        t = np.clip(np.sum(ap * ab, axis=-1) / np.sum(ab * ab, axis=-1), 0.0, 1.0)
        closest = a + t[..., None] * ab
        return closest, np.linalg.norm(p[..., None, :] - closest, axis=-1)

    def _edge_distance(self, p: np.ndarray) -> np.ndarray:
        return self._edge_points(p)[1].min(axis=-1)

    def nearest_point(self, points: np.ndarray) -> np.ndarray:
        p = _points(points)
        closest, distances = self._edge_points(p)
        rim = np.take_along_axis(closest, distances.argmin(axis=-1)[..., None, None],
                                 axis=-2)[..., 0, :]
        return np.where(self._crossing_inside(p)[..., None], p, rim)

    def _crossing_inside(self, p: np.ndarray) -> np.ndarray:
        a = np.asarray(self.vertices, dtype=np.float64)
        b = np.roll(a, -1, axis=0)
        px, py = p[..., 0:1], p[..., 1:2]
        straddles = (a[:, 1] > py) != (b[:, 1] > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_cross = a[:, 0] + (py - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
        crossings = np.sum(straddles & (px < x_cross), axis=-1)
        return crossings % 2 == 1

    def signed_distance(self, points: np.ndarray) -> np.ndarray:
        p = _points(points)
        dist = self._edge_distance(p)
        return np.where(self._crossing_inside(p), -dist, dist)

    def contains(self, points: np.ndarray) -> np.ndarray:
        return self.signed_distance(points) <= 0.0

    def segment_entry_time(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """First ``t`` in ``[0, 1]`` where ``start + t (end - start)`` is in the polygon, else inf.

        A segment starting outside enters where it first meets an edge (touching counts;
        a segment running along an edge meets it where the overlap begins). Shapes
        ``(..., 2)`` -> ``(...)``.
        """
        p0, p1 = _points(starts), _points(ends)
        a = np.asarray(self.vertices, dtype=np.float64)
        e = np.roll(a, -1, axis=0) - a
        d = (p1 - p0)[..., None, :]
        w = a - p0[..., None, :]
        denom = d[..., 0] * e[:, 1] - d[..., 1] * e[:, 0]
        w_cross_e = w[..., 0] * e[:, 1] - w[..., 1] * e[:, 0]
        w_cross_d = w[..., 0] * d[..., 1] - w[..., 1] * d[..., 0]
        eps = 1e-12
        with np.errstate(divide="ignore", invalid="ignore"):
            t = w_cross_e / denom
            s = w_cross_d / denom
            crossing = (denom != 0.0) & (t >= 0.0) & (t <= 1.0) & (s >= -eps) & (s <= 1.0 + eps)
            # Collinear with an edge: the overlap of the two segments, if any.
            dd = np.sum(d * d, axis=-1)
            t_a = np.sum(w * d, axis=-1) / dd
            t_b = np.sum((w + e) * d, axis=-1) / dd
            first = np.maximum(np.minimum(t_a, t_b), 0.0)
            last = np.minimum(np.maximum(t_a, t_b), 1.0)
        collinear = (denom == 0.0) & (w_cross_d == 0.0) & (dd > 0.0) & (first <= last)
        hits = np.where(crossing, t, np.where(collinear, first, np.inf))
        return _settle(hits.min(axis=-1), self.contains(p0), self.contains(p1))

    def bounds(self) -> tuple[float, float, float, float]:
        v = np.asarray(self.vertices, dtype=np.float64)
        return (float(v[:, 0].min()), float(v[:, 0].max()), float(v[:, 1].min()),
                float(v[:, 1].max()))

    def outline(self) -> np.ndarray:
        return np.asarray(self.vertices, dtype=np.float64)

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.type, "vertices": [list(v) for v in self.vertices]}


def quadratic_entry_time(offsets: np.ndarray, motions: np.ndarray,
                         radius: float) -> np.ndarray:
    """First ``t`` in ``[0, 1]`` with ``|offset + t motion| <= radius``, else inf.

    ``offsets`` and ``motions`` are ``(..., 2)`` (map units); the result is ``(...)``.
    The earliest root of the quadratic in its cancellation-free form
    ``t = c / (-b + sqrt(b^2 - a c))``; zero where the offset already lies within ``radius``.
    """
    ox, oy = offsets[..., 0], offsets[..., 1]
    mx, my = motions[..., 0], motions[..., 1]
    r2 = radius * radius
    a = mx * mx + my * my
    b = ox * mx + oy * my
    c = ox * ox + oy * oy - r2
    disc = b * b - a * c
    approaching = (b < 0.0) & (disc >= 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = c / (np.sqrt(np.where(approaching, disc, 0.0)) - b)
    t = np.where(approaching & (t <= 1.0), t, np.inf)
    ex, ey = ox + mx, oy + my
    t = np.where(ex * ex + ey * ey <= r2, np.minimum(t, 1.0), t)
    return np.where(c <= 0.0, 0.0, t)


def _vector(value: Any, field: str) -> tuple[float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise ShapeError(f"{field}: expected a vector [x, y] of length 2, got {value!r}",
                         field=field)
    try:
        x, y = (float(c) for c in value)
    except (TypeError, ValueError):
        raise ShapeError(f"{field}: expected numbers, got {value!r}", field=field) from None
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ShapeError(f"{field}: coordinates must be finite, got {value!r}", field=field)
    return (x, y)


def _keys(data: dict[str, Any], field: str, required: set[str]) -> None:
    """Refuse a table of the wrong keys (``type`` aside), naming ``field``."""
    keys = set(data) - {"type"}
    missing, extra = required - keys, keys - required
    if missing:
        raise ShapeError(f"{field}: {data['type']} needs {sorted(missing)}", field=field)
    if extra:
        raise ShapeError(f"{field}: unknown keys {sorted(extra)} for a {data['type']}", field=field)


def shape_from_dict(data: Any, field: str) -> Shape:
    """Build a shape from its TOML table (``SHAPES``); errors name ``field`` and the reason."""
    if not isinstance(data, dict):
        raise ShapeError(f"{field}: expected a table with a 'type', got {data!r}", field=field)
    kind = data.get("type")
    if kind not in SHAPES:
        raise ShapeError(f"{field}.type: unknown shape type {kind!r} (expected one of "
                         f"{', '.join(SHAPES)})", field=f"{field}.type")
    try:
        return SHAPES[kind].from_dict(data, field)
    except ShapeError as err:
        raise _named(err, field) from None


def _named(err: ShapeError, field: str) -> ShapeError:
    """``err`` if it names its field, else the same reason under ``field``."""
    return err if err.field is not None else ShapeError(f"{field}: {err}", field)

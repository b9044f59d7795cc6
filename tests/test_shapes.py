"""Shapes: signed distance and segment entry times against brute force, inclusive bounds."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.path import Path

import reachavoid_env
from reachavoid_env import Box, Circle, Polygon, ShapeError
from reachavoid_env.shapes import (
    MAX_POLYGON_VERTICES,
    _edges_meet,
    _first_crossing,
    quadratic_entry_time,
    shape_from_dict,
)

CONCAVE = Polygon(((-0.6, -0.5), (0.6, -0.5), (0.6, 0.5), (0.2, 0.5), (0.0, -0.1),
                   (-0.2, 0.5), (-0.6, 0.5)))           # a "U"-like notch from the top
CLOCKWISE = Polygon(((0.0, 0.0), (0.0, 0.4), (0.3, 0.1)))
SHAPES = {
    "box": Box((-0.3, -0.2), (0.5, 0.4)),
    "circle": Circle((0.1, -0.2), 0.35),
    "concave": CONCAVE,
    "clockwise": CLOCKWISE,
}


def boundary_samples(shape, per_unit: int = 20000) -> np.ndarray:
    """Dense points on the shape's boundary."""
    if isinstance(shape, Circle):
        n = int(2 * np.pi * shape.radius * per_unit)
        angle = np.linspace(0, 2 * np.pi, n, endpoint=False)
        return np.asarray(shape.center) + shape.radius * np.stack([np.cos(angle),
                                                                    np.sin(angle)], -1)
    if isinstance(shape, Box):
        (x0, y0), (x1, y1) = shape.min, shape.max
        ring = np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
    else:
        ring = np.asarray(shape.vertices)
    pieces = []
    for a, b in zip(ring, np.roll(ring, -1, axis=0), strict=True):
        n = max(2, int(np.linalg.norm(b - a) * per_unit))
        pieces.append(a + np.linspace(0, 1, n, endpoint=False)[:, None] * (b - a))
    return np.concatenate(pieces)


def brute_inside(shape, points: np.ndarray) -> np.ndarray:
    if isinstance(shape, Circle):
        return np.hypot(*(points - shape.center).T) < shape.radius
    if isinstance(shape, Box):
        return np.all((points > shape.min) & (points < shape.max), axis=-1)
    return Path(np.asarray(shape.vertices)).contains_points(points)


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_signed_distance_matches_brute_force(name):
    shape = SHAPES[name]
    rng = np.random.default_rng(1)
    points = rng.uniform(-1, 1, size=(400, 2))
    boundary = boundary_samples(shape)
    spacing = 1.0 / 20000
    brute = np.min(np.linalg.norm(points[:, None] - boundary[None], axis=-1), axis=1)
    brute = np.where(brute_inside(shape, points), -brute, brute)
    exact = shape.signed_distance(points)
    assert np.all(np.abs(exact - brute) <= spacing)
    assert np.any(exact < 0) and np.any(exact > 0)


def test_concave_polygon_notch_is_outside():
    assert not CONCAVE.contains(np.array([0.0, 0.3]))
    assert CONCAVE.contains(np.array([0.0, -0.2]))
    # Distance from the notch's mouth to the nearest edge, not to the hull.
    assert CONCAVE.signed_distance(np.array([0.0, 0.3])) == pytest.approx(
        0.4 / np.hypot(1, 3), abs=1e-12)


def test_contains_is_inclusive_on_the_boundary():
    box = Box((0.6, 0.1), (0.8, 0.3))
    edges = np.array([[0.6, 0.2], [0.8, 0.3], [0.7, 0.1], [0.6, 0.1]])
    assert box.contains(edges).all()
    assert not box.contains(np.array([0.6 - 1e-12, 0.2]))
    assert Circle((0.0, 0.0), 0.5).contains(np.array([0.5, 0.0]))
    assert CONCAVE.contains(np.array([0.6, 0.0]))


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_segment_entry_time_matches_sampling(name):
    """The exact entry time is in the shape, and no earlier sample along the segment is."""
    shape = SHAPES[name]
    rng = np.random.default_rng(2)
    starts = rng.uniform(-1, 1, size=(300, 2))
    ends = starts + rng.normal(scale=0.6, size=(300, 2))
    exact = shape.segment_entry_time(starts, ends)
    samples = np.linspace(0, 1, 4001)
    tol = 1e-9
    hits = 0
    for p0, p1, t in zip(starts, ends, exact, strict=True):
        along = p0 + samples[:, None] * (p1 - p0)
        distance = shape.signed_distance(along)
        if np.isfinite(t):
            hits += 1
            assert 0.0 <= t <= 1.0
            assert shape.signed_distance(p0 + t * (p1 - p0)) <= tol
            assert np.all(distance[samples < t - 1e-3] > -tol)
        else:
            assert np.all(distance > -tol)
    assert hits > 20


def test_segment_entry_time_edge_cases():
    box = Box((0.6, 0.1), (0.8, 0.3))
    starts = np.array([[0.5, 0.2], [0.7, 0.2], [0.5, 0.3], [0.5, 0.0], [0.5, 0.5],
                       [0.55, 0.2]])
    ends = np.array([[0.6, 0.2], [0.7, 0.2], [0.7, 0.3], [0.7, 0.0], [0.7, 0.3],
                     [0.55, 0.2]])
    t = box.segment_entry_time(starts, ends)
    # Ends on the edge; starts inside (still); runs along the top edge; misses below;
    # ends on the top edge after a diagonal approach; a still point outside never enters.
    assert t.tolist() == [1.0, 0.0, 0.5, np.inf, 1.0, np.inf]
    circle = Circle((0.0, 0.0), 1.0)
    t = circle.segment_entry_time(np.array([[-2.0, 1.0], [-2.0, 1.0 + 1e-9]]),
                                  np.array([[2.0, 1.0], [2.0, 1.0 + 1e-9]]))
    assert t[0] == pytest.approx(0.5) and t[1] == np.inf
    notch = CONCAVE.segment_entry_time(np.array([[0.0, 0.4], [0.0, 0.4]]),
                                       np.array([[0.0, -0.3], [0.0, 0.2]]))
    assert notch[0] == pytest.approx(0.5 / 0.7) and notch[1] == np.inf


def test_quadratic_entry_time_catches_a_fast_pass_by():
    # Both ends are 1.0 away, but the segment passes through the disc.
    t = quadratic_entry_time(np.array([-1.0, 0.05]), np.array([2.0, 0.0]), 0.1)
    assert t == pytest.approx((1.0 - np.sqrt(0.1**2 - 0.05**2)) / 2.0)
    assert quadratic_entry_time(np.array([-1.0, 0.2]), np.array([2.0, 0.0]), 0.1) == np.inf
    assert quadratic_entry_time(np.array([0.05, 0.0]), np.array([2.0, 0.0]), 0.1) == 0.0


def test_pymunk_shapes_cover_concave_polygon():
    import pymunk

    from reachavoid_env.world import static_shapes

    space = pymunk.Space()
    parts = static_shapes(CONCAVE, space.static_body)
    space.add(*parts)
    assert len(parts) >= 2
    inside = space.point_query_nearest((0.0, -0.3), 0.0, pymunk.ShapeFilter())
    notch = space.point_query_nearest((0.0, 0.3), 0.0, pymunk.ShapeFilter())
    assert inside is not None and notch is None


@pytest.mark.parametrize(("table", "message"), [
    ({"type": "hexagon"}, "obstacles[0].type: unknown shape type 'hexagon'"),
    ({"type": "box", "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0]},
     "obstacles[0].min: expected a vector [x, y] of length 2"),
    ({"type": "box", "min": [1.0, 0.0], "max": [0.0, 1.0]}, "obstacles[0]: box max"),
    ({"type": "circle", "center": [0.0, 0.0], "radius": -1.0},
     "obstacles[0]: circle radius must be positive"),
    ({"type": "circle", "center": [0.0, 0.0]}, "obstacles[0]: circle needs ['radius']"),
    ({"type": "polygon", "vertices": [[0, 0], [2, 0], [0, 1], [1, 1]]},
     "obstacles[0]: polygon edges 1 and 3 cross"),
    ({"type": "polygon", "vertices": [[0, 0], [1, 1]]},
     "obstacles[0]: polygon needs at least 3 distinct vertices"),
])
def test_shape_errors_name_the_field(table, message):
    with pytest.raises(ShapeError) as info:
        shape_from_dict(table, "obstacles[0]")
    assert message in str(info.value)


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_to_dict_round_trips(name):
    shape = SHAPES[name]
    assert shape_from_dict(shape.to_dict(), "target") == shape


def test_polygon_repeated_vertices_are_dropped():
    ring = reachavoid_env.Polygon(((0.0, 0.0), (1.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.0, 0.0)))
    assert ring.vertices == ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0))
    inside = np.array([0.2, 0.2])
    assert ring.contains(inside) and np.isfinite(ring.signed_distance(inside))


@pytest.mark.parametrize(("vertices", "message"), [
    ([[0, 0], [1, 0], [2, 0]], "zero area"),
    ([[0, 0], [1, 0], [1, 1], [0, 1], [1, 0.5], [0.5, 0]], "self-intersecting"),
    ([[0, 0], [2, 0], [1, 0], [1, 1]], "self-intersecting"),
])
def test_degenerate_polygons_are_refused_by_name(vertices, message):
    with pytest.raises(reachavoid_env.ShapeError, match=rf"obstacles\[2\]: .*{message}"):
        reachavoid_env.scenario.shape_from_dict({"type": "polygon", "vertices": vertices},
                                                "obstacles[2]")


def test_polygon_vertex_cap():
    angles = np.linspace(0.0, 2.0 * np.pi, MAX_POLYGON_VERTICES, endpoint=False)
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    assert len(Polygon(tuple(map(tuple, ring))).vertices) == MAX_POLYGON_VERTICES
    more = np.vstack([ring, [[0.5, 0.0]]])
    with pytest.raises(ShapeError, match=f"at most {MAX_POLYGON_VERTICES}"):
        Polygon(tuple(map(tuple, more)))


def test_vectorised_crossing_check_matches_the_pairwise_one():
    def pairwise(v):
        n = len(v)
        return next(((i, j) for i in range(n) for j in range(i + 1, n)
                     if _edges_meet(v[i], v[(i + 1) % n], v[j], v[(j + 1) % n],
                                    j == i + 1 or (i == 0 and j == n - 1))), None)

    rng = np.random.default_rng(0)
    checked = 0
    for _ in range(2000):
        v = rng.integers(0, 4, size=(rng.integers(3, 9), 2)).astype(float)
        if np.any(np.all(v == np.roll(v, -1, axis=0), axis=1)):
            continue
        assert (pairwise(v) is None) == (_first_crossing(v) is None), v.tolist()
        checked += 1
    assert checked > 1000

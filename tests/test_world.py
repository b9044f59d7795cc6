"""The pymunk world: free motion, wall sliding, no tunnelling, players never in obstacles."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from reachavoid_env import Box, Circle, GameMap, Polygon, builtin_map
from reachavoid_env.world import World, substeps_for

RADIUS = 0.005
DT = 0.005
TOP_SPEED = 1.5

THIN_WALL = Box((0.0, -0.8), (0.001, 0.8))
FUZZ_MAP = GameMap(
    domain=(-1.0, 1.0, -1.0, 1.0),
    target=(Box((0.6, 0.6), (0.8, 0.8)),),
    obstacles=(
        THIN_WALL,
        Circle((-0.5, 0.5), 0.15),
        Polygon(((-0.7, -0.7), (-0.2, -0.7), (-0.2, -0.2), (-0.35, -0.2), (-0.45, -0.55),
                 (-0.55, -0.2), (-0.7, -0.2))),
        Box((0.3, -0.5), (0.5, -0.3)),
    ),
)


def world_of(game_map: GameMap, positions, substeps: int | None = None) -> World:
    return World(game_map, RADIUS, np.asarray(positions, dtype=float), TOP_SPEED, DT,
                 substeps=substeps)


def test_substeps_keep_moves_under_half_a_radius():
    assert substeps_for(1.5, 0.005, 0.005) == 3
    assert substeps_for(1.0, 0.001, 0.005) == 1
    assert substeps_for(10.0, 0.01, 0.005) == 40


def test_free_motion_is_exact():
    world = world_of(builtin_map(), [[-0.5, 0.0], [0.5, 0.0]])
    velocities = np.array([[1.0, 0.5], [-1.5, 0.0]])
    positions = world.step(velocities)
    assert np.allclose(positions, [[-0.5 + 0.005, 0.0025], [0.5 - 0.0075, 0.0]], atol=1e-12)
    for _ in range(99):
        positions = world.step(velocities)
    assert np.allclose(positions, [[0.0, 0.25], [0.5 - 0.75, 0.0]], atol=1e-9)


def test_players_pass_through_each_other():
    world = world_of(builtin_map(), [[0.3, 0.0], [0.5, 0.0]])
    for _ in range(40):
        positions = world.step(np.array([[1.0, 0.0], [-1.0, 0.0]]))
    assert np.allclose(positions, [[0.5, 0.0], [0.3, 0.0]], atol=1e-9)


def test_player_slides_along_a_wall():
    # The paper's lower wall: x in [-0.1, 0.1], y in [-1, -0.3]. Push right and up into it.
    world = world_of(builtin_map(), [[-0.2, -0.8]])
    velocity = np.array([[1.2, 0.9]])          # speed 1.5
    path = np.array([world.step(velocity)[0] for _ in range(60)])
    touching = path[:, 0] > -0.1 - RADIUS - 1e-3
    assert touching.sum() > 40
    assert np.all(path[:, 0] <= -0.1 - 0.5 * RADIUS)
    # Along the wall the vertical speed is kept, the horizontal one is stopped.
    steps_up = np.diff(path[touching, 1])
    assert np.allclose(steps_up[1:], 0.9 * DT, rtol=1e-6)
    # Past the wall's top end (y = -0.3) the player goes round the corner.
    for _ in range(120):
        end = world.step(velocity)[0]
    assert end[0] > 0.1 and end[1] > -0.3


def test_player_stops_at_the_domain_edge():
    world = world_of(builtin_map(), [[0.9, 0.9]])
    for _ in range(100):
        end = world.step(np.array([[1.5, 0.0]]))[0]
    assert end[0] == pytest.approx(1.0 - RADIUS, abs=1e-4) and end[1] == pytest.approx(0.9)


def _rush_the_thin_wall(substeps: int | None) -> np.ndarray:
    """Players at top speed head-on into a wall 0.001 thick, from staggered distances."""
    game_map = GameMap((-1.0, 1.0, -1.0, 1.0), (Box((0.6, 0.85), (0.8, 0.95)),), (THIN_WALL,))
    starts = np.stack([-0.05 - np.linspace(0.0, 0.0075, 16), np.linspace(-0.5, 0.5, 16)], -1)
    world = world_of(game_map, starts, substeps=substeps)
    for _ in range(40):
        positions = world.step(np.tile([TOP_SPEED, 0.0], (16, 1)))
    return positions


def test_no_tunnelling_through_a_thin_wall_at_top_speed():
    positions = _rush_the_thin_wall(substeps=None)
    assert np.all(positions[:, 0] < 0.0)
    assert np.all(THIN_WALL.signed_distance(positions) >= 0.5 * RADIUS)


def test_one_physics_step_per_step_would_tunnel():
    # The check above bites: without sub-steps some player crosses the wall.
    positions = _rush_the_thin_wall(substeps=1)
    assert np.any(positions[:, 0] > 0.001)


def test_world_is_deterministic():
    starts = [[-0.8, 0.1], [0.7, -0.2], [0.2, 0.9]]
    rng = np.random.default_rng(3)
    velocities = rng.uniform(-1.0, 1.0, size=(200, 3, 2))
    runs = []
    for _ in range(2):
        world = world_of(FUZZ_MAP, starts)
        runs.append(np.array([world.step(v) for v in velocities]))
    assert np.array_equal(runs[0], runs[1])


def test_bodies_out_of_batch_order_are_found_by_their_rows():
    # Bodies added in order sit in consecutive batch rows (a slice); any other order is
    # looked up row by row and moves the same.
    starts = [[-0.8, 0.1], [0.7, -0.2], [0.2, 0.9]]
    velocities = np.random.default_rng(5).uniform(-1.0, 1.0, size=(50, 3, 2))
    world, swapped = world_of(FUZZ_MAP, starts), world_of(FUZZ_MAP, starts)
    assert isinstance(world._rows, slice)
    swapped.bodies[0], swapped.bodies[1] = swapped.bodies[1], swapped.bodies[0]
    swapped._ids[[0, 1]] = swapped._ids[[1, 0]]
    swapped._rows, _ = swapped._body_rows()
    order = [1, 0, 2]
    assert swapped._rows.tolist() == order
    for v in velocities:
        assert np.array_equal(world.step(v), swapped.step(v[order])[order])


@settings(max_examples=25, deadline=None)
@given(
    starts=arrays(np.float64, (6, 2), elements=st.floats(-0.98, 0.98)),
    controls=arrays(np.float64, (80, 6, 2), elements=st.floats(-1.0, 1.0)),
    persist=st.integers(1, 20),
)
def test_fuzz_players_stay_in_the_domain_and_out_of_obstacles(starts, controls, persist):
    clear = FUZZ_MAP.obstacle_signed_distance(starts) >= RADIUS
    starts = np.where(clear[:, None], starts, [[0.9, 0.0]])
    world = world_of(FUZZ_MAP, starts)
    for k, control in enumerate(controls):
        # Hold each action a while so players press into walls and corners.
        held = controls[(k // persist) * persist]
        velocity = TOP_SPEED * (held if k % 2 else control)
        positions = world.step(velocity)
        assert np.all(FUZZ_MAP.obstacle_signed_distance(positions) >= 0.25 * RADIUS)

"""Geodesic distance fields and the shortest-path attacker."""

from __future__ import annotations

import numpy as np
import pytest

import reachavoid_env
from policies import IdleDefender, ShortestPathAttacker
from reachavoid_env import AttackerStatus, Box, GameMap, GameState, Policy, builtin_map
from reachavoid_env.geodesic import distance_field

RADIUS = 0.005
PAPER = builtin_map("paper")
# Hard starts on the paper map: behind the wall rising from the bottom edge, pressed
# against the walls' faces, and on the ridge behind the upper wall (y = 0.49 on its left
# face the ways over and under it are equally long).
BEHIND_WALLS = np.array([[-0.2, -0.95], [-0.5, -0.8], [-0.106, -0.6], [-0.106, 0.49],
                         [-0.3, 0.49], [-0.106, 0.35], [0.0, 0.62], [-0.95, 0.95],
                         [0.106, -0.9], [0.0, -0.28]])


def free_starts(game_map: GameMap, count: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    points = rng.uniform(-1.0, 1.0, size=(20 * count, 2))
    ok = (game_map.obstacle_signed_distance(points) > 0.02) \
        & (game_map.target_signed_distance(points) > 0.02)
    return points[ok][:count]


def integrate(field, starts: np.ndarray, speed: float = 1.0, dt: float = 0.005,
              max_time: float = 6.0) -> tuple[np.ndarray, float]:
    """Move points along ``field.descent`` (x' = speed * u) until each is in the target.

    Returns the arrival times (inf if never) and the smallest clearance to the obstacles
    and walls along the way.
    """
    position = starts.astype(float).copy()
    arrival = np.full(len(starts), np.inf)
    lowest = np.inf
    for step in range(int(max_time / dt)):
        live = ~np.isfinite(arrival)
        if not live.any():
            break
        position[live] += dt * speed * field.descent(position[live])
        lowest = min(lowest, float(field.game_map.obstacle_signed_distance(position).min()))
        arrived = live & field.game_map.in_target(position)
        arrival[arrived] = (step + 1) * dt
    return arrival, lowest


def test_field_is_euclidean_without_obstacles():
    open_map = GameMap(PAPER.domain, PAPER.target, ())
    field = distance_field(open_map, RADIUS, 128)
    points = free_starts(open_map, 500, seed=0)
    exact = open_map.target_signed_distance(points)
    h = field.spacing[0]
    assert np.max(np.abs(field.distance(points) - exact)) < 0.5 * h
    assert np.all(field.distance(np.array([[0.7, 0.2], [0.65, 0.15]])) < -0.04)  # inside


def test_field_goes_round_the_wall():
    field = distance_field(PAPER, RADIUS, 256)
    behind = np.array([[-0.2, -0.95], [-0.5, -0.8]])
    corner, nearest_target_point = np.array([-0.1, -0.3]), np.array([0.6, 0.1])
    via_corner = (np.linalg.norm(behind - corner, axis=1)
                  + np.linalg.norm(corner - nearest_target_point))
    straight = PAPER.target_signed_distance(behind)
    assert np.all(field.distance(behind) > straight + 0.02)
    # fast marching is first order where paths graze an obstacle: allow two cells
    np.testing.assert_allclose(field.distance(behind), via_corner, atol=2 * field.spacing[0])


def test_gradient_has_unit_length_in_free_space():
    field = distance_field(PAPER, RADIUS, 256)
    points = free_starts(PAPER, 2000, seed=1)
    points = points[PAPER.obstacle_signed_distance(points) > 0.05]
    length = np.linalg.norm(field.gradient(points), axis=1)
    assert np.mean(np.abs(length - 1.0) < 0.05) > 0.97


def test_descent_never_points_into_a_wall():
    field = distance_field(PAPER, RADIUS, 256)
    rng = np.random.default_rng(2)
    points = rng.uniform(-1.0, 1.0, size=(80000, 2))
    gap = PAPER.obstacle_signed_distance(points)
    points = points[(gap > RADIUS) & (gap < RADIUS + field.spacing[0])]  # within one cell
    assert len(points) > 300
    heading = field.descent(points)
    np.testing.assert_allclose(np.linalg.norm(heading, axis=1), 1.0, rtol=1e-9)
    eps = 1e-6
    normal = np.stack([
        PAPER.obstacle_signed_distance(points + [eps, 0]) - PAPER.obstacle_signed_distance(
            points - [eps, 0]),
        PAPER.obstacle_signed_distance(points + [0, eps]) - PAPER.obstacle_signed_distance(
            points - [0, eps])], axis=1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    assert np.all(np.einsum("kd,kd->k", heading, normal) > -1e-6)


@pytest.mark.parametrize("starts", ["behind_walls", "random"])
def test_descent_reaches_the_target_within_the_field_time(starts):
    field = distance_field(PAPER, RADIUS, 256)
    points = BEHIND_WALLS if starts == "behind_walls" else free_starts(PAPER, 80, seed=3)
    arrival, lowest = integrate(field, points)
    assert np.all(np.isfinite(arrival))
    bound = field.distance(points)  # speed 1: the field is the time to the target
    assert np.all(arrival <= 1.03 * bound + 0.015)
    assert np.all(arrival >= 0.97 * bound - 0.015)
    assert lowest > 0.5 * RADIUS  # never cuts a corner or grazes into a wall


@pytest.mark.parametrize("starts", ["behind_walls", "random"])
def test_attacker_reaches_the_target_in_the_env(starts):
    # One idle defender in a corner, away from every path: only the attackers move.
    points = BEHIND_WALLS if starts == "behind_walls" else free_starts(PAPER, 40, seed=4)
    points = points[np.linalg.norm(points - [0.95, -0.95], axis=1) > 0.2]
    scenario = reachavoid_env.builtin_scenario("paper_2v1")
    scenario = scenario.with_players(len(points), 1).with_starts(points, np.array([[0.95, -0.95]]))
    env = reachavoid_env.parallel_env(scenario=scenario)
    env.reset(seed=0)
    attackers, defenders = ShortestPathAttacker(), IdleDefender()
    attackers.reset(env.unwrapped.scenario)
    defenders.reset(env.unwrapped.scenario)
    arrival = np.full(len(points), np.inf)
    while env.agents:
        state = env.unwrapped.game_state()
        actions = {**attackers.act(state), **defenders.act(state)}
        env.step({agent: actions[agent] for agent in env.agents})
        after = env.unwrapped.game_state()
        for i, status in enumerate(after.attacker_status):
            if status is AttackerStatus.ARRIVED and not np.isfinite(arrival[i]):
                arrival[i] = after.time
    env.close()
    assert np.all(np.isfinite(arrival)), arrival
    bound = attackers.field.distance(points) / scenario.attacker_speed
    assert np.all(arrival <= 1.03 * bound + 3 * scenario.dt)


def state_of(attackers, status=None) -> GameState:
    attackers = np.asarray(attackers, dtype=float)
    return GameState(time=0.0, step=0, attacker_positions=attackers,
                     defender_positions=np.array([[0.95, -0.95]]),
                     attacker_status=tuple(status or [AttackerStatus.ACTIVE] * len(attackers)),
                     attacker_speed=1.0, defender_speed=1.5, capture_radius=0.1)


def test_attacker_actions():
    policy = ShortestPathAttacker(cells=128)
    assert isinstance(policy, Policy)
    with pytest.raises(RuntimeError, match="reset"):
        policy.act(state_of([[0.0, 0.0]]))
    policy.reset(reachavoid_env.builtin_scenario("paper_2v1"))
    status = [AttackerStatus.ACTIVE, AttackerStatus.CAPTURED, AttackerStatus.ACTIVE,
              AttackerStatus.ACTIVE]
    actions = policy.act(state_of([[-0.5, 0.0], [0.0, 0.8], [0.7, 0.2], [0.3, 0.2]], status))
    assert sorted(actions) == ["attacker_0", "attacker_2", "attacker_3"]
    for action in actions.values():
        assert action.dtype == np.float32 and action.shape == (2,)
    np.testing.assert_array_equal(actions["attacker_2"], [0.0, 0.0])  # in the target: stop
    np.testing.assert_allclose(actions["attacker_3"], [1.0, 0.0], atol=0.02)
    assert np.linalg.norm(actions["attacker_0"]) == pytest.approx(1.0, abs=1e-6)
    assert policy.act(state_of([[0.0, 0.0]], [AttackerStatus.ARRIVED])) == {}


def test_fields_are_cached_per_map():
    assert distance_field(PAPER, RADIUS, 64) is distance_field(PAPER, RADIUS, 64)
    assert distance_field(PAPER, RADIUS, 64) is not distance_field(PAPER, 2 * RADIUS, 64)
    assert not distance_field(PAPER, RADIUS, 64).values.flags.writeable


def test_field_errors_name_the_argument():
    with pytest.raises(ValueError, match="clearance"):
        distance_field(PAPER, -0.1)
    with pytest.raises(ValueError, match="cells"):
        distance_field(PAPER, RADIUS, 4)
    speck = GameMap((-1.0, 1.0, -1.0, 1.0), (Box((0.301, 0.301), (0.302, 0.302)),))
    with pytest.raises(ValueError, match="target"):
        distance_field(speck, RADIUS, 32)
    with pytest.raises(ValueError, match="points"):
        distance_field(PAPER, RADIUS, 64).distance(np.zeros(3))

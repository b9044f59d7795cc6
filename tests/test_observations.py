"""The egocentric observation (v1): lidar distances exact, the target seen, the layout."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from lidar_reference import cast

import reachavoid_env
from reachavoid_env import Box, Circle, GameMap, Polygon, builtin_scenario
from reachavoid_env.lidar import Lidar, RayScene
from reachavoid_env.observations import ObservationConfig

OPEN = GameMap(domain=(-1.0, 1.0, -1.0, 1.0), target=(Box((0.6, 0.6), (0.9, 0.9)),))


def _env(scenario, **kwargs):
    env = reachavoid_env.parallel_env(scenario=scenario, **kwargs)
    return env


def test_a_wall_in_front_shortens_the_ray_to_the_exact_distance():
    """Ray 0 points along +x: with a wall 0.37 ahead of the attacker it reads 0.37 (less the
    nothing: the distance from the centre to the wall's face)."""
    scenario = replace(builtin_scenario("paper_1v1").with_players(1, 1), map=OPEN)
    wall = replace(scenario, map=replace(OPEN, obstacles=(Box((0.17, -0.5), (0.3, 0.5)),)))
    seen = {}
    for name, sc in (("open", scenario), ("wall", wall)):
        env = _env(sc, observation=ObservationConfig(lidar_rays=4))
        obs, _ = env.reset(seed=0, options={"attackers": [[-0.2, 0.0]],
                                            "defenders": [[-0.5, -0.5]]})
        seen[name] = obs["attacker_0"]
    diagonal = math.hypot(2.0, 2.0)
    ray0 = 4 + 3        # own (x, y, vx, vy), target (dx, dy, distance), then the rays
    assert seen["open"][ray0] == pytest.approx(1.2 / diagonal)     # the domain's side
    assert seen["wall"][ray0] == pytest.approx(0.37 / diagonal, abs=1e-7)
    assert seen["wall"][ray0 + 2] == seen["open"][ray0 + 2]          # -x: nothing changed


def test_moving_the_target_changes_the_observation():
    scenario = replace(builtin_scenario("paper_1v1").with_players(1, 1), map=OPEN)
    moved = replace(scenario, map=replace(OPEN, target=(Box((-0.9, 0.6), (-0.6, 0.9)),)))
    starts = {"attackers": [[0.0, 0.0]], "defenders": [[0.5, -0.5]]}
    first = _env(scenario).reset(seed=0, options=starts)[0]["attacker_0"]
    second = _env(moved).reset(seed=0, options=starts)[0]["attacker_0"]
    diagonal = math.hypot(2.0, 2.0)
    assert first[4:6] == pytest.approx(np.array([0.6, 0.6]) / diagonal)
    assert second[4:6] == pytest.approx(np.array([-0.6, 0.6]) / diagonal)
    np.testing.assert_array_equal(first[7:], second[7:])          # the rest is the same


@pytest.mark.parametrize("obstacles", [
    (),
    (Box((-0.3, -0.2), (0.1, 0.4)), Circle((0.5, -0.4), 0.2)),
    (Polygon(((-0.8, -0.8), (-0.2, -0.7), (-0.5, -0.3))), Circle((0.2, 0.7), 0.1)),
])
def test_the_kernel_is_its_numpy_twin(obstacles):
    game_map = replace(OPEN, obstacles=obstacles)
    lidar = Lidar(RayScene.of(game_map), 37, 2.2)
    rng = np.random.default_rng(0)
    origins = rng.uniform(-1.0, 1.0, (200, 2))
    origins = origins[game_map.obstacle_signed_distance(origins) > 0]
    np.testing.assert_allclose(lidar(origins), cast(lidar, origins), rtol=1e-12, atol=1e-12)
    # every hit lies on the boundary of the free space (or at the range)
    hits = origins[:, None, :] + lidar(origins)[..., None] * lidar.directions
    at_range = lidar(origins) >= 2.2
    boundary = np.abs(game_map.obstacle_signed_distance(hits))
    assert (boundary[~at_range] < 1e-9).all()


def test_layout_and_options():
    config = ObservationConfig(lidar_rays=0, velocities=False, time_left=False)
    assert config.size(2, 1) == 2 + 3 + 3 * 2
    assert ObservationConfig().size(8, 4) == 79
    env = _env("paper_2v1", observation={"lidar_rays": 8})
    assert env.observation_space("defender_0").shape == (4 + 3 + 8 + 5 * 2 + 1,)
    with pytest.raises(ValueError, match="observation.lidar_rays: must be an integer"):
        ObservationConfig(lidar_rays=-1)
    with pytest.raises(ValueError, match="observation.rays: not an option"):
        _env("paper_2v1", observation={"rays": 8})
    with pytest.raises(ValueError, match="observation.velocities: expected true or false"):
        ObservationConfig(velocities=1)


def test_velocities_and_time_left_follow_the_game():
    env = _env("paper_1v1", max_cycles=10)
    obs, _ = env.reset(seed=0)
    assert obs["attacker_0"][2:4].tolist() == [0.0, 0.0] and obs["attacker_0"][-1] == 1.0
    obs, *_ = env.step({"attacker_0": np.array([1.0, 0.0]), "defender_0": np.zeros(2)})
    fastest = max(env.scenario.attacker_speed, env.scenario.defender_speed)
    assert obs["attacker_0"][2] == pytest.approx(env.scenario.attacker_speed / fastest)
    assert obs["attacker_0"][-1] == pytest.approx(0.9)
    # the defender sees the attacker's velocity in its opponents' block
    assert obs["defender_0"][-4] == pytest.approx(obs["attacker_0"][2])

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
from reachavoid_env.observations import ObservationConfig, observe

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


def test_nearest_players_are_every_players_blocks_sorted_and_padded():
    """``teammates`` / ``opponents``: against the full observation and the players'
    positions (a plain reference: sort each side's players by distance, in-game first)."""
    config = ObservationConfig(teammates=2, opponents=3)
    env = _env("paper_6v2", observation=config)
    assert env.observation_space("attacker_0").shape == (7 + 16 + 5 * 5 + 1,)
    observations, _ = env.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(120):
        state = env.game_state()
        near = observe(state, env.scenario.map, config, env.max_cycles)
        every = observe(state, env.scenario.map, ObservationConfig(), env.max_cycles)
        for name in observations:
            np.testing.assert_array_equal(observations[name], near[name])
        positions = np.concatenate([state.attacker_positions, state.defender_positions])
        active = np.concatenate([state.active_attackers,
                                 np.full(2, state.active_attackers.any())])
        for i, name in enumerate(env.possible_agents):
            side = range(6) if i < 6 else range(6, 8)
            mates = [k for k in side if k != i]
            foes = [k for k in range(8) if k not in side]
            others = mates + foes                    # the full layout's order
            blocks = every[name][23:-1].reshape(7, 5)
            got = near[name][23:-1].reshape(5, 5)
            for group, count, rows in ((mates, 2, got[:2]), (foes, 3, got[2:])):
                ranked = sorted(group, key=lambda k: (not active[k], np.hypot(
                    *(positions[k] - positions[i]))))[:count]
                expected = [blocks[others.index(k)] for k in ranked]
                expected += [np.zeros(5, np.float32)] * (count - len(ranked))
                np.testing.assert_array_equal(rows, np.array(expected))
            np.testing.assert_array_equal(near[name][:23], every[name][:23])
            assert near[name][-1] == every[name][-1]
        observations, *_ = env.step({name: rng.uniform(-1, 1, 2) for name in env.agents})
        if not env.agents:
            break
    assert env.game_state().step > 50
    # one teammate and one opponent: an attacker's blocks in a 2 vs 1 game, bit for bit
    two = _env("paper_2v1", observation={"teammates": 1, "opponents": 1})
    obs, _ = two.reset(seed=1)
    plain, _ = _env("paper_2v1").reset(seed=1)
    for name in ("attacker_0", "attacker_1"):
        np.testing.assert_array_equal(obs[name], plain[name])
    with pytest.raises(ValueError, match="observation.opponents: set teammates and opponents"):
        ObservationConfig(teammates=1)
    with pytest.raises(ValueError, match="observation.teammates: must be an integer"):
        ObservationConfig(teammates=-1, opponents=1)


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

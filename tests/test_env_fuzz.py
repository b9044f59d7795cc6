"""Hypothesis fuzz of the env: random (also over-long) actions never put a player in an
obstacle or out of the domain, observations stay in their space, departed players stay put."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from reachavoid_env import Box, Circle, GameMap, Polygon, ReachAvoidEnv, Scenario

FUZZ_MAP = GameMap(
    domain=(-1.0, 1.0, -0.8, 0.8),
    target=(Box((0.6, 0.1), (0.8, 0.3)), Circle((-0.7, 0.6), 0.1)),
    obstacles=(
        Box((-0.1, -0.8), (0.1, -0.3)),
        Box((0.3, -0.1), (0.302, 0.5)),                   # a thin wall
        Circle((-0.5, -0.3), 0.12),
        Polygon(((0.4, -0.7), (0.9, -0.7), (0.9, -0.2), (0.75, -0.2), (0.65, -0.55),
                 (0.55, -0.2), (0.4, -0.2))),            # concave
    ),
)
SCENARIO = Scenario(map=FUZZ_MAP, num_attackers=4, num_defenders=3, capture_radius=0.08,
                    max_steps=10_000)


@settings(max_examples=20, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    actions=arrays(np.float64, (40, 7, 2), elements=st.floats(-3.0, 3.0)),
    hold=st.integers(1, 15),
)
def test_fuzz_random_actions_keep_players_in_free_space(seed, actions, hold):
    env = ReachAvoidEnv(SCENARIO)
    env.reset(seed=seed)
    radius = SCENARIO.player_radius
    left_at: dict[int, np.ndarray] = {}
    for k in range(4 * len(actions)):
        if not env.agents:
            break
        chosen = actions[(k // hold) % len(actions)]
        step_actions = {name: chosen[env.possible_agents.index(name)].astype(np.float32)
                        for name in env.agents}
        obs, _, _, _, _ = env.step(step_actions)
        for name, value in obs.items():
            assert env.observation_space(name).contains(value)
        state = env.game_state()
        players = np.concatenate([state.attacker_positions, state.defender_positions])
        assert np.all(FUZZ_MAP.obstacle_signed_distance(players) >= 0.25 * radius)
        for i, active in enumerate(state.active_attackers):
            if not active:
                where = left_at.setdefault(i, state.attacker_positions[i].copy())
                assert np.array_equal(state.attacker_positions[i], where)

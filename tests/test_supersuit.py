"""SuperSuit + Stable-Baselines3 (rl extra): the vector env chain and the PPO example."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("supersuit")
pytest.importorskip("stable_baselines3")

from checks import records, run_example  # noqa: E402

import reachavoid_env  # noqa: E402
from reachavoid.training.views import make_attackers_parallel_env  # noqa: E402
from reachavoid_env.integrations.supersuit import sb3_vec_env  # noqa: E402

# attacker_0 runs east into the target (arrives on step 10); attacker_1 runs east while
# defender_0 runs north at it (captured on step 8). Slots: attacker_0, attacker_1, defender_0.
SCENARIO = reachavoid_env.builtin_scenario("paper_2v1").with_starts(
    [[0.55, 0.2], [0.3, -0.15]], [[0.3, -0.3]])
EAST_EAST_NORTH = np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 1.0]], dtype=np.float32)


def test_episode_ends_on_the_step_the_game_ends_and_dead_slots_are_black():
    envs = sb3_vec_env(reachavoid_env.parallel_env(scenario=SCENARIO), copies=2)
    assert envs.num_envs == 6
    start = envs.reset()
    actions = np.tile(EAST_EAST_NORTH, (2, 1))
    rewards, dones, observations = [], [], []
    for _ in range(10):
        obs, reward, done, infos = envs.step(actions)
        rewards.append(reward[:3])
        dones.append(done[:3])
        observations.append(obs[:3])
    rewards, dones = np.array(rewards), np.array(dones)
    assert not dones[:9].any() and dones[9].all()       # the game ends on step 10
    assert rewards[7].tolist() == [0.0, -1.0, 1.0]      # step 8: attacker_1 is captured
    assert rewards[9].tolist() == [1.0, 0.0, -1.0]      # step 10: attacker_0 arrives
    assert rewards.sum() == rewards[7].sum() + rewards[9].sum()
    assert not observations[8][1].any()                 # attacker_1's slot is zeroed
    np.testing.assert_array_equal(observations[9], start[:3])   # auto-reset
    assert infos[0]["TimeLimit.truncated"] is False      # a termination, not a time-out
    assert infos[0]["terminal_observation"].shape == (34,)
    # the auto-reset's infos replace the last step's; "final_info" keeps them
    assert infos[0]["status"] == 0 and infos[0]["arrived"] == 0
    assert infos[0]["final_info"] == {"captured": 1, "arrived": 1, "status": 2, "captured_by": -1}
    assert infos[2]["final_info"] == {"captured": 1, "arrived": 1}
    assert "final_info" not in infos[1]                 # attacker_1 left the game on step 8


def test_time_out_is_marked_for_bootstrapping():
    envs = sb3_vec_env(reachavoid_env.parallel_env(scenario=SCENARIO, max_cycles=3))
    envs.reset()
    for _ in range(3):
        _, _, done, infos = envs.step(np.zeros((3, 2), dtype=np.float32))
    assert done.all()
    assert [info["TimeLimit.truncated"] for info in infos] == [True, True, True]


def test_seed_seeds_the_next_reset_of_every_copy():
    def first_steps(seed):
        envs = sb3_vec_env(make_attackers_parallel_env(
            reachavoid_env.builtin_scenario("paper_6v2").with_players(3, 2),
            defenders="greedy"), copies=2)
        assert envs.seed(seed) == [seed, seed + 1]
        record = [envs.reset()]
        for _ in range(5):
            record.append(envs.step(np.full((6, 2), 0.5, dtype=np.float32))[0])
        return np.array(record)

    one, again, other = first_steps(3), first_steps(3), first_steps(4)
    np.testing.assert_array_equal(one, again)
    assert not np.array_equal(one[0, :3], one[0, 3:])   # the copies differ
    assert not np.array_equal(one[0], other[0])


def test_ppo_learns_on_the_vectorised_attackers_against_hj_defenders():
    rows = records(run_example("sb3_supersuit_ppo", "--scenario", "paper_2v1", "--defenders",
                               "hj", "--grid1", "25", "--grid2", "13", "--timesteps", "512",
                               "--n-steps", "64"))
    assert rows[-1]["timesteps"] >= 512 and rows[-1]["slots"] == 2 * 2  # 2 copies x 2 attackers
    trained = [row for row in rows if "train/loss" in row]
    assert trained
    for row in trained:
        for key in ("train/loss", "train/value_loss", "train/policy_gradient_loss"):
            assert math.isfinite(row[key])
    episodes = [row["rollout/ep_rew_mean"] for row in rows if "rollout/ep_rew_mean" in row]
    assert episodes and all(math.isfinite(value) for value in episodes)

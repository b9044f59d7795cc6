"""The vector env's training views: copy k is the single-attacker env seeded with seed + k,
the batched scripted sides act as the single-game policies, and the SB3 and Gymnasium
adapters run."""

from __future__ import annotations

import numpy as np
import pytest

from policies.training import make_attacker_env, make_attacker_vector_env, make_attackers_vector_env
from reachavoid_env.integrations.vector import GymVectorEnv, sb3_vec_env


@pytest.mark.parametrize("repeat", [1, 3])
def test_copy_k_is_the_single_attacker_env(repeat):
    copies, seed = 5, 11
    kwargs = dict(scenario="paper_2v1", defenders="greedy", teammates="shortest-path",
                  attacker=1, action_repeat=repeat, timeout_reward=-1.0, shaping=0.5,
                  max_cycles=150)
    view = make_attacker_vector_env(num_envs=copies, starts="random", **kwargs)
    singles = [make_attacker_env(starts="random", **kwargs) for _ in range(copies)]
    table, _ = view.reset(seed=seed)
    seen = [env.reset(seed=seed + k)[0] for k, env in enumerate(singles)]
    rng = np.random.default_rng(0)
    episodes = 0
    for _ in range(300 // repeat):
        for k in range(copies):
            np.testing.assert_array_equal(table[k, 0], seen[k])
        actions = rng.uniform(-1, 1, (copies, 1, 2))
        table, rewards, terminated, truncated, infos = view.step(actions)
        for k, env in enumerate(singles):
            obs, reward, term, trunc, info = env.step(actions[k, 0])
            assert rewards[k, 0] == pytest.approx(reward, abs=1e-12)
            assert (terminated[k, 0], truncated[k, 0]) == (term, trunc)
            assert infos["episode_over"][k] == (term or trunc)
            if term or trunc:
                np.testing.assert_array_equal(infos["final_observation"][k, 0], obs)
                assert infos["arrived"][k, 0] == info["is_success"]
                obs, _ = env.reset()
                episodes += 1
            seen[k] = obs
    assert episodes >= copies


def test_sb3_trains_the_shared_attacker_on_the_vector_env():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor

    view = make_attackers_vector_env("paper_6v2", defenders="greedy", num_envs=4,
                                     action_repeat=5, max_cycles=100)
    envs = VecMonitor(sb3_vec_env(view))
    assert envs.num_envs == 4 * 6
    model = PPO("MlpPolicy", envs, n_steps=16, batch_size=96, n_epochs=1, seed=0,
                device="cpu")
    model.learn(4 * 6 * 32)
    assert model.num_timesteps >= 4 * 6 * 32
    assert len(model.ep_info_buffer) >= 4 * 6      # every slot finished an episode


def test_gymnasium_vector_api():
    view = make_attacker_vector_env("paper_1v1", defenders="greedy", num_envs=3,
                                    action_repeat=10)
    envs = GymVectorEnv(view)
    obs, _ = envs.reset(seed=0)
    assert obs.shape == (3, envs.single_observation_space.shape[0])
    assert envs.observation_space.contains(obs)
    ended = 0
    for _ in range(60):
        obs, rewards, terminations, truncations, infos = envs.step(envs.action_space.sample())
        ended += int((terminations | truncations).sum())
        if "_final_obs" in infos:
            assert (infos["_final_obs"] == (terminations | truncations)).all()
    assert ended >= 3

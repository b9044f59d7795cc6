"""The vector env's training views: copy k is the single-attacker env seeded with seed + k,
the batched scripted sides act as the single-game policies, and the SB3 and Gymnasium
adapters run."""

from __future__ import annotations

import numpy as np
import pytest

from reachavoid.training.views import (
    make_attacker_env,
    make_attacker_vector_env,
    make_attackers_parallel_env,
    make_attackers_vector_env,
)
from reachavoid_env.integrations.vector import GymVectorEnv, sb3_vec_env


@pytest.mark.parametrize(("repeat", "defenders"), [
    (1, "greedy"), (3, "greedy"), (3, "hj")])
def test_copy_k_is_the_single_attacker_env(repeat, defenders):
    """The batched defenders (``hj``, ``greedy``) and the per-copy teammates make copy k of
    the vector view the single-attacker env seeded with seed + k."""
    copies, seed = 5, 11
    options = {"grid1": 25, "grid2": 15} if defenders == "hj" else None
    kwargs = dict(scenario="paper_2v1", defenders=defenders, defender_options=options,
                  teammates="shortest-path", attacker=1, action_repeat=repeat,
                  timeout_reward=-1.0, shaping=0.5, max_cycles=150)
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


def test_team_reward_adds_the_teammates_outcomes():
    """With ``team_reward = w`` each attacker in play gets w times the other attackers'
    +1 / -1 of the step on top of its own reward, in the vector view as in copy k's
    ``AttackerParallelEnv``."""
    copies, seed, weight = 4, 3, 0.5
    kwargs = dict(defenders="greedy", action_repeat=1, timeout_reward=-1.0, shaping=0.5,
                  max_cycles=150, starts="random")
    alone = make_attackers_vector_env("paper_6v2", num_envs=copies, **kwargs)
    team = make_attackers_vector_env("paper_6v2", num_envs=copies, team_reward=weight, **kwargs)
    singles = [make_attackers_parallel_env("paper_6v2", team_reward=weight, **kwargs)
               for _ in range(copies)]
    alone.reset(seed=seed)
    _, infos = team.reset(seed=seed)
    for k, env in enumerate(singles):
        env.reset(seed=seed + k)
    rng = np.random.default_rng(1)
    shared = 0
    for _ in range(300):
        playing = infos["active"]
        actions = rng.uniform(-1, 1, (copies, 6, 2))
        _, own, *_ = alone.step(actions)
        _, rewards, terminated, _, infos = team.step(actions)
        outcomes = np.where(terminated, np.where(infos["arrived"], 1.0, -1.0), 0.0)
        others = outcomes.sum(axis=1, keepdims=True) - outcomes
        np.testing.assert_allclose(rewards, own + np.where(playing, weight * others, 0.0),
                                   atol=1e-12)
        shared += int((playing & (others != 0)).sum())
        for k, env in enumerate(singles):
            names = list(env.agents)
            _, single, *_ = env.step({n: actions[k, int(n.split("_")[1])] for n in names})
            for name in names:
                assert single[name] == pytest.approx(rewards[k, int(name.split("_")[1])],
                                                     abs=1e-12)
            if not env.agents:
                env.reset()
    assert shared > 20


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

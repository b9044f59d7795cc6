"""RLlib on the attacker-only env (``rllib`` extra, in a virtual environment of its own:
every ``ray[rllib]`` release pins Gymnasium exactly): PPO with one policy shared by every
attacker, the defenders scripted inside the env.

    from reachavoid.training.rllib import ppo_config, train

    config = ppo_config("paper_6v2", defenders="greedy", train_batch_size=2000)
    for result in train(config, iterations=5):
        print(result["env_runners"].get("episode_return_mean"))

The env reaches RLlib through its PettingZoo wrapper, ``ParallelPettingZooEnv``, registered
as ``ENV_NAME`` (``env_creator``) when ``ppo_config`` makes a config. Ray is imported here
alone (``examples/rllib_config.py`` runs this).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv
from ray.tune.registry import register_env

from reachavoid.training.views import make_attackers_parallel_env

ENV_NAME = "reachavoid_attackers"
"""The name the attacker-only env is registered under with Ray's env registry."""

POLICY = "attacker"
"""The one policy every attacker maps to."""


def env_creator(config: dict[str, Any]) -> ParallelPettingZooEnv:
    """RLlib's env factory of ``ENV_NAME``: ``config`` holds
    ``make_attackers_parallel_env`` keywords."""
    return ParallelPettingZooEnv(make_attackers_parallel_env(**config))


def ppo_config(scenario: str = "paper_6v2", defenders: str = "hj",
               defender_options: dict[str, Any] | None = None, action_repeat: int = 10,
               shaping: float = 1.0, train_batch_size: int = 2000) -> PPOConfig:
    """PPO on the attackers of ``scenario`` against scripted ``defenders`` (with their
    ``defender_options``; the envs' ``action_repeat`` and ``shaping``), sampled in the
    driver (no env runner processes); every attacker maps to the policy ``POLICY``
    (parameter sharing: the observation starts with the own position). Registers
    ``ENV_NAME`` first."""
    register_env(ENV_NAME, env_creator)
    env_config = {"scenario": scenario, "defenders": defenders,
                  "defender_options": defender_options, "action_repeat": action_repeat,
                  "shaping": shaping}
    return (
        PPOConfig()
        .environment(ENV_NAME, env_config=env_config)
        .env_runners(num_env_runners=0)
        .multi_agent(policies={POLICY},
                     policy_mapping_fn=lambda agent_id, episode, **kwargs: POLICY)
        .training(train_batch_size=train_batch_size,
                  minibatch_size=min(256, train_batch_size), num_epochs=5)
    )


def train(config: PPOConfig, iterations: int) -> Iterator[dict[str, Any]]:
    """Builds the algorithm of ``config`` and yields the result dict of each of its
    ``iterations`` training iterations (``result["env_runners"]``: the sampling,
    ``result["learners"][POLICY]``: the losses); the algorithm is stopped when the loop
    ends, is left or fails."""
    algo = config.build_algo()
    try:
        for _ in range(iterations):
            yield algo.train()
    finally:
        algo.stop()

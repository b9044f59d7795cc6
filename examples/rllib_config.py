"""The attacker-only env under RLlib: PPO with one policy shared by all attackers.

Needs the ``rllib`` extra in a virtual environment of its own (every ``ray[rllib]``
release pins Gymnasium exactly): ``pip install -e '.[rllib]'``. The env reaches RLlib
through its PettingZoo wrapper, ``ParallelPettingZooEnv``; the defenders are scripted
inside the env:

    python examples/rllib_config.py --scenario paper_6v2 --defenders greedy --iterations 5

``build_config`` is the part to reuse.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv
from ray.tune.registry import register_env

from reachavoid.training.flags import add_defender_arguments, defender_options
from reachavoid.training.views import make_attackers_parallel_env

ENV_NAME = "reachavoid_attackers"


def env_creator(config: dict[str, Any]) -> ParallelPettingZooEnv:
    """RLlib's env factory: ``config`` holds ``make_attackers_parallel_env`` keywords."""
    return ParallelPettingZooEnv(make_attackers_parallel_env(**config))


register_env(ENV_NAME, env_creator)


def build_config(scenario: str = "paper_6v2", defenders: str = "hj",
                 defender_options: dict[str, Any] | None = None, action_repeat: int = 10,
                 shaping: float = 1.0, train_batch_size: int = 2000) -> PPOConfig:
    """PPO on the attackers of ``scenario``; every attacker maps to the policy
    ``"attacker"`` (parameter sharing: the observation starts with the own position)."""
    env_config = {"scenario": scenario, "defenders": defenders,
                  "defender_options": defender_options, "action_repeat": action_repeat,
                  "shaping": shaping}
    return (
        PPOConfig()
        .environment(ENV_NAME, env_config=env_config)
        .env_runners(num_env_runners=0)
        .multi_agent(policies={"attacker"},
                     policy_mapping_fn=lambda agent_id, episode, **kwargs: "attacker")
        .training(train_batch_size=train_batch_size,
                  minibatch_size=min(256, train_batch_size), num_epochs=5)
    )


def main(argv: Sequence[str] | None = None) -> list[dict[str, Any]]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    add_defender_arguments(parser, scenario="paper_6v2")
    parser.add_argument("--iterations", type=int, default=5)
    parser.add_argument("--batch", type=int, default=2000, help="train batch (agent steps)")
    args = parser.parse_args(argv)
    options = defender_options(args)
    algo = build_config(args.scenario, args.defenders, options,
                        train_batch_size=args.batch).build_algo()
    results = []
    try:
        for iteration in range(args.iterations):
            result = algo.train()
            runners = result.get("env_runners", {})
            print(f"iteration {iteration}: episode return mean "
                  f"{runners.get('episode_return_mean', float('nan')):.3f}, "
                  f"{runners.get('num_env_steps_sampled_lifetime', 0)} agent steps")
            results.append(result)
    finally:
        algo.stop()
    return results


if __name__ == "__main__":
    main()

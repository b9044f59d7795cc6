"""The attacker-only env under RLlib: PPO with one policy shared by all attackers.

Needs the ``rllib`` extra in a virtual environment of its own (every ``ray[rllib]``
release pins Gymnasium exactly): ``pip install -e '.[rllib]'``. The env reaches RLlib
through its PettingZoo wrapper, ``ParallelPettingZooEnv``; the defenders are scripted
inside the env:

    python examples/rllib_config.py --scenario paper_6v2 --defenders greedy --iterations 5

Prints each iteration's mean episode return and the agent steps sampled so far.
``reachavoid.training.rllib`` (``ppo_config``, ``train``) is the part to reuse.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from reachavoid.training.flags import DefenderFields, config_parser, defender_options
from reachavoid.training.rllib import ppo_config, train


@dataclass
class Config(DefenderFields):
    iterations: int = 5         # PPO iterations
    batch: int = field(default=2000, metadata={"help": "train batch (agent steps)"})


def main(config: Config) -> None:
    ppo = ppo_config(config.scenario, config.defenders, defender_options(config),
                     train_batch_size=config.batch)
    for iteration, result in enumerate(train(ppo, config.iterations)):
        runners = result.get("env_runners", {})
        print(f"iteration {iteration}: episode return mean "
              f"{runners.get('episode_return_mean', float('nan')):.3f}, "
              f"{runners.get('num_env_steps_sampled_lifetime', 0)} agent steps", flush=True)


if __name__ == "__main__":
    parser = config_parser(Config, __doc__.split("\n\n")[0])
    main(Config(**vars(parser.parse_args())))

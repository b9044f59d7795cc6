"""MAPPO for the attackers with TorchRL: one actor shared by every attacker, a centralised
critic, and the agent mask for attackers that have left the game.

Needs the ``rl`` extra (torch, torchrl). The attackers learn against scripted defenders
(``AttackerParallelEnv``); ``reachavoid_env.integrations.torchrl.torchrl_env`` makes the
TorchRL env (the ``"attacker"`` group, a ``mask`` per agent, the episode done when every
attacker is):

    python examples/torchrl_mappo.py --scenario paper_2v1 --defenders hj --iterations 20

A captured or arrived attacker stays in the group with ``mask`` False, zero observation
and reward, and ``done`` True; its steps are left out of the loss
(``reachavoid.training.mappo.ppo_epochs``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import torch
from tensordict import TensorDictBase
from tensordict.nn import NormalParamExtractor, TensorDictModule
from torch import nn
from torchrl.collectors import Collector
from torchrl.envs import EnvBase
from torchrl.modules import MultiAgentMLP, ProbabilisticActor, TanhNormal

from reachavoid.training.flags import (
    DefenderFields,
    RewardFields,
    attackers_from_args,
    config_parser,
    scenario_field,
)
from reachavoid.training.mappo import LOSSES, ppo_epochs, ppo_loss
from reachavoid_env import AttackerStatus
from reachavoid_env.integrations.torchrl import torchrl_env

GROUP = "attacker"


@dataclass
class Config(RewardFields, DefenderFields):
    scenario: str = scenario_field("paper_2v1")
    iterations: int = 20        # collections, each followed by PPO epochs
    frames: int = field(default=2000, metadata={"help": "env steps per iteration"})
    epochs: int = 4             # passes over each iteration's batch
    minibatch: int = 500        # env steps per gradient step
    lr: float = 3e-4            # Adam's learning rate
    seed: int = 0               # torch's and the env's seed


def build_modules(env: EnvBase) -> tuple[ProbabilisticActor, TensorDictModule]:
    """The shared actor (own observation -> tanh-normal action) and the centralised critic
    (every attacker's observation -> one value per attacker)."""
    n_agents, obs_size = env.observation_spec[GROUP, "observation"].shape
    action_spec = env.full_action_spec[GROUP, "action"]
    actor_net = nn.Sequential(
        MultiAgentMLP(obs_size, 2 * action_spec.shape[-1], n_agents, centralized=False,
                      share_params=True, depth=2, num_cells=64),
        NormalParamExtractor())
    actor = ProbabilisticActor(
        TensorDictModule(actor_net, in_keys=[(GROUP, "observation")],
                         out_keys=[(GROUP, "loc"), (GROUP, "scale")]),
        in_keys=[(GROUP, "loc"), (GROUP, "scale")], out_keys=[(GROUP, "action")],
        spec=action_spec, distribution_class=TanhNormal,
        distribution_kwargs={"low": action_spec.space.low, "high": action_spec.space.high},
        return_log_prob=True, log_prob_key=(GROUP, "action_log_prob"))
    critic = TensorDictModule(
        MultiAgentMLP(obs_size, 1, n_agents, centralized=True, share_params=True, depth=2,
                      num_cells=64),
        in_keys=[(GROUP, "observation")], out_keys=[(GROUP, "state_value")])
    return actor, critic


def outcomes(batch: TensorDictBase) -> dict[str, int]:
    """Attackers that arrived or were captured during ``batch`` (from the numeric infos)."""
    left = batch[GROUP, "mask"] & batch["next", GROUP, "done"].squeeze(-1)
    status = batch["next", GROUP, "info", "status"][left]
    return {"arrived": int((status == AttackerStatus.ARRIVED.code).sum()),
            "captured": int((status == AttackerStatus.CAPTURED.code).sum())}


def main(config: Config) -> None:
    """``config.iterations`` MAPPO iterations; prints a record per iteration (mean losses
    over the live agents' steps, the batch's live-agent reward sum, arrivals and captures)."""
    torch.manual_seed(config.seed)
    torch.set_num_threads(1)    # tiny networks: more threads only contend for the cores
    # the flags' helper reads the defender and reward fields of the config
    env = torchrl_env(attackers_from_args(config), seed=config.seed)
    actor, critic = build_modules(env)
    loss_module = ppo_loss(actor, critic, GROUP, entropy=1e-3)
    optimiser = torch.optim.Adam(loss_module.parameters(), lr=config.lr)
    collector = Collector(env, actor, frames_per_batch=config.frames,
                          total_frames=config.frames * config.iterations)
    history = []
    try:
        for iteration, batch in enumerate(collector):
            losses = ppo_epochs(loss_module, optimiser, batch, GROUP, config.epochs,
                                config.minibatch)
            live_reward = batch["next", GROUP, "reward"][batch[GROUP, "mask"]]
            record = {"iteration": iteration, "frames": batch.numel(),
                      "reward_sum": float(live_reward.sum())}
            record |= losses | outcomes(batch)
            history.append(record)
            print(", ".join(f"{key} {value:.4g}" if isinstance(value, float)
                            else f"{key} {value}" for key, value in record.items()), flush=True)
    finally:
        collector.shutdown()
        env.close()
    assert all(math.isfinite(record[key]) for record in history for key in LOSSES)


if __name__ == "__main__":
    parser = config_parser(Config, __doc__.split("\n\n")[0])
    main(Config(**vars(parser.parse_args())))

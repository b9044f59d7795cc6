"""Multi-agent PPO with TorchRL on ReachAvoid-v2, as TorchRL's multi-agent PPO tutorial:
``PettingZooWrapper`` with every agent in one group (``--groups one``: attackers and
defenders share one actor and one critic) or a group per team (``--groups teams``: each
team its own actor and critic, trained side by side).

``remove_agents=False`` keeps every agent in its group for the whole episode, so no agent
mask is needed; every agent's infos hold the same numeric keys from ``reset`` on, which
TorchRL reads into its specs.

    python examples/torchrl_v2.py --groups teams --iterations 50

Prints each iteration's reward seen per group, then ``done``.
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass

import torch
from tensordict.nn import NormalParamExtractor, TensorDictModule, TensorDictSequential
from torch import nn
from torchrl.collectors import Collector
from torchrl.envs.libs.pettingzoo import PettingZooWrapper
from torchrl.envs.utils import MarlGroupMapType
from torchrl.modules import MultiAgentMLP, ProbabilisticActor, TanhNormal
from torchrl.objectives import ClipPPOLoss, ValueEstimators

from reachavoid_env import reach_avoid_v2


@dataclass
class Config:
    scenario: str = "paper_2v1"
    reward: str = "shaped"
    groups: str = "one"        # "one": every agent in one group; "teams": a group per team
    iterations: int = 50
    frames: int = 2000         # decisions per iteration
    epochs: int = 4
    minibatch: int = 500
    lr: float = 3e-4
    seed: int = 0


def modules(env: PettingZooWrapper, group: str) -> tuple[ProbabilisticActor, TensorDictModule]:
    """A shared actor and a centralised critic for ``group``."""
    n_agents, size = env.observation_spec[group, "observation"].shape
    spec = env.full_action_spec[group, "action"]
    actor = ProbabilisticActor(
        TensorDictModule(nn.Sequential(MultiAgentMLP(size, 2 * spec.shape[-1], n_agents,
                                                     centralized=False, share_params=True,
                                                     depth=2, num_cells=64),
                                       NormalParamExtractor()),
                         in_keys=[(group, "observation")],
                         out_keys=[(group, "loc"), (group, "scale")]),
        in_keys=[(group, "loc"), (group, "scale")], out_keys=[(group, "action")], spec=spec,
        distribution_class=TanhNormal,
        distribution_kwargs={"low": spec.space.low, "high": spec.space.high},
        return_log_prob=True, log_prob_key=(group, "action_log_prob"))
    critic = TensorDictModule(MultiAgentMLP(size, 1, n_agents, centralized=True,
                                            share_params=True, depth=2, num_cells=64),
                              in_keys=[(group, "observation")],
                              out_keys=[(group, "state_value")])
    return actor, critic


def main(c: Config) -> None:
    torch.manual_seed(c.seed)
    torch.set_num_threads(1)
    game = reach_avoid_v2.parallel_env(scenario=c.scenario, reward=c.reward,
                                       remove_agents=False)
    group_map = MarlGroupMapType.ALL_IN_ONE_GROUP if c.groups == "one" else {
        team: [a for a in game.possible_agents if a.startswith(team)]
        for team in ("attacker", "defender")}
    env = PettingZooWrapper(game, group_map=group_map, use_mask=False, done_on_any=False,
                            seed=c.seed)
    groups = list(env.group_map)
    losses, actors = {}, []
    for group in groups:
        actor, critic = modules(env, group)
        loss = ClipPPOLoss(actor, critic, clip_epsilon=0.2, entropy_coeff=1e-3)
        loss.set_keys(reward=(group, "reward"), action=(group, "action"),
                      value=(group, "state_value"), done=(group, "done"),
                      terminated=(group, "terminated"),
                      sample_log_prob=(group, "action_log_prob"))
        loss.make_value_estimator(ValueEstimators.GAE, gamma=0.99, lmbda=0.95)
        losses[group] = (loss, torch.optim.Adam(loss.parameters(), lr=c.lr))
        actors.append(actor)
    collector = Collector(env, TensorDictSequential(*actors), frames_per_batch=c.frames,
                          total_frames=c.frames * c.iterations)
    for iteration, batch in enumerate(collector):
        seen = {}
        for group, (loss, optimiser) in losses.items():
            seen[group] = float(batch["next", group, "reward"].abs().sum())
            with torch.no_grad():
                loss.value_estimator(batch, params=loss.critic_network_params,
                                     target_params=loss.target_critic_network_params)
            flat = batch.reshape(-1)
            for _ in range(c.epochs):
                for rows in torch.randperm(flat.shape[0]).split(c.minibatch):
                    terms = loss(flat[rows])
                    total = terms["loss_objective"] + terms["loss_critic"] \
                        + terms["loss_entropy"]
                    optimiser.zero_grad()
                    total.backward()
                    nn.utils.clip_grad_norm_(loss.parameters(), 1.0)
                    optimiser.step()
        print(f"iteration {iteration} reward seen " + ", ".join(
            f"{group} {value:.4g}" for group, value in seen.items()), flush=True)
    collector.shutdown()
    env.close()
    print("done")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    for field in dataclasses.fields(Config):
        parser.add_argument(f"--{field.name.replace('_', '-')}", type=type(field.default),
                            default=field.default)
    main(Config(**vars(parser.parse_args())))

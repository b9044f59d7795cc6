"""A CleanRL-style PPO (one file, discrete actions) on ReachAvoid-v2: MPE2's discrete
actions (``continuous_actions=False``: stay or 8 full-speed headings), every agent a slot
of SuperSuit's vector env, one shared policy, as CleanRL's PettingZoo scripts do.

    python examples/cleanrl_ppo_discrete.py --total-timesteps 500000

Prints each update's mean absolute reward per step, then ``done``.
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass

import numpy as np
import supersuit as ss
import torch
from torch import nn
from torch.distributions import Categorical

from reachavoid_env import reach_avoid_v2


@dataclass
class Config:
    scenario: str = "paper_2v1"
    reward: str = "shaped"
    copies: int = 4
    total_timesteps: int = 500_000
    num_steps: int = 128        # rollout length per slot
    learning_rate: float = 2.5e-4
    gamma: float = 0.99
    gae_lambda: float = 0.95
    update_epochs: int = 4
    minibatches: int = 4
    clip_coef: float = 0.2
    ent_coef: float = 0.01
    seed: int = 0


class Agent(nn.Module):
    def __init__(self, obs_size: int, actions: int) -> None:
        super().__init__()
        self.critic = nn.Sequential(nn.Linear(obs_size, 64), nn.Tanh(), nn.Linear(64, 64),
                                    nn.Tanh(), nn.Linear(64, 1))
        self.actor = nn.Sequential(nn.Linear(obs_size, 64), nn.Tanh(), nn.Linear(64, 64),
                                   nn.Tanh(), nn.Linear(64, actions))

    def act(self, x: torch.Tensor, action: torch.Tensor | None = None) -> tuple:
        dist = Categorical(logits=self.actor(x))
        action = dist.sample() if action is None else action
        return action, dist.log_prob(action), dist.entropy(), self.critic(x).squeeze(-1)


def main(c: Config) -> None:
    torch.manual_seed(c.seed)
    torch.set_num_threads(1)
    env = reach_avoid_v2.parallel_env(scenario=c.scenario, reward=c.reward, gamma=c.gamma,
                                      continuous_actions=False, remove_agents=False)
    envs = ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(env), c.copies,
                                 num_cpus=0, base_class="gymnasium")
    n = envs.num_envs
    agent = Agent(envs.observation_space.shape[0], envs.action_space.n)
    optimizer = torch.optim.Adam(agent.parameters(), lr=c.learning_rate, eps=1e-5)
    obs_buf = torch.zeros((c.num_steps, n, envs.observation_space.shape[0]))
    act_buf, logp_buf, rew_buf, done_buf, val_buf = (torch.zeros((c.num_steps, n))
                                                     for _ in range(5))
    obs = torch.tensor(envs.reset(seed=c.seed)[0])
    done = torch.zeros(n)
    for update in range(c.total_timesteps // (c.num_steps * n)):
        for t in range(c.num_steps):
            obs_buf[t], done_buf[t] = obs, done
            with torch.no_grad():
                action, logp, _, value = agent.act(obs)
            val_buf[t], act_buf[t], logp_buf[t] = value, action, logp
            obs, reward, term, trunc, _ = envs.step(action.numpy())
            obs, rew_buf[t] = torch.tensor(obs), torch.tensor(reward)
            done = torch.tensor(np.logical_or(term, trunc), dtype=torch.float32)
        with torch.no_grad():   # generalised advantage estimation
            advantages, last = torch.zeros_like(rew_buf), 0.0
            next_value = agent.act(obs)[3]
            for t in reversed(range(c.num_steps)):
                nonterminal = 1.0 - (done if t == c.num_steps - 1 else done_buf[t + 1])
                following = next_value if t == c.num_steps - 1 else val_buf[t + 1]
                delta = rew_buf[t] + c.gamma * following * nonterminal - val_buf[t]
                advantages[t] = last = delta + c.gamma * c.gae_lambda * nonterminal * last
            returns = advantages + val_buf
        b_obs, b_act, b_logp = obs_buf.flatten(0, 1), act_buf.flatten(), logp_buf.flatten()
        b_adv, b_ret = advantages.flatten(), returns.flatten()
        size = len(b_obs) // c.minibatches
        for _ in range(c.update_epochs):
            for idx in torch.randperm(len(b_obs)).split(size):
                _, logp, entropy, value = agent.act(b_obs[idx], b_act[idx].long())
                ratio = (logp - b_logp[idx]).exp()
                adv = (b_adv[idx] - b_adv[idx].mean()) / (b_adv[idx].std() + 1e-8)
                pg_loss = torch.max(-adv * ratio, -adv * ratio.clamp(1 - c.clip_coef,
                                                                      1 + c.clip_coef)).mean()
                loss = pg_loss + 0.5 * ((value - b_ret[idx]) ** 2).mean() \
                    - c.ent_coef * entropy.mean()
                optimizer.zero_grad()
                loss.backward()
                nn.utils.clip_grad_norm_(agent.parameters(), 0.5)
                optimizer.step()
        print(f"update {update} mean |reward| {rew_buf.abs().mean():.4g} "
              f"reward seen {rew_buf.abs().sum():.4g}", flush=True)
    envs.close()
    print("done")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    for field in dataclasses.fields(Config):
        parser.add_argument(f"--{field.name.replace('_', '-')}", type=type(field.default),
                            default=field.default)
    main(Config(**vars(parser.parse_args())))

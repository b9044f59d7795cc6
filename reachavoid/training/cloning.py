"""The team recipe's warm start: behaviour cloning of a scripted team and DAgger rounds
(``--imitate-steps``, ``--dagger-rounds``)."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from stable_baselines3 import PPO
from tqdm import tqdm

from reachavoid.training.config import Maps, game
from reachavoid.training.flags import reward_options
from reachavoid.training.teams import Team, learned_team, scripted_team
from reachavoid_env import AttackerStatus

IMITATION_SEED_OFFSET = 1_000_000
"""The cloned games start from seed ``--seed`` + this (the evaluation uses 0, 1, ...)."""


@dataclass(frozen=True)
class Demonstrations:
    """The scripted team in the training env: one row per live attacker and env step."""

    observations: np.ndarray    # (K, observation size) float32, what the learner would see
    actions: np.ndarray         # (K, 2) float32, the script's action, held for the env step
    returns: np.ndarray         # (K,) float32, discounted shaped return from that step
    episodes: int
    arrival_rate: float         # fraction of the attackers of those episodes that arrived

    def __add__(self, other: Demonstrations) -> Demonstrations:
        """Both sets' rows (the aggregate DAgger fits); the arrival rate over both."""
        episodes = self.episodes + other.episodes
        return Demonstrations(
            *(np.concatenate([getattr(self, key), getattr(other, key)])
              for key in ("observations", "actions", "returns")), episodes,
            (self.arrival_rate * self.episodes + other.arrival_rate * other.episodes)
            / episodes)


def discounted(rewards: Sequence[float], gamma: float) -> list[float]:
    """Returns-to-go ``G_t = r_t + gamma G_{t+1}`` of one attacker's rewards."""
    returns, total = [], 0.0
    for reward in reversed(rewards):
        total = reward + gamma * total
        returns.append(total)
    return returns[::-1]


def collect_demonstrations(args: argparse.Namespace, maps: Maps, gamma: float,
                           player: Team | None = None, steps: int | None = None,
                           seed: int | None = None, desc: str = "cloning") -> Demonstrations:
    """``steps`` (default ``args.imitate_steps``) rows of ``player`` (default: the
    ``--imitate-from`` team itself) playing whole episodes of the training env, from
    ``reset(seed=seed)`` (default ``--seed`` + ``IMITATION_SEED_OFFSET``) and then the env's
    random stream; the last episode is finished and its rows cut at the count. Each row is
    labelled with the ``--imitate-from`` team's action in that state, whoever plays, and
    with the discounted return of the rewards that followed it in the game played."""
    steps = args.imitate_steps if steps is None else steps
    env = game(args, maps, **reward_options(args))
    teacher = scripted_team(args.imitate_from, args, maps)
    observations: list[np.ndarray] = []
    actions: list[np.ndarray] = []
    returns: list[float] = []
    arrived = episodes = 0
    progress = tqdm(total=steps, desc=desc, unit="step", disable=not sys.stderr.isatty())
    next_seed: int | None = args.seed + IMITATION_SEED_OFFSET if seed is None else seed
    while len(actions) < steps:
        seen, _ = env.reset(seed=next_seed)
        next_seed = None        # later episodes continue the env's random stream
        teacher.reset(env)
        if player is not None:
            player.reset(env)
        played: dict[str, list[tuple[np.ndarray, np.ndarray, float]]] = {
            name: [] for name in env.agents}
        while env.agents:
            labels = teacher.act(seen, env)
            after, rewards, *_ = env.step(labels if player is None else player.act(seen, env))
            for name, label in labels.items():
                played[name].append((seen[name], label, rewards[name]))
            progress.update(len(labels))
            seen = after
        for steps_of_one in played.values():
            seen_by_step, chosen_by_step, rewards_by_step = zip(*steps_of_one, strict=True)
            observations.extend(seen_by_step)
            actions.extend(chosen_by_step)
            returns.extend(discounted(rewards_by_step, gamma))
        arrived += env.game_state().attacker_status.count(AttackerStatus.ARRIVED)
        episodes += 1
    progress.close()
    env.close()
    return Demonstrations(np.asarray(observations[:steps], dtype=np.float32),
                          np.asarray(actions[:steps], dtype=np.float32),
                          np.asarray(returns, dtype=np.float32)[:steps], episodes,
                          arrived / (episodes * maps[0].num_attackers))


def imitate(model: PPO, demonstrations: Demonstrations, epochs: int, batch_size: int,
            learning_rate: float, log_std: float) -> dict[str, float]:
    """Fit ``model``'s action mean to the script's actions and its value to the returns
    (mean-squared error, Adam, minibatches of ``batch_size``), then set the log std of its
    actions to ``log_std``. Returns the last epoch's mean losses."""
    policy = model.policy
    observations = torch.as_tensor(demonstrations.observations)
    actions = torch.as_tensor(demonstrations.actions)
    returns = torch.as_tensor(demonstrations.returns)
    optimiser = torch.optim.Adam(policy.parameters(), lr=learning_rate)
    generator = torch.Generator().manual_seed(model.seed or 0)
    policy.set_training_mode(True)
    for _ in range(epochs):
        action_losses, value_losses = [], []
        for rows in torch.randperm(len(actions), generator=generator).split(batch_size):
            means = policy.get_distribution(observations[rows]).distribution.mean
            values = policy.predict_values(observations[rows]).squeeze(-1)
            action_loss = torch.nn.functional.mse_loss(means, actions[rows])
            value_loss = torch.nn.functional.mse_loss(values, returns[rows])
            optimiser.zero_grad()
            (action_loss + value_loss).backward()
            optimiser.step()
            action_losses.append(action_loss.item())
            value_losses.append(value_loss.item())
    policy.set_training_mode(False)
    with torch.no_grad():
        policy.log_std.fill_(log_std)
    return {"action_mse": float(np.mean(action_losses)),
            "value_mse": float(np.mean(value_losses))}


def action_error(model: PPO, demonstrations: Demonstrations) -> float:
    """Mean-squared error of ``model``'s action mean against the recorded actions."""
    with torch.no_grad():
        means = model.policy.get_distribution(
            torch.as_tensor(demonstrations.observations)).distribution.mean
        return float(torch.nn.functional.mse_loss(
            means, torch.as_tensor(demonstrations.actions)))


def clone(args: argparse.Namespace, maps: Maps, model: PPO) -> dict[str, Any]:
    """Fit ``model`` to ``--imitate-steps`` of the ``--imitate-from`` team, then run
    ``--dagger-rounds`` of DAgger: the fitted policy (deterministic, as ``learned_team``)
    plays ``--dagger-steps`` in the training env, the teacher labels every state it
    visits, and the policy is fitted again (``--dagger-epochs``) on all the labelled rows
    so far. Returns what was done, per round."""
    start, cpu_start = time.perf_counter(), time.process_time()
    demonstrations = collect_demonstrations(args, maps, model.gamma)
    collected = time.perf_counter()
    losses = imitate(model, demonstrations, args.imitate_epochs, args.batch_size,
                     args.imitate_learning_rate, args.imitate_log_std)
    cloning: dict[str, Any] = {
        "teacher": args.imitate_from, "agent_steps": len(demonstrations.actions),
        "episodes": demonstrations.episodes,
        "scripted_arrival_rate": round(demonstrations.arrival_rate, 4),
        "epochs": args.imitate_epochs, "learning_rate": args.imitate_learning_rate,
        "log_std": args.imitate_log_std, **losses,
        "collect_seconds": round(collected - start, 1),
        "fit_seconds": round(time.perf_counter() - collected, 1)}
    print("cloning: " + ", ".join(f"{k} {v}" for k, v in cloning.items()), flush=True)
    rounds = []
    for number in range(1, args.dagger_rounds + 1):
        start = time.perf_counter()
        visited = collect_demonstrations(
            args, maps, model.gamma,
            player=learned_team(model, 1, args.full_speed, args.observation),
            steps=args.dagger_steps, seed=args.seed + IMITATION_SEED_OFFSET + number,
            desc=f"DAgger {number}")
        collected = time.perf_counter()
        demonstrations = demonstrations + visited
        learner_error = action_error(model, visited)
        losses = imitate(model, demonstrations, args.dagger_epochs, args.batch_size,
                         args.imitate_learning_rate, args.imitate_log_std)
        rounds.append({"round": number, "agent_steps": len(visited.actions),
                       "episodes": visited.episodes,
                       "learner_arrival_rate": round(visited.arrival_rate, 4),
                       "learner_action_mse": round(learner_error, 5),
                       "aggregate_steps": len(demonstrations.actions), **losses,
                       "collect_seconds": round(collected - start, 1),
                       "fit_seconds": round(time.perf_counter() - collected, 1)})
        print("DAgger: " + ", ".join(f"{k} {v}" for k, v in rounds[-1].items()), flush=True)
    if rounds:
        cloning["dagger"] = {"epochs": args.dagger_epochs, "rounds": rounds}
    cloning["cpu_seconds"] = round(time.process_time() - cpu_start, 1)
    return cloning


"""MAPPO for the defenders with TorchRL (``rl`` extra): the recipe of ``learned-mappo``'s
weights (``policies/mappo.py``), and its command line (``main(argv) -> history``, ``run``;
``examples/train_defender_mappo.py`` runs it).

    from reachavoid.training.mappo import TrainConfig, train_defenders
    weights, history = train_defenders(TrainConfig(iterations=120))

    python examples/train_defender_mappo.py --out policies/weights/learned_mappo.npz

One actor shared by every defender reads the padded layout (``policies.mappo``), so one
network learns from every game of ``GAMES`` at once: each iteration collects a batch from
the next game in turn (``VectorGroupEnv`` over ``make_defenders_vector_env``: ``copies``
random starts, scripted attackers) and takes PPO steps on it. The critic is centralised:
each defender's value reads its own padded observation and the mean over its team's
(the live defenders'), so it sees the whole game whatever the team's size. Rewards are the
defenders' (captures minus arrivals) with the attackers' progress to the target as
shaping (``shaping``). Everything is seeded: the same seed on the same machine and
library versions gives the same weights, bit for bit. The command line prints one line per
iteration and, with ``--report``, writes every iteration's record as JSON; every flag and
output is checked before any work, and an existing file is replaced only with ``--force``.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any, NamedTuple

import gymnasium
import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import NormalParamExtractor, TensorDictModule
from torch import nn
from torchrl.collectors import Collector
from torchrl.modules import ProbabilisticActor, TanhNormal
from torchrl.objectives import ClipPPOLoss, ValueEstimators

from policies.mappo import (
    ActorWeights,
    check_players,
    pad_observations,
    padded_size,
    save_weights,
)
from policies.registry import ATTACKERS, PolicySpec, make_batch_policy
from reachavoid.paths import UsageError, check_outputs
from reachavoid.training.flags import Bounds, check_ranges
from reachavoid.training.views import make_defenders_vector_env
from reachavoid_env import PolicyMismatch, builtin_names, builtin_scenario
from reachavoid_env.files import atomic_write, one_command
from reachavoid_env.integrations.torchrl import VectorGroupEnv
from reachavoid_env.observations import ObservationConfig
from reachavoid_env.vector import MAX_COPIES
from reachavoid_env.vector_views import LearnerVectorEnv

GROUP = "defender"
LOSSES = ("loss_objective", "loss_critic", "loss_entropy")


class Game(NamedTuple):
    """One training game: a built-in scenario (random starts of its players and map) and
    the scripted attackers (a registry name)."""

    scenario: str
    attackers: str


GAMES = (Game("paper_1v1", "shortest-path"), Game("paper_2v1", "shortest-path"),
         Game("paper_6v2", "shortest-path"), Game("paper_8v4", "shortest-path"),
         Game("paper_6v4_equal", "shortest-path"), Game("paper_6v2", "random"))
"""The default suite's games (``reachavoid_env/suites/default.toml``), against
shortest-path attackers, and 6v2 against random ones."""


@dataclass(frozen=True)
class TrainConfig:
    """A training run. ``iterations`` batches of ``copies x steps`` agent steps (each
    ``action_repeat`` game steps), the games taken in turn; ``epochs`` passes of minibatches
    of ``minibatch`` copy-steps per batch; ``hidden`` units in each of the two hidden layers
    of the actor and critic. ``teacher`` (a registry defender, ``None``: PPO from scratch)
    plays ``teacher_steps`` agent steps of ``copies`` copies of every game first, and the
    actor is cloned from it (``clone``: ``clone_epochs`` passes, the action's scale fitted
    to ``clone_scale``)."""

    games: tuple[Game, ...] = GAMES
    iterations: int = 36
    copies: int = 32
    steps: int = 32
    action_repeat: int = 10
    shaping: float = 1.0
    epochs: int = 4
    minibatch: int = 256
    lr: float = 1e-4
    entropy: float = 1e-3
    hidden: int = 64
    lidar_rays: int = 16
    teacher: str | None = "intercept"
    teacher_steps: int = 48
    clone_epochs: int = 30
    clone_scale: float = 0.3
    seed: int = 0


class PaddedView:
    """A defenders' training view (``LearnerVectorEnv``) whose observations are in the
    padded layout: what ``VectorGroupEnv`` reads (``num_envs``, ``learners``, ``autoreset``,
    ``single_observation_space``, the view's ``action_shape`` and ``single_action_space``,
    ``reset`` / ``step`` / ``reset_copies``)."""

    def __init__(self, view: LearnerVectorEnv, lidar_rays: int) -> None:
        scenario = view.vec.base_scenario
        self.view = view
        self.num_envs, self.learners, self.autoreset = view.num_envs, view.learners, False
        self.action_shape, self.single_action_space = view.action_shape, view.single_action_space
        self._pad = (scenario.num_attackers, scenario.num_defenders, lidar_rays)
        self.single_observation_space = gymnasium.spaces.Box(
            -1.0, 1.0, (padded_size(lidar_rays),), dtype=np.float32)

    def reset(self, seed: int | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        table, infos = self.view.reset(seed=seed)
        return pad_observations(table, *self._pad), infos

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, ...]:
        table, *rest = self.view.step(actions)
        return (pad_observations(table, *self._pad), *rest)

    def reset_copies(self, copies: np.ndarray) -> np.ndarray:
        return pad_observations(self.view.reset_copies(copies), *self._pad)

    def close(self) -> None:
        self.view.close()


class PooledCritic(nn.Module):
    """Each defender's value from its own observation and the mean of its live team's
    (``(..., L, D)`` and mask ``(..., L)`` -> ``(..., L, 1)``)."""

    def __init__(self, size: int, hidden: int) -> None:
        super().__init__()
        self.net = nn.Sequential(nn.Linear(2 * size, hidden), nn.Tanh(),
                                 nn.Linear(hidden, hidden), nn.Tanh(), nn.Linear(hidden, 1))

    def forward(self, observation: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        live = mask.unsqueeze(-1).to(observation.dtype)
        pooled = (observation * live).sum(-2, keepdim=True) / live.sum(-2, keepdim=True).clamp(
            min=1.0)
        return self.net(torch.cat([observation, pooled.expand_as(observation)], dim=-1))


def seeded(attackers: str, seed: int) -> dict[str, int]:
    """``{"seed": seed}`` for attackers that draw random numbers (``random``), else ``{}``:
    without it they would draw from fresh entropy and no run would repeat. Every copy's
    attackers get the same seed (their starts differ)."""
    return {"seed": seed} if PolicySpec("attackers", attackers).seeded else {}


def make_env(game: Game, config: TrainConfig, seed: int) -> VectorGroupEnv:
    """The TorchRL env of ``game``: ``config.copies`` random starts of its scenario."""
    view = make_defenders_vector_env(
        builtin_scenario(game.scenario), attackers=game.attackers, num_envs=config.copies,
        attacker_options=seeded(game.attackers, seed), action_repeat=config.action_repeat,
        autoreset=False, shaping=config.shaping,
        observation=ObservationConfig(lidar_rays=config.lidar_rays))
    env = VectorGroupEnv(PaddedView(view, config.lidar_rays))  # type: ignore[arg-type]
    env.set_seed(seed)
    return env


def build_modules(config: TrainConfig) -> tuple[nn.Sequential, ProbabilisticActor,
                                                 TensorDictModule]:
    """The actor's network (padded observation -> loc and scale of a tanh-normal action),
    the actor, and the critic."""
    size, hidden = padded_size(config.lidar_rays), config.hidden
    net = nn.Sequential(nn.Linear(size, hidden), nn.Tanh(), nn.Linear(hidden, hidden),
                        nn.Tanh(), nn.Linear(hidden, 4), NormalParamExtractor())
    actor = ProbabilisticActor(
        TensorDictModule(net, in_keys=[(GROUP, "observation")],
                         out_keys=[(GROUP, "loc"), (GROUP, "scale")]),
        in_keys=[(GROUP, "loc"), (GROUP, "scale")], out_keys=[(GROUP, "action")],
        distribution_class=TanhNormal, distribution_kwargs={"low": -1.0, "high": 1.0},
        return_log_prob=True, log_prob_key=(GROUP, "action_log_prob"))
    critic = TensorDictModule(PooledCritic(size, hidden),
                              in_keys=[(GROUP, "observation"), (GROUP, "mask")],
                              out_keys=[(GROUP, "state_value")])
    return net, actor, critic


def export(net: nn.Sequential, config: TrainConfig) -> ActorWeights:
    """The actor's weights for numpy play (``policies.mappo``): the linear layers, the last
    one cut to the action's mean."""
    linear = [layer for layer in net if isinstance(layer, nn.Linear)]
    layers = []
    for index, layer in enumerate(linear):
        weight = layer.weight.detach().numpy().T
        bias = layer.bias.detach().numpy()
        if index == len(linear) - 1:
            weight, bias = weight[:, :2], bias[:2]
        layers.append((np.ascontiguousarray(weight, dtype=np.float32),
                       np.ascontiguousarray(bias, dtype=np.float32)))
    return ActorWeights(tuple(layers), config.lidar_rays, config.action_repeat)


def masked_mean(values: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Mean of the per-agent ``values`` (``(B, agents)``, maybe a trailing 1) over the
    entries where ``mask`` (``(B, agents)``) is True."""
    values = values.reshape(mask.shape)
    return (values * mask).sum() / mask.sum().clamp(min=1)


def demonstrations(game: Game, config: TrainConfig, seed: int
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The teacher's padded observations ``(R, D)`` and actions ``(R, 2)`` (one row per
    live defender and agent step) over ``config.teacher_steps`` agent steps of
    ``config.copies`` random starts of ``game``, seeded ``seed``; the teacher decides
    every agent step and its action is held ``action_repeat`` game steps, as the learner's
    will be."""
    scenario = builtin_scenario(game.scenario)
    view = make_defenders_vector_env(
        scenario, attackers=game.attackers, num_envs=config.copies,
        attacker_options=seeded(game.attackers, seed),
        action_repeat=config.action_repeat, autoreset=True,
        observation=ObservationConfig(lidar_rays=config.lidar_rays))
    teacher = make_batch_policy("defenders", config.teacher, scenario)
    table, infos = view.reset(seed=seed)
    teacher.reset_copies(np.arange(config.copies), view.vec.episode_scenarios)
    live = infos["active"]
    observations, actions = [], []
    for _ in range(config.teacher_steps):
        act = teacher.act_batch(view.vec.batch_state())
        observations.append(pad_observations(table[live], scenario.num_attackers,
                                             scenario.num_defenders, config.lidar_rays))
        actions.append(act[live])
        table, _, _, _, infos = view.step(act)
        live = infos["active"]
        if infos["episode_over"].any():
            copies = np.flatnonzero(infos["episode_over"])
            teacher.reset_copies(copies, [view.vec.episode_scenarios[c] for c in copies])
    view.close()
    return np.concatenate(observations), np.concatenate(actions).astype(np.float32)


def clone(net: nn.Sequential, observations: np.ndarray, actions: np.ndarray,
          config: TrainConfig) -> float:
    """Fit the actor's mean action (``tanh`` of its loc) to the teacher's ``actions`` and
    its scale to ``config.clone_scale``, by mean-squared error, ``config.clone_epochs``
    passes of Adam over minibatches; returns the last pass's mean action error."""
    inputs = torch.as_tensor(observations)
    targets = torch.as_tensor(actions).clamp(-0.999, 0.999)
    optimiser = torch.optim.Adam(net.parameters(), lr=1e-3)
    error = 0.0
    for _ in range(config.clone_epochs):
        total = 0.0
        for rows in torch.randperm(len(inputs)).split(config.minibatch):
            loc, scale = net(inputs[rows])
            miss = ((torch.tanh(loc) - targets[rows]) ** 2).mean()
            loss = miss + ((scale - config.clone_scale) ** 2).mean()
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            total += miss.item() * len(rows)
        error = total / len(inputs)
    return error


def train_defenders(config: TrainConfig = TrainConfig(),
                    log: Callable[[dict[str, Any]], None] | None = None
                    ) -> tuple[ActorWeights, list[dict[str, Any]]]:
    """Train the shared actor (module docstring); returns its weights and one record per
    iteration (game, frames, mean reward per live defender-step, mean losses, seconds).

    Args:
        config: the run.
        log: called with each record as it is made.
    """
    torch.manual_seed(config.seed)
    torch.set_num_threads(1)    # tiny networks: more threads only contend for the cores
    net, actor, critic = build_modules(config)
    started = time.process_time()
    history: list[dict[str, Any]] = []
    if config.teacher is not None:
        rows = [demonstrations(game, config, config.seed + 1_000_000 + 1000 * index)
                for index, game in enumerate(config.games)]
        observations = np.concatenate([r[0] for r in rows])
        error = clone(net, observations, np.concatenate([r[1] for r in rows]), config)
        record = {"stage": "clone", "rows": len(observations), "action_mse": error,
                  "cpu_s": time.process_time() - started}
        history.append(record)
        if log is not None:
            log(record)
    loss_module = ppo_loss(actor, critic, GROUP, config.entropy, normalize_advantage=True)
    optimiser = torch.optim.Adam(loss_module.parameters(), lr=config.lr)
    frames = config.copies * config.steps
    collectors = [Collector(make_env(game, config, config.seed + 1000 * index), actor,
                            frames_per_batch=frames, total_frames=-1,
                            auto_register_policy_transforms=False)
                  for index, game in enumerate(config.games)]
    streams = [iter(collector) for collector in collectors]
    try:
        for iteration in range(config.iterations):
            which = iteration % len(streams)
            batch = next(streams[which])
            record = {"stage": "ppo", "iteration": iteration, "game": "/".join(config.games[which]),
                      **_update(loss_module, optimiser, batch, config),
                      "cpu_s": time.process_time() - started}
            history.append(record)
            if log is not None:
                log(record)
    finally:
        for collector in collectors:
            collector.shutdown()
    return export(net, config), history


def _update(loss_module: ClipPPOLoss, optimiser: torch.optim.Optimizer,
            batch: TensorDictBase, config: TrainConfig) -> dict[str, float]:
    """PPO epochs on one batch ``(copies, steps)``; the batch's mean reward per live
    defender-step and the mean losses."""
    losses = ppo_epochs(loss_module, optimiser, batch, GROUP, config.epochs, config.minibatch)
    live = batch[GROUP, "mask"]
    reward = batch["next", GROUP, "reward"].squeeze(-1)
    return {"reward": float(masked_mean(reward, live)),
            "episodes": int(batch["next", "done"].sum()), **losses}


def ppo_loss(actor: ProbabilisticActor, critic: TensorDictModule, group: str,
             entropy: float, normalize_advantage: bool = False) -> ClipPPOLoss:
    """Clipped PPO (clip 0.2, entropy weight ``entropy``, per-agent terms: ``ppo_epochs``
    averages them over the live agents) on the keys of ``group``, with GAE targets (gamma
    0.99, lambda 0.95)."""
    loss_module = ClipPPOLoss(actor, critic, clip_epsilon=0.2, entropy_coeff=entropy,
                              normalize_advantage=normalize_advantage, reduction="none")
    loss_module.set_keys(reward=(group, "reward"), action=(group, "action"),
                         value=(group, "state_value"), done=(group, "done"),
                         terminated=(group, "terminated"),
                         sample_log_prob=(group, "action_log_prob"))
    loss_module.make_value_estimator(ValueEstimators.GAE, gamma=0.99, lmbda=0.95)
    return loss_module


def ppo_epochs(loss_module: ClipPPOLoss, optimiser: torch.optim.Optimizer,
               batch: TensorDictBase, group: str, epochs: int,
               minibatch: int) -> dict[str, float]:
    """The GAE targets of ``batch``, then ``epochs`` passes of clipped PPO over it in
    shuffled minibatches of ``minibatch`` rows, each loss term averaged over the live
    agents of ``group`` (its ``mask``: agents that left are out of the loss). Returns the
    mean of each loss term (``LOSSES``) over the updates."""
    with torch.no_grad():
        loss_module.value_estimator(batch, params=loss_module.critic_network_params,
                                    target_params=loss_module.target_critic_network_params)
    flat = batch.reshape(-1)
    sums, updates = dict.fromkeys(LOSSES, 0.0), 0
    for _ in range(epochs):
        for rows in torch.randperm(flat.shape[0]).split(minibatch):
            sample = flat[rows]
            live = sample[group, "mask"]
            terms = {key: masked_mean(value, live)
                     for key, value in loss_module(sample).items() if key in LOSSES}
            loss = sum(terms.values())
            optimiser.zero_grad()
            loss.backward()
            nn.utils.clip_grad_norm_(loss_module.parameters(), 1.0)
            optimiser.step()
            for key, value in terms.items():
                sums[key] += value.item()
            updates += 1
    return {key: value / updates for key, value in sums.items()}


def games_of(names: Sequence[str]) -> tuple[Game, ...]:
    """Games from ``SCENARIO/ATTACKERS`` strings (``paper_6v2/random``); ``ValueError``
    naming ``games`` for a scenario that is not a built-in one, attackers that are not a
    registry attacker, or players the padded layout cannot hold (``check_players``)."""
    games = []
    for name in names:
        scenario, _, attackers = name.partition("/")
        if scenario not in builtin_names():
            raise ValueError(f"games: {name!r}: {scenario!r} is not a built-in scenario "
                             f"(choose from {', '.join(builtin_names())})")
        if (attackers or "shortest-path") not in ATTACKERS:
            raise ValueError(f"games: {name!r}: {attackers!r} is not an attacker (choose "
                             f"from {', '.join(ATTACKERS)})")
        try:
            check_players(builtin_scenario(scenario))
        except PolicyMismatch as err:
            raise ValueError(f"games: {name!r}: {str(err).split(': ', 1)[1]}") from None
        games.append(Game(scenario, attackers or "shortest-path"))
    return tuple(games)


RANGES: dict[str, Bounds] = {
    "iterations": (1, 10**6), "copies": (1, MAX_COPIES), "steps": (1, 10**6),
    "action_repeat": (1, 1000), "epochs": (1, 10**4), "minibatch": (1, 10**9),
    "hidden": (1, 4096), "seed": (0, 2**32 - 1), "shaping": (None, None),
    "lr": (0.0, None, True), "entropy": (0.0, None)}
"""Every number's range (``check_ranges``), checked before any work; an action repeat as
the weights file holds it (``policies.mappo``)."""


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line's arguments, every flag and output checked before any work."""
    defaults = TrainConfig()
    parser = argparse.ArgumentParser(
        description="Train the learned-mappo defenders (MAPPO with TorchRL) and write their "
                    "actor as the weights file the registry plays.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--out", required=True, help="the weights file to write (.npz)")
    parser.add_argument("--report", help="write the iterations' records here (.json)")
    parser.add_argument("--games", default=",".join("/".join(game) for game in GAMES),
                        help="SCENARIO/ATTACKERS, comma-separated, trained in turn")
    for name in ("iterations", "copies", "steps", "action_repeat", "epochs", "minibatch",
                 "hidden", "seed"):
        parser.add_argument(f"--{name.replace('_', '-')}", type=int,
                            default=getattr(defaults, name))
    for name in ("shaping", "lr", "entropy"):
        parser.add_argument(f"--{name}", type=float, default=getattr(defaults, name))
    parser.add_argument("--force", action="store_true",
                        help="replace output files that exist (default: refuse, before any work)")
    args = parser.parse_args(argv)
    check_ranges(parser, args, RANGES)
    try:
        args.games = games_of(args.games.split(","))
        check_outputs([("--out", args.out), ("--report", args.report)], args.force,
                      text={"--report"})
    except (ValueError, UsageError) as err:
        parser.error(f"--{err}" if str(err).startswith("games:") else str(err))
    return args


def main(argv: Sequence[str] | None = None) -> list[dict[str, Any]]:
    """The command line: parse ``argv``, train and write (``run``); the records."""
    with one_command():
        return run(parse_args(argv))


def run(args: argparse.Namespace) -> list[dict[str, Any]]:
    """Train as ``args`` (checked by ``parse_args``) say; write the weights and report."""
    options = {key: value for key, value in vars(args).items()
               if key not in ("out", "report", "games", "force")}
    config = TrainConfig(games=args.games, **options)
    started = time.perf_counter()

    def log(record: dict[str, Any]) -> None:
        print(", ".join(f"{key} {value:.4g}" if isinstance(value, float) else f"{key} {value}"
                        for key, value in record.items()), flush=True)

    weights, history = train_defenders(config, log)
    save_weights(args.out, weights)
    wall = time.perf_counter() - started
    print(f"wrote {args.out}: {history[-1]['cpu_s']:.0f} CPU s, {wall:.0f} wall s")
    if args.report:
        with atomic_write(args.report) as handle:
            json.dump({"config": asdict(config), "wall_s": wall, "history": history},
                      handle, indent=1)
    return history

"""The team recipe's evaluation: scripted and learned teams on seeded starts of the
attacker-only game, per-episode counts, summaries with intervals, paired differences, and
the video of a learned episode."""

from __future__ import annotations

import argparse
import functools
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from tqdm import tqdm

from policies.learned import ObservationPolicy
from policies.registry import PolicySpec
from reachavoid.evaluation import bootstrap_interval
from reachavoid.training.config import Maps, game
from reachavoid_env import AttackerStatus, PerMapPolicy, Policy
from reachavoid_env.observations import ObservationConfig
from reachavoid_env.video import RecordEpisode
from reachavoid_env.wrappers import AttackerParallelEnv

if TYPE_CHECKING:
    from stable_baselines3 import PPO


class Team(Protocol):
    """Moves the live attackers of an ``AttackerParallelEnv``, one game step at a time."""

    def reset(self, env: AttackerParallelEnv) -> None: ...

    def act(self, observations: dict[str, np.ndarray],
            env: AttackerParallelEnv) -> dict[str, np.ndarray]: ...


class ScriptedTeam:
    """A scripted attacker policy (``reachavoid_env.Policy``), asked every game step."""

    def __init__(self, policy: Policy) -> None:
        self.policy = policy

    def reset(self, env: AttackerParallelEnv) -> None:
        self.policy.reset(env.game.scenario)

    def act(self, observations: dict[str, np.ndarray],
            env: AttackerParallelEnv) -> dict[str, np.ndarray]:
        chosen = self.policy.act(env.game_state())
        return {name: chosen[name] for name in env.agents}


def learned_team(model: PPO, hold: int, full_speed: bool,
                 observation: ObservationConfig) -> ScriptedTeam:
    """The shared policy as a ``reachavoid_env.Policy`` (``policies.learned``): every live
    attacker decides every ``hold`` game steps from its own ``observation``, and holds its
    action in between (``action_repeat`` in training); with ``full_speed`` (as trained)
    its actions are headings."""
    return ScriptedTeam(ObservationPolicy(
        lambda batch: model.predict(batch, deterministic=True)[0], action_repeat=hold,
        full_speed=full_speed, observation=observation))


def play(env: AttackerParallelEnv, team: Team, seed: int) -> tuple[int, int]:
    """One episode from ``reset(seed=seed)``; returns (attackers arrived, captured)."""
    observations, _ = env.reset(seed=seed)
    team.reset(env)
    while env.agents:
        observations, *_ = env.step(team.act(observations, env))
    status = env.game_state().attacker_status
    return status.count(AttackerStatus.ARRIVED), status.count(AttackerStatus.CAPTURED)


@dataclass(frozen=True)
class TeamResult:
    """A team over the evaluation starts: per-episode counts and their summaries."""

    team: str
    arrived: tuple[int, ...]
    captured: tuple[int, ...]
    attackers: int

    @property
    def arrival_fractions(self) -> np.ndarray:
        return np.asarray(self.arrived, dtype=np.float64) / self.attackers

    def summary(self) -> dict[str, Any]:
        return {"episodes": len(self.arrived),
                "arrival_rate": float(self.arrival_fractions.mean()),
                "arrival_rate_ci95": bootstrap_interval(self.arrival_fractions),
                "mean_captured": float(np.mean(self.captured)),
                "mean_captured_ci95": bootstrap_interval(np.asarray(self.captured, float)),
                "mean_arrived": float(np.mean(self.arrived))}


def scripted_team(name: str, args: argparse.Namespace, maps: Maps) -> ScriptedTeam:
    """The scripted attackers ``name`` (``policies.registry.ATTACKERS``): ``random`` seeded
    with ``--seed``, ``hj`` and ``hj-pairs`` on the defenders' tubes (``--grid1``,
    ``--grid2``)."""
    choice = PolicySpec("attackers", name).choice
    grids = {flag: getattr(args, flag) for flag in ("grid1", "grid2") if choice.takes(flag)}
    spec = PolicySpec.of("attackers", name, **grids)
    return ScriptedTeam(PerMapPolicy(functools.partial(spec, seed=args.seed, progress=False),
                                     "attackers", first=maps[0]))


def make_team(name: str, model: PPO | None, args: argparse.Namespace,
              maps: Maps) -> Team:
    if name == "learned":
        return learned_team(model, args.action_repeat, args.full_speed, args.observation)
    return scripted_team(name, args, maps)


def evaluate(args: argparse.Namespace, maps: Maps, model: PPO | None,
             teams: Sequence[str]) -> dict[str, TeamResult]:
    """Every team in ``teams`` on the starts ``reset(seed=k)``, ``args.first_seed`` <= k <
    ``args.first_seed + args.episodes``, of one attacker-only env (no shaping; the defenders
    of ``args``)."""
    env = game(args, maps)
    results = {}
    for name in teams:
        team = make_team(name, model, args, maps)
        seeds = range(args.first_seed, args.first_seed + args.episodes)
        outcomes = [play(env, team, seed) for seed in tqdm(
            seeds, desc=name, unit="episode", disable=not sys.stderr.isatty())]
        results[name] = TeamResult(name, *map(tuple, zip(*outcomes, strict=True)),
                                   attackers=maps[0].num_attackers)
    env.close()
    return results


def paired_difference(first: TeamResult, second: TeamResult) -> dict[str, Any]:
    """Arrival rate of ``first`` minus ``second`` over the same starts, 95% bootstrap."""
    difference = first.arrival_fractions - second.arrival_fractions
    return {"teams": [first.team, second.team], "arrival_rate": float(difference.mean()),
            "arrival_rate_ci95": bootstrap_interval(difference)}


def record(args: argparse.Namespace, maps: Maps, model: PPO, seed: int) -> int:
    """The learned team on start ``seed`` to ``args.video`` in real time; returns frames."""
    env = game(args, maps, render_mode="rgb_array", render_width=args.video_width)
    fps = 1.0 / (maps[0].dt * args.video_every)
    with RecordEpisode(env, args.video, fps=fps, every=args.video_every) as recorded:
        play(recorded, learned_team(model, args.action_repeat, args.full_speed,
                                    args.observation), seed)
    return recorded.frames


"""A PettingZoo ``ParallelEnv`` of the game as a seeded Stable-Baselines3 ``VecEnv``, through
SuperSuit (``rl`` extra).

    >>> from stable_baselines3 import PPO
    >>> from reachavoid.training.views import make_attackers_parallel_env    # (the user's code)
    >>> from reachavoid_env.integrations.supersuit import sb3_vec_env
    >>> envs = sb3_vec_env(make_attackers_parallel_env("paper_6v2"), copies=4)
    >>> PPO("MlpPolicy", envs, seed=0).learn(100_000)

The chain is SuperSuit's ``black_death_v3`` (an agent that has left gets a zero
observation and reward 0 until the game ends, so the number of slots stays fixed),
``pettingzoo_env_to_vec_env_v1`` (one vector slot per agent, every slot the same policy:
parameter sharing, the observation starts with the own position) and
``concat_vec_envs_v1`` (``copies`` games, in ``num_cpus`` processes). It works around two
traps of SuperSuit 3.11:

- ``black_death_v3`` ends an episode only on a step where every agent is both terminated
  and truncated; otherwise one step late, after a step of zero observations that SB3 then
  learns from. ``GameEndFlags`` (under it) marks the step that ends the game so; a time-out
  is passed to SB3 as ``info["TimeLimit.truncated"]``, so that PPO bootstraps it.
- On the step that ends the game, ``pettingzoo_env_to_vec_env_v1`` resets and merges the
  reset's infos over the last step's, so ``status`` and the counts of the last step are
  replaced by those of the new episode. ``GameEndFlags`` also keeps the last step's info
  of every agent still in the game whole under ``info["final_info"]`` (a key no reset info has).
- ``PPO(seed=...)`` calls the vector env's ``seed``, which SuperSuit's SB3 wrapper cannot
  do; ``SeededVecEnv.seed(s)`` seeds the next reset instead, game copy ``i`` with ``s + i``.
- SB3's ``VecMonitor`` asks the vector env for ``render_mode``, which SuperSuit's
  concatenated envs do not answer (a warning, "The `render_mode` attribute is not
  defined"); ``SeededVecEnv`` answers with the game's.

``sb3_vec_env`` returns the chain under a ``VecMonitor``: every slot's episode return and
length reach SB3 (``info["episode"]``, ``model.ep_info_buffer``, the logger's
``rollout/ep_rew_mean`` and ``rollout/ep_len_mean``). A slot's episode is one agent's part
of a game, to the end of the game.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import supersuit
from pettingzoo import ParallelEnv
from pettingzoo.utils import BaseParallelWrapper
from stable_baselines3.common.vec_env import VecMonitor
from supersuit.vector.sb3_vector_wrapper import SB3VecEnvWrapper


class GameEndFlags(BaseParallelWrapper):
    """Marks every agent of the step that ends the game both terminated and truncated (what
    ``black_death_v3`` looks for); ``info["TimeLimit.truncated"]`` says which ran out of
    time, and ``info["final_info"]`` is that step's info as the game gave it."""

    def step(self, actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        observations, rewards, terminations, truncations, infos = self.env.step(actions)
        if observations and not self.env.agents:
            infos = {name: info | {"TimeLimit.truncated": truncations[name]
                                   and not terminations[name], "final_info": dict(info)}
                     for name, info in infos.items()}
            terminations = dict.fromkeys(observations, True)
            truncations = dict.fromkeys(observations, True)
        return observations, rewards, terminations, truncations, infos


class SeededVecEnv(SB3VecEnvWrapper):
    """SuperSuit's SB3 vector env with ``seed`` (what ``PPO(seed=)`` calls): the seed is
    used by the next ``reset``, game copy ``i`` reset with ``seed + i``."""

    def __init__(self, venv: Any) -> None:
        super().__init__(venv)
        self._next_seed: int | None = None

    def seed(self, seed: int | None = None) -> list[int | None]:
        self._next_seed = seed
        copies = len(getattr(self.venv, "vec_envs", [None]))
        return [None if seed is None else seed + i for i in range(copies)]

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        if attr_name == "render_mode":
            return [self.render_mode] * self.num_envs
        return super().get_attr(attr_name, indices)

    def reset(self) -> np.ndarray:
        seed, self._next_seed = self._next_seed, None
        observations, self.reset_infos = self.venv.reset(seed=seed)
        return observations


def sb3_vec_env(env: ParallelEnv, copies: int = 1, num_cpus: int = 0) -> VecMonitor:
    """``copies`` copies of ``env`` (pickled; give env factories, not heavy policy objects,
    to ``AttackerParallelEnv``) as one SB3 ``VecEnv`` with a slot per agent and copy, in
    ``num_cpus`` worker processes (0: in this process), under a ``VecMonitor``. Every
    agent needs the same observation and action spaces (true of the game and of
    ``AttackerParallelEnv``)."""
    slots = supersuit.pettingzoo_env_to_vec_env_v1(supersuit.black_death_v3(GameEndFlags(env)))
    return VecMonitor(SeededVecEnv(supersuit.concat_vec_envs_v1(
        slots, copies, num_cpus=num_cpus, base_class="gymnasium")))

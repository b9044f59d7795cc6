"""The vector env's training view (``vector_views.LearnerVectorEnv``) for RL libraries:
Stable-Baselines3's ``VecEnv`` and Gymnasium's ``VectorEnv``.

- ``SB3VecEnv(view)``: one slot per (copy, learner), copy-major, all slots one policy
  (parameter sharing), so ``PPO("MlpPolicy", SB3VecEnv(view))`` trains the shared attacker
  directly. A slot's episode is its learner's part of a game, to the end of the game (as
  SuperSuit's ``black_death_v3`` chain has it, ``integrations.supersuit``): a learner that
  has left gets a zero observation and reward 0 until its copy's episode ends (the step it
  leaves carries ``info["status"]``, ``AttackerStatus.code``); then every
  slot of the copy is ``done``, with ``info["terminal_observation"]`` (zero for a learner
  that had left), ``info["TimeLimit.truncated"]`` (time ran out with the learner in play, so
  PPO bootstraps) and ``info["is_success"]`` (the learner arrived). ``seed(s)`` seeds the
  next reset, copy ``k`` with ``s + k``.
- ``GymVectorEnv(view)``: a view of one learner as Gymnasium's ``VectorEnv`` (same-step
  autoreset: ``infos["final_obs"]`` and ``infos["_final_obs"]`` on the steps that end an
  episode), for Gymnasium's vector API and libraries built on it.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv

from reachavoid_env.game_state import AttackerStatus
from reachavoid_env.vector_views import LearnerVectorEnv

_ARRIVED, _CAPTURED = AttackerStatus.ARRIVED.code, AttackerStatus.CAPTURED.code


def _sb3_vec_env_class() -> type:
    from stable_baselines3.common.vec_env import VecEnv

    class SB3VecEnv(VecEnv):
        """``LearnerVectorEnv`` as a Stable-Baselines3 ``VecEnv`` (module docstring)."""

        def __init__(self, view: LearnerVectorEnv) -> None:
            self.view = view
            self._learners = len(view.learners)
            super().__init__(view.num_envs * self._learners, view.single_observation_space,
                             view.single_action_space)
            self._seed: int | None = None
            self._actions: np.ndarray | None = None
            self._alive = np.ones((view.num_envs, self._learners), dtype=bool)
            self._arrived = np.zeros_like(self._alive)

        def reset(self) -> np.ndarray:
            table, infos = self.view.reset(seed=self._seed)
            self._seed = None
            self._alive = infos["active"].copy()
            self._arrived[:] = False
            return self._flat(np.where(self._alive[..., None], table, 0.0))

        def step_async(self, actions: np.ndarray) -> None:
            self._actions = np.asarray(actions).reshape(self.view.num_envs, self._learners,
                                                        *self.view.action_shape)

        def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict]]:
            alive_before = self._alive
            table, rewards, terminated, truncated, infos = self.view.step(self._actions)
            self._arrived |= infos["arrived"]
            over = infos["episode_over"]
            self._alive = infos["active"].copy()
            table = np.where(self._alive[..., None], table, 0.0)
            dones = np.repeat(over, self._learners)
            slot_infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
            for copy, j in zip(*np.nonzero(terminated & ~over[:, None]), strict=True):
                slot_infos[copy * self._learners + j] = {"status": int(
                    _ARRIVED if infos["arrived"][copy, j] else _CAPTURED)}
            if over.any():
                final = np.where(alive_before[..., None], infos["final_observation"], 0.0)
                for copy in np.flatnonzero(over).tolist():
                    for j in range(self._learners):
                        slot_infos[copy * self._learners + j] = {
                            "terminal_observation": final[copy, j].astype(np.float32),
                            "TimeLimit.truncated": bool(truncated[copy, j]),
                            "is_success": bool(self._arrived[copy, j]),
                        }
                self._arrived[over] = False
            return (self._flat(table), rewards.reshape(-1).astype(np.float32), dones,
                    slot_infos)

        def _flat(self, table: np.ndarray) -> np.ndarray:
            return table.reshape(self.num_envs, -1).astype(np.float32)

        def seed(self, seed: int | None = None) -> list[int | None]:
            self._seed = seed
            return [None if seed is None else seed + c for c in range(self.view.num_envs)]

        def close(self) -> None:
            self.view.close()

        def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
            return [getattr(self.view, attr_name)] * len(self._indices(indices))

        def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
            setattr(self.view, attr_name, value)

        def env_method(self, method_name: str, *args: Any, indices: Any = None,
                       **kwargs: Any) -> list[Any]:
            result = getattr(self.view, method_name)(*args, **kwargs)
            return [result] * len(self._indices(indices))

        def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
            return [False] * len(self._indices(indices))

        def _indices(self, indices: Any) -> list[int]:
            if indices is None:
                return list(range(self.num_envs))
            return [indices] if isinstance(indices, int) else list(indices)

    return SB3VecEnv


def sb3_vec_env(view: LearnerVectorEnv) -> Any:
    """``view`` as a Stable-Baselines3 ``VecEnv`` (``SB3VecEnv``, module docstring)."""
    return _sb3_vec_env_class()(view)


class GymVectorEnv(VectorEnv):
    """A ``LearnerVectorEnv`` of one learner as Gymnasium's ``VectorEnv`` (module
    docstring): observations ``(K, D)``, rewards, terminations and truncations ``(K,)``."""

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(self, view: LearnerVectorEnv) -> None:
        if len(view.learners) != 1:
            raise ValueError(f"view: a Gymnasium vector env has one learner per copy, this "
                             f"view has {len(view.learners)}")
        self.view = view
        self.num_envs = view.num_envs
        self.single_observation_space = view.single_observation_space
        self.single_action_space = view.single_action_space
        self.observation_space = gymnasium.vector.utils.batch_space(
            self.single_observation_space, self.num_envs)
        self.action_space = gymnasium.vector.utils.batch_space(self.single_action_space,
                                                               self.num_envs)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None,
              ) -> tuple[np.ndarray, dict[str, Any]]:
        table, infos = self.view.reset(seed=seed)
        return table[:, 0], {}

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                          dict[str, Any]]:
        table, rewards, terminated, truncated, infos = self.view.step(
            np.asarray(actions).reshape(self.num_envs, 1, *self.view.action_shape))
        out: dict[str, Any] = {}
        over = infos["episode_over"]
        if over.any():
            out = {"final_obs": infos["final_observation"][:, 0], "_final_obs": over,
                   "is_success": infos["arrived"][:, 0], "_is_success": over}
        return table[:, 0], rewards[:, 0], terminated[:, 0], truncated[:, 0], out

    def close_extras(self, **kwargs: Any) -> None:
        self.view.close()

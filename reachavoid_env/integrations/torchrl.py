"""The game as a TorchRL env (``rl`` extra).

    import reachavoid_env
    from reachavoid_env.integrations.torchrl import torchrl_env
    from torchrl.envs.utils import check_env_specs

    env = torchrl_env(reachavoid_env.parallel_env(scenario="paper_2v1"), seed=0)
    check_env_specs(env)
    rollout = env.rollout(100)      # rollout["next", "attacker", "reward"]: (100, 2, 1)

Agents leave the game (captured, arrived), so the wrapper needs ``use_mask=True``: each
group gets a ``"mask"`` entry, ``False`` for an agent no longer in play (its observation
and reward are then zero); and ``done_on_any=False``, so the episode ends when every agent
is done rather than at the first capture. Agents are grouped by role, ``"attacker"`` and
``"defender"`` (TorchRL would otherwise make one group per agent), so a group's policy is
shared by its agents. The infos become tensors under ``(group, "info")``: they must be the
env's numeric infos (``info_format="numeric"``, the default).

``VectorGroupEnv(view)`` is the batched form over the vector env's training view: the
learners of ``K`` copies (the attackers, or the defenders) as one TorchRL env of batch size
``(K,)``, the scripted side acting inside it (below).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils import BaseWrapper
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import EnvBase
from torchrl.envs.libs.pettingzoo import PettingZooWrapper

from reachavoid_env.vector_views import LearnerVectorEnv


class TorchRLAEC(BaseWrapper):
    """An AEC env as TorchRL's ``PettingZooWrapper`` reads it when agents leave.

    PettingZoo's AEC API removes a terminated or truncated agent by ``step(None)`` on its
    turn and then drops it from ``rewards``, ``terminations``, ``truncations`` and
    ``infos``; TorchRL sends the group's (masked) action tensor for it and reads those
    dicts and ``observe`` for every agent. This wrapper passes ``None`` for a done agent and
    keeps removed agents in the dicts and ``observe`` (reward 0; done flags, info and
    observation as they ended).
    """

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None) -> None:
        self._removed: dict[str, tuple[bool, bool, dict[str, Any], Any]] = {}
        super().reset(seed=seed, options=options)

    def step(self, action: Any) -> None:
        agent = self.agent_selection
        if self.env.terminations[agent] or self.env.truncations[agent]:
            self._removed[agent] = (self.env.terminations[agent], self.env.truncations[agent],
                                    self.env.infos[agent], self.env.observe(agent))
            action = None
        super().step(action)

    def observe(self, agent: str) -> Any:
        return self._removed[agent][3] if agent in self._removed else self.env.observe(agent)

    @property
    def rewards(self) -> dict[str, float]:
        return dict.fromkeys(self._removed, 0.0) | self.env.rewards

    @property
    def terminations(self) -> dict[str, bool]:
        return {name: ended[0] for name, ended in self._removed.items()} | self.env.terminations

    @property
    def truncations(self) -> dict[str, bool]:
        return {name: ended[1] for name, ended in self._removed.items()} | self.env.truncations

    @property
    def infos(self) -> dict[str, dict[str, Any]]:
        return {name: ended[2] for name, ended in self._removed.items()} | self.env.infos


def role_groups(possible_agents: list[str]) -> dict[str, list[str]]:
    """``{"attacker": [...], "defender": [...]}``: the agents by the role in their name
    (roles with no agent are left out)."""
    groups: dict[str, list[str]] = {}
    for name in possible_agents:
        groups.setdefault(name.rsplit("_", 1)[0], []).append(name)
    return groups


def torchrl_env(env: ParallelEnv | AECEnv, *, seed: int | None = None, device: Any = "cpu",
                **kwargs: Any) -> PettingZooWrapper:
    """``env`` (the parallel or AEC game, or ``AttackerParallelEnv``) as a TorchRL env with
    role groups, the agent mask, episodes that end when every agent is done and the global
    ``state``; an AEC env is wrapped in ``TorchRLAEC``. ``kwargs`` go to
    ``PettingZooWrapper`` (e.g. ``group_map`` to override the groups)."""
    if getattr(env.unwrapped, "info_format", "numeric") != "numeric":
        raise ValueError("info_format: TorchRL needs the env's numeric infos; build the env "
                         "with info_format='numeric' (the default)")
    if isinstance(env, AECEnv):
        env = TorchRLAEC(env)
    options = {"group_map": role_groups(list(env.possible_agents)), "use_mask": True,
               "done_on_any": False, "return_state": hasattr(env.unwrapped, "state_space")}
    return PettingZooWrapper(env, seed=seed, device=device, **(options | kwargs))


class VectorGroupEnv(EnvBase):
    """The learners of a vector training view (``vector_views.LearnerVectorEnv`` made with
    ``autoreset=False``; ``reachavoid.training.views.make_attackers_vector_env(...,
    autoreset=False)``) as a batched TorchRL env: batch size ``(K,)``, one group (``group``:
    ``"attacker"`` or ``"defender"``, the learners' side) with ``observation``
    ``(K, L, D)``, ``action`` ``(K, L, 2)`` (``(K, L)`` integers for a view with discrete
    actions), ``reward``
    ``(K, L, 1)``, per-learner ``done`` / ``terminated`` / ``truncated`` and ``mask``
    (``False`` for a learner that has left: its observation is then zero), and the copy's
    ``done`` / ``terminated`` / ``truncated`` ``(K, 1)`` at the root. A copy whose episode
    ended stands still until TorchRL resets it (``"_reset"``), as its collectors do.
    """

    def __init__(self, view: LearnerVectorEnv) -> None:
        if view.autoreset:
            raise ValueError("view: TorchRL resets the copies itself; make the view with "
                             "autoreset=False")
        k, learners = view.num_envs, len(view.learners)
        size = view.single_observation_space.shape[0]
        super().__init__(batch_size=torch.Size([k]), device="cpu")
        self.view = view
        self.group = "attacker" if view.learners[0].startswith("attacker") else "defender"
        group = (k, learners)
        flags = {name: Categorical(2, (*group, 1), dtype=torch.bool)
                 for name in ("done", "terminated", "truncated")}
        self.observation_spec = Composite({self.group: Composite(
            observation=Bounded(-1.0, 1.0, (*group, size), dtype=torch.float32),
            mask=Categorical(2, group, dtype=torch.bool), shape=group)}, shape=(k,))
        action = Bounded(-1.0, 1.0, (*group, 2), dtype=torch.float32) \
            if view.action_shape else Categorical(view.single_action_space.n, group)
        self.action_spec = Composite({self.group: Composite(action=action, shape=group)},
                                     shape=(k,))
        self.reward_spec = Composite({self.group: Composite(
            reward=Unbounded((*group, 1), dtype=torch.float32), shape=group)}, shape=(k,))
        self.done_spec = Composite(
            {self.group: Composite(**flags, shape=group),
             **{name: Categorical(2, (k, 1), dtype=torch.bool) for name in flags}}, shape=(k,))
        self._seed: int | None = None
        self._alive = np.ones(group, dtype=bool)
        self._left = np.zeros(group, dtype=bool)

    def _set_seed(self, seed: int | None) -> None:
        self._seed = seed

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs: Any) -> TensorDict:
        partial = tensordict is not None and "_reset" in tensordict.keys()
        if partial and self._started:
            copies = np.flatnonzero(tensordict["_reset"].reshape(-1).numpy())
            table = self._table.copy()
            table[copies] = self.view.reset_copies(copies)
            self._alive[copies] = True
            self._left[copies] = False
        else:
            table, infos = self.view.reset(seed=self._seed)
            self._seed, self._started = None, True
            self._alive = infos["active"].copy()
            self._left[:] = False
        self._table = table
        return self._output(table, None, np.zeros_like(self._left), np.zeros_like(self._left),
                            np.zeros(len(table), dtype=bool))

    _started = False

    def _step(self, tensordict: TensorDictBase) -> TensorDict:
        actions = tensordict[self.group, "action"].detach().cpu().numpy()
        table, rewards, terminated, truncated, infos = self.view.step(actions)
        self._left |= terminated
        self._alive = infos["active"].copy()
        self._table = table
        over = infos["episode_over"]
        return self._output(table, rewards, self._left | truncated, truncated, over)

    def _output(self, table: np.ndarray, rewards: np.ndarray | None, done: np.ndarray,
                truncated: np.ndarray, over: np.ndarray) -> TensorDict:
        k, learners = self._left.shape
        observed = np.where(self._alive[..., None], table, 0.0).astype(np.float32)
        group = {"observation": torch.from_numpy(observed),
                 "mask": torch.from_numpy(self._alive.copy()),
                 "done": torch.from_numpy(done[..., None].copy()),
                 "terminated": torch.from_numpy((done & ~truncated)[..., None].copy()),
                 "truncated": torch.from_numpy(truncated[..., None].copy())}
        if rewards is not None:
            group["reward"] = torch.from_numpy(rewards[..., None].astype(np.float32))
        copy_truncated = truncated.any(axis=1)[:, None]
        root = {"done": torch.from_numpy(over[:, None].copy()),
                "terminated": torch.from_numpy((over[:, None] & ~copy_truncated).copy()),
                "truncated": torch.from_numpy((over[:, None] & copy_truncated).copy())}
        return TensorDict({self.group: TensorDict(group, batch_size=(k, learners)), **root},
                          batch_size=(k,))

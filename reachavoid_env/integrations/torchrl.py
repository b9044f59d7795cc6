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
"""

from __future__ import annotations

from typing import Any

from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils import BaseWrapper
from torchrl.envs.libs.pettingzoo import PettingZooWrapper


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

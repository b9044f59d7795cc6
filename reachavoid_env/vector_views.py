"""Training views of the vector env: some players of ``K`` copies learn, batched scripted
policies (``BatchPolicy``) move the others.

``LearnerVectorEnv(vec, learners, scripted)`` steps ``vec`` (a ``ReachAvoidVectorEnv``
made with ``autoreset=False``) with the learners' actions ``(K, L, 2)`` (``(K, L)``
integers when ``vec`` has ``continuous_actions=False``) and the scripted
sides' ``act_batch`` of the same ``BatchState``, every env step. Arrays out are
``(K, L, ...)``: copy first, learner second (agent order). ``action_repeat = k`` holds the
learners' actions for ``k`` env steps and sums their rewards; a copy whose episode ends
within the held steps stands still for the rest of them (it does not run into its next
episode). An episode of the view ends in a copy when its game ends or when none of its
learners is left (teammates that are scripted do not play on alone); that copy is reset at
once (Gymnasium's same-step autoreset; with ``autoreset=False`` it stands still until
``reset_copies``, as TorchRL resets envs): the returned observation is the new episode's,
and ``infos["final_observation"]`` ``(K, L, D)`` holds the ended one's last (rows of other
copies are the current ones), ``infos["episode_over"]`` ``(K,)`` marks those copies.

Rewards are the env's (``shaping`` included) plus ``timeout_reward`` for a learner still
in play when its episode is truncated, and, for learning attackers, ``team_reward`` times
the sum of the other learners' +1 / -1 (arrival, capture) in each env step for a learner in
play (``reachavoid_env.rewards.team_bonus``, as ``AttackerParallelEnv``).
``start_reach`` reads and sets the vector env's (easy starts for a curriculum; Stable-
Baselines3's ``set_attr`` reaches it through ``integrations.vector``).

``terminated`` ``(K, L)``: the learner was captured or arrived within this step;
``truncated``: it was still in play when ``max_cycles`` ran out. ``infos["active"]``
``(K, L)``: the learner is in the game in the returned observation (a learner that left
stays out, masked, until its copy resets); ``infos["arrived"]`` ``(K, L)``: the learner
arrived within this step.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from reachavoid_env import checks
from reachavoid_env.actions import controls
from reachavoid_env.game_state import AttackerStatus
from reachavoid_env.policy import BatchPolicy
from reachavoid_env.rewards import team_bonus, timeout
from reachavoid_env.vector import ReachAvoidVectorEnv

_ARRIVED = AttackerStatus.ARRIVED.code


class LearnerVectorEnv:
    """Learners ``learners`` (agent names) of ``vec``'s copies; ``scripted`` pairs a
    ``BatchPolicy`` with the agent names it moves (module docstring)."""

    def __init__(self, vec: ReachAvoidVectorEnv, learners: Sequence[str],
                 scripted: Sequence[tuple[BatchPolicy, Sequence[str]]],
                 action_repeat: int = 1, timeout_reward: float = 0.0,
                 autoreset: bool = True, team_reward: float = 0.0) -> None:
        if vec.autoreset:
            raise ValueError("vec: the training views reset copies themselves; make the "
                             "vector env with autoreset=False")
        self.vec = vec
        self.autoreset = bool(autoreset)
        self.num_envs = vec.num_envs
        self.action_repeat = checks.integer(action_repeat, "action_repeat", 1, 1_000_000)
        self.timeout_reward = checks.real(timeout_reward, "timeout_reward")
        self.team_reward = checks.real(team_reward, "team_reward")
        names = vec.possible_agents
        self.learners = list(learners)
        self._learner_rows = np.array([names.index(n) for n in self.learners])
        self._m = m = vec.base_scenario.num_attackers
        if self.team_reward and (self._learner_rows >= m).any():
            raise ValueError("team_reward: for learning attackers only (the defenders' "
                             "reward is already their team's)")
        # (policy, the rows it moves among all players, the same among its side's players)
        self._scripted = []
        for policy, moved in scripted:
            rows = np.array([names.index(n) for n in moved])
            if (rows < m).any() and (rows >= m).any():
                raise ValueError("scripted: a policy moves players of one side")
            self._scripted.append((policy, rows, rows - (m if rows[0] >= m else 0)))
        covered = sorted([*self._learner_rows.tolist(),
                          *(r for _, rows, _ in self._scripted for r in rows.tolist())])
        if covered != list(range(len(names))):
            raise ValueError("scripted: every agent must be a learner or moved by exactly one "
                             "scripted policy")
        self.render_mode = None
        self.single_observation_space = vec.single_observation_space
        self.single_action_space = vec.single_action_space

    @property
    def action_shape(self) -> tuple[int, ...]:
        """One learner's action: ``(2,)``, or ``()`` (an integer) with the vector env's
        ``continuous_actions=False``."""
        return (2,) if self.vec.continuous_actions else ()

    @property
    def start_reach(self) -> float | None:
        """The vector env's ``start_reach`` (module docstring)."""
        return self.vec.start_reach

    @start_reach.setter
    def start_reach(self, reach: float | None) -> None:
        self.vec.start_reach = reach

    def reset(self, seed: int | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        observations, infos = self.vec.reset(seed=seed)
        everyone = np.arange(self.num_envs)
        for policy, *_ in self._scripted:
            policy.reset_copies(everyone, self.vec.episode_scenarios)
        table = np.stack([observations[name] for name in self.learners], axis=1)
        return table, {"active": infos["active"][:, self._learner_rows]}

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                          dict[str, Any]]:
        """``actions`` ``(K, L, 2)`` (``(K, L)`` integers with the vector env's
        ``continuous_actions=False``); one learner step (``action_repeat`` env steps)."""
        if not self.vec.continuous_actions:
            learned = controls("actions", actions, (self.num_envs, len(self.learners)))
        else:
            learned = np.asarray(actions, dtype=np.float64)
        if learned.shape != (self.num_envs, len(self.learners), 2):
            raise ValueError(f"actions: expected shape ({self.num_envs}, {len(self.learners)}, "
                             f"2), got {learned.shape}")
        if not np.isfinite(learned).all():
            raise ValueError("actions: must be finite real numbers")
        vec, rows = self.vec, self._learner_rows
        names = vec.possible_agents
        k, learners = self.num_envs, len(self.learners)
        totals = np.zeros((k, learners))
        terminated = np.zeros((k, learners), dtype=bool)
        truncated = np.zeros((k, learners), dtype=bool)
        arrived = np.zeros((k, learners), dtype=bool)
        over = np.zeros(k, dtype=bool)
        final = np.zeros((k, learners, self.single_observation_space.shape[0]),
                         dtype=np.float32)
        for _ in range(self.action_repeat):
            full = np.zeros((k, len(names), 2))
            full[:, rows] = learned
            states = vec.batch_state()
            for policy, moved, side_rows in self._scripted:
                full[:, moved] = policy.act_batch(states)[:, side_rows]
            playing = vec.active[:, rows] if self.team_reward else None
            observations, rewards, terms, truncs, infos = vec.advance(full)
            table = np.stack([observations[name] for name in self.learners], axis=1)
            totals += np.stack([rewards[n] for n in self.learners], axis=1)
            left = np.stack([terms[n] for n in self.learners], axis=1)
            terminated |= left
            truncated |= np.stack([truncs[n] for n in self.learners], axis=1)
            attackers = rows < self._m
            arriving = left[:, attackers] & (infos["status"][:, rows[attackers]] == _ARRIVED)
            arrived[:, attackers] |= arriving
            if self.team_reward and left.any():    # every learner is an attacker here
                outcomes = np.where(arriving, 1.0, np.where(left, -1.0, 0.0))
                totals += team_bonus(outcomes, playing, self.team_reward)
            ending = ~over & (infos["episode_over"] | ~infos["active"][:, rows].any(axis=1))
            if ending.any():          # these copies stand still for the rest of the step
                vec.end_copies(np.flatnonzero(ending))
                final[ending] = table[ending]
                over |= ending
            if over.all():
                break
        totals += timeout(truncated, self.timeout_reward)
        infos_out: dict[str, Any] = {"episode_over": over, "arrived": arrived}
        if over.any():
            infos_out["final_observation"] = np.where(over[:, None, None], final, table)
            if self.autoreset:
                copies = np.flatnonzero(over)
                table[copies] = self.reset_copies(copies)
        infos_out["active"] = vec.active[:, rows]
        return table, totals, terminated, truncated, infos_out

    def reset_copies(self, copies: np.ndarray) -> np.ndarray:
        """New episodes in ``copies`` (their scripted policies reset too); returns the
        learners' first observations ``(len(copies), L, D)``."""
        vec = self.vec
        fresh = vec.reset_copies(copies)
        scenarios = [vec.episode_scenarios[c] for c in np.asarray(copies).tolist()]
        for policy, *_ in self._scripted:
            policy.reset_copies(copies, scenarios)
        return fresh[:, self._learner_rows]

    def close(self) -> None:
        self.vec.close()

"""The game played in decisions: ``DecisionEnv``, the env of ``reachavoid/ReachAvoid-v2``
(``reach_avoid_v2`` has its Version History and the reasons for its defaults).

One step of ``DecisionEnv`` is one decision of every agent: the actions are held for
``decision_steps`` steps of the underlying ``ReachAvoidEnv`` (each ``dt`` seconds, events
judged on every one of them by the env's own ``step``), stopping early when the episode
ends. The rewards come from ``reachavoid_env.rewards``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium.utils import EzPickle
from pettingzoo import ParallelEnv

from reachavoid_env import checks
from reachavoid_env.actions import action_space, control
from reachavoid_env.environment import ParallelView, ReachAvoidEnv, check_agent_names
from reachavoid_env.game_state import AttackerStatus, GameState
from reachavoid_env.maps import ScenarioSource
from reachavoid_env.observations import ObservationConfig
from reachavoid_env.rewards import REWARDS, GeodesicPotential, potential_shaping, zero_sum
from reachavoid_env.scenario import MAX_STEPS, Scenario
from reachavoid_env.video import realtime_fps

DECISION_STEPS = 10
"""Physics steps per decision by default (``reach_avoid_v2`` says why)."""
MAX_DECISIONS = 400
"""Decisions before truncation by default (``reach_avoid_v2`` says why)."""
GAMMA = 0.99
"""The discount per decision the shaping assumes by default (Stable-Baselines3's PPO's)."""
_CAPTURED, _ARRIVED = AttackerStatus.CAPTURED.code, AttackerStatus.ARRIVED.code


class DecisionEnv(ParallelView, ParallelEnv, EzPickle):
    """The reach-avoid game of ``ReachAvoidEnv`` in decisions of ``decision_steps`` physics
    steps (``reach_avoid_v2``'s docstring has the rules of v2 and its defaults).

    Args:
        scenario: as ``ReachAvoidEnv`` (a built-in name, a file, a ``Scenario``, a library).
        max_cycles: decisions before every agent still in play is truncated (default
            ``MAX_DECISIONS``).
        decision_steps: physics steps of ``dt`` seconds per decision.
        reward: ``"sparse"`` (+1 arrival, -1 capture; the defenders minus the attackers'
            sum) or ``"shaped"`` (plus potential-based shaping, ``rewards.GeodesicPotential``).
        gamma: the discount per decision of the shaping (use the learner's).
        continuous_actions: ``True``: ``Box(-1, 1, (2,))`` velocities; ``False``:
            ``Discrete(9)``, stay or one of 8 full-speed headings (``actions``).
        remove_agents: ``True``: captured and arrived attackers leave ``agents``
            (PettingZoo's convention); ``False``: every agent stays in ``agents`` until
            the episode ends (as SuperSuit's ``black_death``).
        starts: ``"random"`` (every player's start drawn at every reset, seeded) or
            ``"scenario"``.
        render_mode, render_width, info_format, observation: as ``ReachAvoidEnv``.
    """

    metadata = {
        "name": "reach_avoid_v2",
        "render_modes": ["human", "rgb_array"],
        "render_fps": 20,
        "is_parallelizable": True,
    }

    def __init__(self, scenario: ScenarioSource = "paper_2v1", max_cycles: int | None = None,
                 decision_steps: int = DECISION_STEPS, reward: str = "sparse",
                 gamma: float = GAMMA, continuous_actions: bool = True,
                 remove_agents: bool = True, starts: str = "random",
                 render_mode: str | None = None, render_width: int = 640,
                 info_format: str = "numeric",
                 observation: ObservationConfig | Mapping[str, Any] | None = None) -> None:
        EzPickle.__init__(self, scenario=scenario, max_cycles=max_cycles,
                          decision_steps=decision_steps, reward=reward, gamma=gamma,
                          continuous_actions=continuous_actions, remove_agents=remove_agents,
                          starts=starts, render_mode=render_mode, render_width=render_width,
                          info_format=info_format, observation=observation)
        self.decision_steps = checks.integer(decision_steps, "decision_steps", 1, 100_000)
        if reward not in REWARDS:
            raise ValueError(f"reward: {reward!r} is not one of {REWARDS}")
        self.reward = reward
        self.gamma = checks.real(gamma, "gamma", 0.0, 1.0)
        self.continuous_actions = checks.flag(continuous_actions, "continuous_actions")
        self.remove_agents = checks.flag(remove_agents, "remove_agents")
        decisions = MAX_DECISIONS if max_cycles is None else checks.integer(
            max_cycles, "max_cycles", 1, MAX_STEPS // self.decision_steps)
        self.game = ReachAvoidEnv(scenario=scenario,
                                  max_cycles=decisions * self.decision_steps,
                                  render_mode=render_mode, render_width=render_width,
                                  info_format=info_format, starts=starts,
                                  observation=observation)
        self.game.observing = False   # observations once, at the end of each decision
        self.metadata = {**self.metadata, "render_fps": round(realtime_fps(
            self.game.base_scenario.dt, self.decision_steps))}
        self.render_mode = render_mode
        self.possible_agents = self.game.possible_agents
        self.agents: list[str] = []
        self._index = {name: i for i, name in enumerate(self.possible_agents)}
        self._m = self.game.base_scenario.num_attackers
        self._n = self.game.base_scenario.num_defenders
        self._action_spaces = {name: action_space(self.continuous_actions)
                               for name in self.possible_agents}
        self.state_space = self.game.state_space
        self._potentials: dict[Any, GeodesicPotential] = {}
        self._phi = np.zeros(self._m)
        self._last_infos: dict[str, dict[str, Any]] = {}

    # --------------------------------------------------------------- settings
    @property
    def max_cycles(self) -> int:
        """Decisions before truncation (``pettingzoo.test.parallel_api_test`` sets it)."""
        return self.game.max_cycles // self.decision_steps

    @max_cycles.setter
    def max_cycles(self, value: int) -> None:
        checks.integer(value, "max_cycles", 1, MAX_STEPS // self.decision_steps)
        self.game.max_cycles = value * self.decision_steps

    @property
    def scenario(self) -> Scenario:
        """The scenario of the current episode (its starts included)."""
        return self.game.scenario

    # ------------------------------------------------------------------ reset
    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None,
              ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        """A new episode, as ``ReachAvoidEnv.reset``.

        Args:
            seed: seeds the env's generator (starts, maps); ``None`` draws on.
            options: ``ReachAvoidEnv.reset``'s options.

        Returns:
            Every agent's first observation and info (the keys of ``_completed``).
        """
        observations, infos = self.game.reset(seed=seed, options=options)
        self.np_random, self.np_random_seed = self.game.np_random, self.game.np_random_seed
        self.agents = self.possible_agents[:]
        state = self.game.game_state()
        if self.reward == "shaped":
            self._phi = self._potential()(state.attacker_positions, state.active_attackers)
        self._last_infos = self._completed(infos, state)
        return observations, {name: dict(info) for name, info in self._last_infos.items()}

    def _potential(self) -> GeodesicPotential:
        """The episode's map's ``GeodesicPotential`` (made once per map)."""
        sc = self.game.scenario
        if sc.map not in self._potentials:
            self._potentials[sc.map] = GeodesicPotential(sc.map, sc.player_radius,
                                                         sc.attacker_speed)
        return self._potentials[sc.map]

    # ------------------------------------------------------------------- step
    def step(self, actions: dict[str, Any]) -> tuple[dict[str, np.ndarray], dict[str, float],
                                                     dict[str, bool], dict[str, bool],
                                                     dict[str, dict[str, Any]]]:
        """One decision: ``actions`` held for up to ``decision_steps`` physics steps.

        Args:
            actions: ``{agent: action}`` for every agent in play (a ``Box`` vector, or an
                integer with ``continuous_actions=False``); agents out of the game (kept
                with ``remove_agents=False``) need none.

        Returns:
            Observations, rewards (summed over the physics steps, plus the shaping),
            terminations, truncations and infos of the agents in ``agents`` at the start.
        """
        if not isinstance(actions, Mapping):
            raise TypeError(f"step: actions must be a dict {{agent name: action}}, got "
                            f"{type(actions).__name__}")
        check_agent_names(actions, self.possible_agents)
        live, game = self.agents, self.game
        if not live:
            return {}, {}, {}, {}, {}
        playing = game.agents
        held = {}
        for name in playing:
            if name not in actions:
                raise KeyError(f"step: no action for live agent {name!r}")
            held[name] = actions[name] if self.continuous_actions \
                else control(name, actions[name])
        rewards = dict.fromkeys(live, 0.0)
        terminated: dict[str, bool] = {}
        truncated: dict[str, bool] = {}
        infos: dict[str, dict[str, Any]] = {}
        for _ in range(self.decision_steps):
            _, rew, term, trunc, info = game.step({name: held[name] for name in game.agents})
            infos.update(info)
            terminated.update(term)
            truncated.update(trunc)
            for name, value in rew.items():
                rewards[name] += value
            if not game.agents:
                break
        observations = game.observe(playing)
        state = game.game_state()
        if self.reward == "shaped":
            phi = self._potential()(state.attacker_positions, state.active_attackers)
            shaping = zero_sum(potential_shaping(self._phi, phi, self.gamma), self._n)
            self._phi = phi
            for name in playing:
                rewards[name] += float(shaping[self._index[name]])
        infos = self._completed(infos, state)
        if self.remove_agents:
            self.agents = game.agents[:]
            return observations, rewards, terminated, truncated, infos
        return self._kept(live, observations, rewards, truncated, infos)

    def _kept(self, live: list[str], observations: dict[str, np.ndarray],
              rewards: dict[str, float], truncated: dict[str, bool],
              infos: dict[str, dict[str, Any]]) -> tuple[dict, dict, dict, dict, dict]:
        """The outputs of a decision with ``remove_agents=False``: every agent of ``live``
        (all of them) keeps its place until the episode ends; one out of the game gets a
        zero observation, reward 0, its last info with ``active`` false, and
        ``terminations`` / ``truncations`` false until the last decision, when every agent
        ends (truncated if the time limit found it in play, terminated otherwise)."""
        over = not self.game.agents
        for name in live:
            if name not in observations:
                space = self.observation_space(name)
                observations[name] = np.zeros(space.shape, dtype=space.dtype)
        ended_by_time = {name: bool(truncated.get(name, False)) for name in live}
        terminations = {name: over and not ended_by_time[name] for name in live}
        truncations = {name: over and ended_by_time[name] for name in live}
        self.agents = [] if over else live
        return observations, rewards, terminations, truncations, infos

    def _completed(self, infos: dict[str, dict[str, Any]], state: GameState,
                   ) -> dict[str, dict[str, Any]]:
        """Every agent's info with the same keys (numeric infos): ``captured`` and
        ``arrived`` (the episode's counts at the end of the decision), ``status`` and
        ``captured_by`` (a defender's: 0 and -1), ``active`` (in play now); agents not in
        ``infos`` (out of the game, kept) repeat their last, with ``captured_by`` -1."""
        codes = [status.code for status in state.attacker_status]
        counts = {"captured": codes.count(_CAPTURED), "arrived": codes.count(_ARRIVED)}
        numeric = self.info_format == "numeric"
        in_play = set(self.game.agents)
        completed = {}
        for name in self.agents:
            if name in infos:
                info = dict(infos[name])
            else:
                info = dict(self._last_infos[name])
                if numeric:
                    info["captured_by"] = -1
                else:
                    info.pop("captured_by", None)
            if numeric and self._index[name] >= self._m:
                info.setdefault("status", 0)
                info.setdefault("captured_by", -1)
            info.update(counts, active=name in in_play)
            completed[name] = info
        self._last_infos.update(completed)
        return completed

    # ------------------------------------------------------------ the rest
    def state(self) -> np.ndarray:
        """The global state (``ReachAvoidEnv.state``)."""
        return self.game.state()


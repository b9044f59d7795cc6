"""Training views of the game: attackers learn, scripted policies drive everyone else.

- ``AttackerParallelEnv``: a PettingZoo ``ParallelEnv`` whose agents are the attackers only;
  a defender policy moves the defenders every step.
- ``SingleAttackerEnv``: a Gymnasium ``Env`` for one learning attacker; a defender policy
  moves the defenders and, with more than one attacker, a teammate policy moves the others.

Both take policy objects (``reachavoid_env.Policy``: ``reset(scenario)``, ``act(state)``)
or factories ``scenario -> policy``; this module imports no policy. Give a factory when the
env is pickled or sent to a subprocess (``AsyncVectorEnv``) and the policy is heavy to copy:
each copy of the env builds its own policy from it. Both inherit ``EzPickle``, so a pickled
env is rebuilt from its constructor arguments (a fresh, un-reset env).

``continuous_actions=False`` gives the learners MPE2's discrete actions
(``reachavoid_env.actions``: stay or 8 full-speed headings).
``action_repeat = k`` holds each learner action for ``k`` env steps; rewards are summed
over the held steps, and ``metadata["render_fps"]`` is ``1 / (k dt)``: one frame per
learner step plays back in real time. ``starts="random"`` draws every player's start at
every reset (``ReachAvoidEnv``), seeded by ``reset(seed=...)``.

The scripted policies act every env step (``dt`` seconds) unless
``scripted_every = k > 1``: then they are asked every ``k`` env steps, and at once when a
player leaves the game, and their actions are held in between (a zero-order hold, for
training throughput with expensive policies; ``benchmarks/training_throughput.py``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium
import numpy as np
from gymnasium.utils import EzPickle
from pettingzoo import ParallelEnv

from reachavoid_env import checks
from reachavoid_env.actions import action_space, control
from reachavoid_env.environment import GameView, ParallelView, ReachAvoidEnv, check_agent_names
from reachavoid_env.game_state import AttackerStatus
from reachavoid_env.maps import ScenarioSource
from reachavoid_env.policy import PerMapPolicy, Policy, build_policy, merged_overlay
from reachavoid_env.rewards import team_bonus, timeout
from reachavoid_env.scenario import Scenario
from reachavoid_env.video import realtime_fps

PolicySource = Policy | Callable[[Scenario], Policy]


def scripted_policy(source: Any, game: ReachAvoidEnv, field: str) -> Policy:
    """``build_policy`` for ``game``'s one map; for a library of maps a ``PerMapPolicy``
    when ``source`` is a factory (a policy object must play every map itself)."""
    if len(game.scenarios) > 1 and callable(source) and not isinstance(source, (Policy, type)):
        return PerMapPolicy(source, field, first=game.base_scenario)
    return build_policy(source, game.base_scenario, field)


class _Scripted:
    """The game plus the policies that move its scripted players.

    ``scripted`` holds ``(policy, names)``: the policy acts for the agents in ``names``
    (every other key it returns is ignored). The policies are asked every ``every`` env
    steps, and whenever a player has left the game; their actions are held in between.
    """

    def __init__(self, game: ReachAvoidEnv,
                 scripted: list[tuple[Policy, frozenset[str]]], every: int) -> None:
        self.game = game
        self.scripted = scripted
        self.every = every
        self._held: dict[str, Any] = {}
        self._since = 0
        self._live = 0

    def reset(self, seed: int | None, options: dict[str, Any] | None,
              ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        observations, infos = self.game.reset(seed=seed, options=options)
        for policy, _ in self.scripted:
            policy.reset(self.game.scenario)
        self._held, self._since = {}, self.every
        self._show_overlay()
        return observations, infos

    def step(self, learner_actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        """One env step: scripted actions for the live scripted agents, ``learner_actions``
        for the live learners (a missing one is a ``KeyError`` naming it)."""
        game = self.game
        live = game.agents
        if self._since >= self.every or len(live) != self._live:
            self._decide()
        self._since += 1
        actions = {**self._held, **learner_actions}
        missing = [name for name in live if name not in actions]
        if missing:
            raise KeyError(f"step: no action for live agent {missing[0]!r}")
        return game.step({name: actions[name] for name in live})

    def _decide(self) -> None:
        state = self.game.game_state()
        held: dict[str, Any] = {}
        for policy, names in self.scripted:
            chosen = policy.act(state)
            held.update((name, chosen[name]) for name in names.intersection(chosen))
        self._held, self._since, self._live = held, 0, len(self.game.agents)
        self._show_overlay()

    def _show_overlay(self) -> None:
        if self.game.render_mode is not None:
            self.game.set_overlay(merged_overlay(*(policy for policy, _ in self.scripted)))


def _metadata(metadata: dict[str, Any], game: ReachAvoidEnv, action_repeat: int,
              ) -> dict[str, Any]:
    """``metadata`` with ``render_fps`` such that one frame per learner step (``action_repeat``
    env steps of ``dt`` seconds) plays back in real time."""
    return {**metadata, "render_fps": realtime_fps(game.base_scenario.dt, action_repeat)}


class _OnGame(GameView):
    """What the training views share: their own options, checked, and the game they open."""

    metadata: dict[str, Any]

    def _open_game(self, scenario: ScenarioSource, max_cycles: int | None,
                   render_mode: str | None, shaping: float, timeout_reward: float,
                   action_repeat: int, scripted_every: int, render_width: int,
                   info_format: str, starts: str, observation: Any,
                   continuous_actions: bool) -> ReachAvoidEnv:
        """Check the view's own options, set them and ``metadata``, and build the game
        (which checks the rest)."""
        self.continuous_actions = checks.flag(continuous_actions, "continuous_actions")
        self.timeout_reward = checks.real(timeout_reward, "timeout_reward")
        self.action_repeat = checks.integer(action_repeat, "action_repeat", 1, 1_000_000)
        self.scripted_every = checks.integer(scripted_every, "scripted_every", 1, 1_000_000)
        game = ReachAvoidEnv(scenario=scenario, max_cycles=max_cycles, render_mode=render_mode,
                             shaping=shaping, render_width=render_width, info_format=info_format,
                             starts=starts, observation=observation)
        self.metadata = _metadata(self.metadata, game, self.action_repeat)
        self._action_spaces = {name: action_space(self.continuous_actions)
                               for name in game.possible_agents}
        return game

    def _action(self, agent: str, action: Any) -> Any:
        """The continuous action the game steps with (a discrete one through
        ``actions.TABLE``)."""
        return action if self.continuous_actions else control(agent, action)


class AttackerParallelEnv(_OnGame, ParallelView, ParallelEnv, EzPickle):
    """The attackers of a reach-avoid game as a PettingZoo ``ParallelEnv``; ``defenders``
    (a policy or a factory ``scenario -> policy``) moves the defenders every step.

    Agents: ``attacker_0 .. attacker_{M-1}``. Observations, actions, rewards, infos, rules,
    ``state()`` and ``reset`` options are the attackers' part of ``ReachAvoidEnv`` (its
    docstring has the layouts): the attackers' observations (``observation``, as
    ``ReachAvoidEnv``: egocentric by default); action ``Box(-1, 1, (2,))``,
    a velocity as a fraction of the attacker's speed; reward +1 on arrival, -1 on capture
    (plus the optional ``shaping`` progress term, ``timeout_reward`` for an attacker
    still in play when the episode is truncated, and ``team_reward`` times the sum of the
    other attackers' +1 / -1 in the step for an attacker in play, ``team_bonus``). An
    attacker leaves ``agents`` (terminated) on the step it is captured or arrives; after
    ``max_cycles`` env steps the rest are truncated. With ``action_repeat = k`` one step here
    is ``k`` env steps with the attackers' actions held (rewards summed; it ends early when
    no attacker is left).
    ``scripted_every``: see the module docstring.

    ``info_format`` and ``starts`` as ``ReachAvoidEnv`` (numeric infos by default, for
    TorchRL and BenchMARL; the scenario's starts by default, ``"random"`` for new ones at
    every reset).
    ``game`` is the underlying ``ReachAvoidEnv``; ``game_state()`` its state.
    """

    metadata = {
        "name": "reach_avoid_attackers_v0",
        "render_modes": ["human", "rgb_array"],
        "is_parallelizable": True,
    }

    def __init__(self, defenders: PolicySource, scenario: ScenarioSource = "paper_2v1",
                 max_cycles: int | None = None, render_mode: str | None = None,
                 shaping: float = 0.0, timeout_reward: float = 0.0, action_repeat: int = 1,
                 scripted_every: int = 1, render_width: int = 640,
                 info_format: str = "numeric", starts: str = "scenario",
                 observation: Any = None, team_reward: float = 0.0,
                 continuous_actions: bool = True) -> None:
        EzPickle.__init__(self, defenders, scenario=scenario, max_cycles=max_cycles,
                          render_mode=render_mode, shaping=shaping,
                          timeout_reward=timeout_reward, action_repeat=action_repeat,
                          scripted_every=scripted_every, render_width=render_width,
                          info_format=info_format, starts=starts, observation=observation,
                          team_reward=team_reward, continuous_actions=continuous_actions)
        self.team_reward = checks.real(team_reward, "team_reward")
        game = self._open_game(scenario, max_cycles, render_mode, shaping, timeout_reward,
                               action_repeat, scripted_every, render_width, info_format,
                               starts, observation, continuous_actions)
        self.game = game
        self.render_mode = render_mode
        self.defenders = scripted_policy(defenders, game, "defenders")
        self.possible_agents = game.base_scenario.attacker_names
        self._learners = frozenset(self.possible_agents)
        self._core = _Scripted(game, [(self.defenders,
                                       frozenset(game.base_scenario.defender_names))],
                               self.scripted_every)
        self.agents: list[str] = []
        self.state_space = game.state_space

    @property
    def max_cycles(self) -> int:
        """Env steps before truncation (``parallel_api_test`` sets it)."""
        return self.game.max_cycles

    @max_cycles.setter
    def max_cycles(self, value: int) -> None:
        self.game.max_cycles = value

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None,
              ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        observations, infos = self._core.reset(seed, options)
        self.agents = self.possible_agents[:]
        return ({name: observations[name] for name in self.agents},
                {name: infos[name] for name in self.agents})

    def step(self, actions: dict[str, Any]) -> tuple[dict[str, np.ndarray], dict[str, float],
                                                     dict[str, bool], dict[str, bool],
                                                     dict[str, dict[str, Any]]]:
        check_agent_names(actions, self.possible_agents)
        live = self.agents
        if not live:
            return {}, {}, {}, {}, {}
        observations: dict[str, np.ndarray] = {}
        rewards = dict.fromkeys(live, 0.0)
        terminations: dict[str, bool] = {}
        truncations: dict[str, bool] = {}
        infos: dict[str, dict[str, Any]] = {}
        for _ in range(self.action_repeat):
            held = {name: self._action(name, actions[name]) for name in self.game.agents
                    if name in self._learners and name in actions}
            playing = [name for name in self.possible_agents if name in self.game.agents]
            obs, rew, term, trunc, info = self._core.step(held)
            if self.team_reward and any(term[name] for name in playing):
                self._share_outcomes(playing, term, rewards)
            for name in obs.keys() & self._learners:
                observations[name] = obs[name]
                rewards[name] += rew[name] + timeout(trunc[name], self.timeout_reward)
                terminations[name] = term[name]
                truncations[name] = trunc[name]
                infos[name] = info[name]
            if not any(name in self._learners for name in self.game.agents):
                break
        self.agents = [name for name in self.game.agents if name in self._learners]
        return observations, rewards, terminations, truncations, infos

    def _share_outcomes(self, playing: list[str], terminated: dict[str, bool],
                        rewards: dict[str, float]) -> None:
        """Add ``team_bonus`` to ``rewards`` of the attackers ``playing`` at the start of
        the env step whose end ``terminated`` reports."""
        status = self.game.game_state().attacker_status
        index = {name: i for i, name in enumerate(self.possible_agents)}
        outcomes = np.array([0.0 if not terminated[name] else
                             1.0 if status[index[name]] is AttackerStatus.ARRIVED else -1.0
                             for name in playing])
        bonus = team_bonus(outcomes, np.ones(len(playing), dtype=bool), self.team_reward)
        for name, value in zip(playing, bonus.tolist(), strict=True):
            rewards[name] += value

    def state(self) -> np.ndarray:
        return self.game.state()


class SingleAttackerEnv(_OnGame, gymnasium.Env, EzPickle):
    """One learning attacker (``attacker_{attacker}``) of a reach-avoid game as a Gymnasium
    ``Env``; ``defenders`` moves the defenders and ``teammates`` the other attackers (each a
    policy or a factory ``scenario -> policy``; ``teammates`` is required when the scenario
    has more than one attacker).

    **Observation**: the learner's observation in ``ReachAvoidEnv`` (``observation``, an
    ``ObservationConfig`` or a dict of its fields: egocentric by default;
    ``reachavoid_env.observations`` has the layouts).

    **Action**: ``Box(-1, 1, (2,), float32)``, the desired velocity as a fraction of the
    attacker's speed (longer vectors are scaled to length 1), held for ``action_repeat``
    env steps of ``dt`` seconds each.

    **Reward**: +1 when the learner reaches the target, -1 when it is captured, 0
    otherwise; with ``shaping > 0`` also ``shaping * (d_before - d_after)`` per env step,
    ``d`` its signed distance to the target in map units. Summed over held steps. On
    truncation a learner still in play also gets ``timeout_reward`` (default 0; -1 scores
    running out the clock as a loss, as in the reach-avoid game, where only arrival wins).

    **Termination**: the learner is captured or arrives (the episode ends there even if
    teammates play on). **Truncation**: ``max_cycles`` env steps (default: the scenario's
    ``max_steps``) pass first. The final step's info has ``is_success`` (the learner
    arrived); every info has the game's ``status``, ``captured_by``, ``captured`` and
    ``arrived`` (in ``info_format``, as ``ReachAvoidEnv``: integer codes by default).

    ``reset(seed=, options=)`` takes ``ReachAvoidEnv``'s options (a scenario with the same
    player counts, start positions); ``starts="random"`` draws every start at every reset
    (``ReachAvoidEnv``). ``game`` is the underlying ``ReachAvoidEnv``.
    ``scripted_every``: see the module docstring.
    Policies keep their own randomness: a seeded reset reseeds the env, not them.
    """

    metadata = {
        "render_modes": ["human", "rgb_array"],
    }

    def __init__(self, defenders: PolicySource, scenario: ScenarioSource = "paper_2v1",
                 attacker: int = 0, teammates: PolicySource | None = None,
                 max_cycles: int | None = None, render_mode: str | None = None,
                 shaping: float = 0.0, timeout_reward: float = 0.0, action_repeat: int = 1,
                 scripted_every: int = 1, render_width: int = 640,
                 info_format: str = "numeric", starts: str = "scenario",
                 observation: Any = None, continuous_actions: bool = True) -> None:
        EzPickle.__init__(self, defenders, scenario=scenario, attacker=attacker,
                          teammates=teammates, max_cycles=max_cycles, render_mode=render_mode,
                          shaping=shaping, timeout_reward=timeout_reward,
                          action_repeat=action_repeat, scripted_every=scripted_every,
                          render_width=render_width, info_format=info_format, starts=starts,
                          observation=observation, continuous_actions=continuous_actions)
        game = self._open_game(scenario, max_cycles, render_mode, shaping, timeout_reward,
                               action_repeat, scripted_every, render_width, info_format,
                               starts, observation, continuous_actions)
        base = game.base_scenario
        m = base.num_attackers
        if isinstance(attacker, bool) or not isinstance(attacker, int) \
                or not 0 <= attacker < m:
            raise ValueError(f"attacker: must be an attacker index in 0..{m - 1} for scenario "
                             f"{base.name!r}, got {attacker!r}")
        self.game = game
        self.render_mode = render_mode
        self.learner = f"attacker_{attacker}"
        self._learner_index = attacker
        self.defenders = scripted_policy(defenders, game, "defenders")
        scripted = [(self.defenders, frozenset(base.defender_names))]
        self.teammates: Policy | None = None
        if m > 1:
            if teammates is None:
                raise ValueError(f"teammates: scenario {base.name!r} has {m} attackers; give "
                                 f"a policy (or factory) for the ones besides {self.learner}")
            self.teammates = scripted_policy(teammates, game, "teammates")
            others = frozenset(base.attacker_names) - {self.learner}
            scripted.append((self.teammates, others))
        self._core = _Scripted(game, scripted, self.scripted_every)
        self.observation_space = game.observation_space(self.learner)
        self.action_space = self._action_spaces[self.learner]

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None,
              ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        observations, infos = self._core.reset(seed, options)
        return observations[self.learner], infos[self.learner]

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        learner = self.learner
        if learner not in self.game.agents:
            raise RuntimeError("step: the episode has ended; call reset()")
        action = self._action(learner, action)
        total = 0.0
        for _ in range(self.action_repeat):
            obs, rewards, terminations, truncations, infos = self._core.step({learner: action})
            total += rewards[learner]
            terminated, truncated = terminations[learner], truncations[learner]
            if terminated or truncated:
                break
        total += timeout(truncated, self.timeout_reward)
        info = infos[learner]
        if terminated or truncated:
            status = self.game.game_state().attacker_status[self._learner_index]
            info["is_success"] = status is AttackerStatus.ARRIVED
        return obs[learner], total, terminated, truncated, info

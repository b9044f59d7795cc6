"""The multi-agent reach-avoid game as a PettingZoo ``ParallelEnv`` (design.md section 1).

``ReachAvoidEnv`` is the parallel env; ``env()`` / ``raw_env()`` give the AEC version.
The rules themselves live in ``rules``; ``step`` applies them in named phases.

Version History: in ``reach_avoid_v2`` (v2 plays this env in decisions; v0 and v1 are
this env with the global and the egocentric observation, bit for bit).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import gymnasium
import numpy as np
from gymnasium.utils import EzPickle, seeding
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils import ClipOutOfBoundsWrapper, OrderEnforcingWrapper, parallel_to_aec

from reachavoid_env import checks, rules
from reachavoid_env.game_state import AttackerStatus, GameState, Overlay
from reachavoid_env.maps import ScenarioSource, load_library
from reachavoid_env.observations import (
    Normaliser,
    ObservationConfig,
    Observer,
    agent_rows,
    player_table,
)
from reachavoid_env.rewards import outcomes, progress, zero_sum
from reachavoid_env.scenario import MAX_STEPS, Scenario, ScenarioError
from reachavoid_env.world import World

_STATUSES = tuple(AttackerStatus)   # index = AttackerStatus.code
_CAPTURED, _ARRIVED = AttackerStatus.CAPTURED.code, AttackerStatus.ARRIVED.code
INFO_FORMATS = ("numeric", "readable")
STARTS = ("scenario", "random")
_RESET_OPTIONS = ("scenario", "attackers", "defenders", "attacker_reach")


class ReachAvoidEnv(ParallelEnv, EzPickle):
    """M attackers race to a target region; N faster defenders try to capture them first.

    Agents: ``attacker_0 .. attacker_{M-1}`` then ``defender_0 .. defender_{N-1}``.
    Players are single integrators, ``x' = speed * u``, in a rectangular domain with
    obstacles (walls stop players, who slide along them); one step lasts the scenario's
    ``dt`` seconds.

    **Actions** (every agent): ``Box(-1, 1, (2,), float32)``, the desired velocity as a
    fraction of the player's speed. Vectors longer than 1 are scaled to length 1.

    **Observations** (every agent, one size for all; ``reachavoid_env.observations``
    gives the layouts, and ``observe`` computes the same from a ``GameState``):
    ``Box(-1, 1, (D,), float32)``. ``observation`` (an ``ObservationConfig``, or a dict of
    its fields) chooses what is in it. The default is **egocentric** (v1): own position and
    velocity, the target's nearest point relative to the agent and its signed distance,
    ``lidar_rays`` (16) lidar distances to walls and obstacles, every teammate's and then
    every opponent's relative position, velocity and active flag, and the time left;
    ``D = 7 + R + 5 (M + N - 1) + 1``. ``ObservationConfig(egocentric=False)`` is v0's
    global vector, ``D = 2 + 3 (M + N)``: own position, then every player's normalised
    position and active flag. ``state()`` is always the global table without the two
    leading own-position entries (``state_space``, ``3 (M + N)``).

    **Rules** (design.md section 1): within one step every player moves along a straight
    segment from its old to its new position; an active attacker is captured at the
    first instant a defender is within ``capture_radius`` and arrives at the first
    instant it touches the target (inclusive bounds); the earlier event wins, a tie goes
    to capture. Captured and arrived attackers leave ``agents``; the defenders leave when
    no attacker remains. After ``max_cycles`` steps (default: the scenario's
    ``max_steps``) every remaining agent is truncated.

    **Rewards**: an attacker gets +1 on arrival, -1 on capture, 0 otherwise; every
    defender gets minus the sum of the attackers' rewards of that step (a zero-sum team
    game). With ``shaping > 0`` each attacker active at the start of a step also gets
    ``shaping * (d_before - d_after)``, where ``d`` is its signed distance to the target
    in map units (the potential-based progress term; it sums to
    ``shaping * (d_start - d_end)`` over an episode), and the defenders get its negated
    sum too. Off by default.

    **Infos**: every agent gets ``captured`` and ``arrived`` (the episode's counts so
    far); attackers also get ``status`` and ``captured_by``. With
    ``info_format="numeric"`` (the default, which tensor-based libraries such as TorchRL
    accept) every value is an ``int`` and every agent has the same keys from ``reset()``
    on: ``status`` is ``AttackerStatus.code`` (0 active, 1 captured, 2 arrived;
    ``AttackerStatus.from_code`` reads it back) and ``captured_by`` the index ``j`` of the
    capturing ``defender_j`` on the step of the capture, ``-1`` otherwise. With
    ``info_format="readable"`` ``status`` is an ``AttackerStatus`` and ``captured_by``
    (the defender's name) appears only on the step of the capture.

    ``scenario``: a built-in name, a TOML file, a ``Scenario``, or a library of maps (a
    folder or ``index.toml`` written by ``reachavoid maps``, or a list of any of these;
    ``maps.load_library``) whose maps share the player counts: each reset then plays one
    map drawn with the env's generator, so the seed of ``reset`` decides map and starts.

    **Starts**: ``starts="scenario"`` (the default) plays the scenario's start positions
    (drawn at random only where the scenario gives none); ``starts="random"`` draws every
    player's start at every reset, uniformly over the map's free space
    (``Scenario.with_players`` with the scenario's player counts; every map of a library),
    from the env's generator, so ``reset(seed=s)`` gives the same starts for the same ``s``.

    ``reset(seed=, options=)`` options (all optional, for this episode only):
    ``{"scenario": Scenario}`` with the same numbers of players, and/or
    ``{"attackers": (M, 2), "defenders": (N, 2)}`` start positions in map units (a missing
    side keeps the scenario's starts, or draws random ones). Invalid starts raise
    ``ValueError`` naming the player. ``{"attacker_reach": D}`` draws random attacker starts
    within ``D`` map units of the target (easy starts for a curriculum,
    ``Scenario.starts``; fixed attacker starts are kept as they are).

    Rendering (``render_mode`` "rgb_array" or "human") draws ``game_state()`` with the
    overlay last given to ``set_overlay``, under the title given to ``set_caption``, and
    the outcome once the episode is over; "human" also draws after every reset and step.
    """

    metadata = {
        "name": "reach_avoid_v0",
        "render_modes": ["human", "rgb_array"],
        "render_fps": 50,
        "is_parallelizable": True,
    }
    _watch: rules.EventWatch | None = None
    _watched_world: World | None = None  # the episode _watch belongs to (reset: a new world)

    def __init__(
        self,
        scenario: ScenarioSource = "paper_2v1",
        max_cycles: int | None = None,
        render_mode: str | None = None,
        shaping: float = 0.0,
        render_width: int = 640,
        info_format: str = "numeric",
        starts: str = "scenario",
        observation: ObservationConfig | Mapping[str, Any] | None = None,
    ) -> None:
        EzPickle.__init__(self, scenario=scenario, max_cycles=max_cycles,
                          render_mode=render_mode, shaping=shaping, render_width=render_width,
                          info_format=info_format, starts=starts, observation=observation)
        self.observation = observation_config(observation)
        self.metadata = {**self.metadata, "name": "reach_avoid_v1"
                         if self.observation.egocentric else "reach_avoid_v0"}
        if starts not in STARTS:
            raise ValueError(f"starts: {starts!r} is not one of {STARTS}")
        self.starts = starts
        self.scenarios = library(scenario, starts)
        self.base_scenario = self.scenarios[0]
        if max_cycles is not None:
            checks.integer(max_cycles, "max_cycles", 1, MAX_STEPS)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode: {render_mode!r} is not one of "
                             f"{self.metadata['render_modes']} or None")
        if info_format not in INFO_FORMATS:
            raise ValueError(f"info_format: {info_format!r} is not one of {INFO_FORMATS}")
        self.info_format = info_format
        self.max_cycles = max_cycles if max_cycles is not None else self.base_scenario.max_steps
        self.render_mode = render_mode
        self.shaping = checks.real(shaping, "shaping", 0.0)
        self.render_width = checks.integer(render_width, "render_width", 16, 4096)
        self.scenario = self.base_scenario

        m, n = self.base_scenario.num_attackers, self.base_scenario.num_defenders
        self._m, self._n = m, n
        self.possible_agents = self.base_scenario.attacker_names + self.base_scenario.defender_names
        self.agents: list[str] = []
        self._index = {name: i for i, name in enumerate(self.possible_agents)}
        players = m + n
        size = self.observation.size(m, n)
        self._observation_spaces = {
            name: gymnasium.spaces.Box(-1.0, 1.0, (size,), np.float32)
            for name in self.possible_agents
        }
        self._action_spaces = {
            name: gymnasium.spaces.Box(-1.0, 1.0, (2,), np.float32)
            for name in self.possible_agents
        }
        self.state_space = gymnasium.spaces.Box(-1.0, 1.0, (3 * players,), np.float32)
        self.np_random: np.random.Generator | None = None
        self.np_random_seed: int | None = None
        self._world: World | None = None
        self._renderer: Any = None
        self._overlay: Overlay | None = None
        self._caption: str | None = None
        self._observer: Observer | None = None
        self._observer_map: Any = None
        self.observing = True
        """``False``: ``step`` returns no observations (v2 asks ``observe`` once a decision)."""

    # ----------------------------------------------------------------- spaces
    def observation_space(self, agent: str) -> gymnasium.spaces.Box:
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> gymnasium.spaces.Box:
        return self._action_spaces[agent]

    # ------------------------------------------------------------------ reset
    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None,
              ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        if seed is not None or self.np_random is None:
            self.np_random, self.np_random_seed = seeding.np_random(seed)
        try:
            options = _checked_options(options)
            scenario = self._episode_scenario(options)
            attackers, defenders = scenario.starts(self.np_random, options.get("attacker_reach"))
            self.scenario = scenario.with_starts(attackers, defenders)
        except ScenarioError as err:
            raise ScenarioError(f"reset: {_name_player(err, self._m, self._n)}",
                                err.field) from None
        sc = self.scenario
        m = self._m
        positions = np.concatenate([attackers, defenders])
        self._world = World(sc.map, sc.player_radius, positions,
                            max(sc.attacker_speed, sc.defender_speed), sc.dt)
        self._positions = positions
        self._active = np.ones(len(positions), dtype=bool)
        self._all_active = True
        self._no_rewards = np.zeros(len(positions))
        self._status = np.zeros(m, dtype=np.int8)
        self._longest_move = rules.longest_move(max(sc.attacker_speed, sc.defender_speed),
                                                sc.dt)
        self._speeds = np.concatenate([np.full(m, sc.attacker_speed),
                                       np.full(self._n, sc.defender_speed)])[:, None]
        self._normaliser = Normaliser.of(sc.map)
        self._velocities = np.zeros_like(positions)
        if self.observation.egocentric and self._observer_map is not sc.map:
            self._observer = Observer(self.observation, sc.map, m, self._n,
                                      max(sc.attacker_speed, sc.defender_speed),
                                      self.max_cycles)
            self._observer_map = sc.map
        self._target_bounds = rules.target_bounds(sc.map)
        self._steps = 0
        self._captured_count = 0
        self._arrived_count = 0
        self.agents = self.possible_agents[:]
        self._overlay = None  # the last episode's decisions do not describe this one
        if self._renderer is not None:
            if self._renderer_key != (sc.map, sc.capture_radius):
                self._renderer.close()
                self._renderer = None
            else:
                self._renderer.reset()
        observations = self._observations(self.agents, slice(None))
        infos = self._infos(self.agents, np.full(m, -1))
        if self.render_mode == "human":
            self.render()
        return observations, infos

    def _episode_scenario(self, options: dict[str, Any]) -> Scenario:
        if "scenario" not in options:
            scenario = draw_scenario(self.scenarios, self.np_random)[0]
        else:
            scenario = options["scenario"]
            if not isinstance(scenario, Scenario):
                raise TypeError(f"options['scenario']: expected a Scenario, "
                                f"got {type(scenario).__name__}")
            if (scenario.num_attackers, scenario.num_defenders) != (self._m, self._n):
                raise ValueError(
                    f"options['scenario']: has {scenario.num_attackers} attackers and "
                    f"{scenario.num_defenders} defenders; this env has {self._m} and {self._n}")
        for role, count in (("attackers", self._m), ("defenders", self._n)):
            if options.get(role) is not None:
                points = _start_points(options[role], count, role)
                scenario = replace(scenario, **{role: points})
        return scenario

    # ------------------------------------------------------------------- step
    def step(self, actions: dict[str, Any]) -> tuple[dict[str, np.ndarray], dict[str, float],
                                                     dict[str, bool], dict[str, bool],
                                                     dict[str, dict[str, Any]]]:
        """One step of ``dt`` seconds: controls, move, events, rewards, outputs."""
        if self._world is None:
            raise RuntimeError("step: call reset() first (a new or unpickled env is not reset)")
        if not isinstance(actions, Mapping):
            raise TypeError(f"step: actions must be a dict {{agent name: action}}, got "
                            f"{type(actions).__name__}")
        check_agent_names(actions, self.possible_agents)
        live = self.agents
        if not live:
            return {}, {}, {}, {}, {}
        rows = slice(None) if len(live) == len(self.possible_agents) else [
            self._index[name] for name in live]
        velocities = self._controls(live, rows, actions)
        old, new = self._move(velocities)
        events = self._resolve_events(old, new, velocities)
        rewards = self._rewards(events, old, new)
        self._steps += 1
        return self._outputs(live, rows, events, rewards)

    def _controls(self, live: list[str], rows: slice | list[int],
                  actions: dict[str, Any]) -> np.ndarray:
        """Phase 1: every player's velocity ``(M + N, 2)``, map units per second (players
        out of the game stand still)."""
        stacked = self._stack_actions(live, actions)
        if isinstance(rows, slice):
            controls = stacked
        else:
            controls = np.zeros((len(self.possible_agents), 2))
            controls[rows] = stacked
        return rules.bounded_controls(controls) * self._speeds

    def _move(self, velocities: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Phase 2: positions before and after the world's step (walls stop and slide)."""
        old = self._positions
        new = self._world.step(velocities)
        if not self._all_active:
            new[~self._active] = old[~self._active]
        return old, new

    def _resolve_events(self, old: np.ndarray, new: np.ndarray,
                        velocities: np.ndarray) -> rules.StepEvents:
        """Phase 3: captures and arrivals along the paths the world moved the players along
        (``rules``: straight segments, sub-step polylines for players that slid); attackers
        that left stop where their event happened, and the defenders leave with the last.
        A step that ``rules.EventWatch`` knows to have no event skips the rules."""
        m = self._m
        world = self._world
        if self._watched_world is not world:
            self._watch = rules.EventWatch(self.scenario.capture_radius, self._target_bounds,
                                           self._longest_move)
            self._watched_world = world
        if self._watch.quiet():
            self._positions = new
            if self.observation.egocentric:
                self._velocities = (new - old) / self.scenario.dt
                self._velocities[~self._active] = 0.0
            return rules.no_events(new[:m])
        moves = rules.Moves(velocities, self.scenario.dt,
                            lambda players: world.replay(old[players], velocities[players]),
                            self._longest_move)
        events = rules.resolve_events(self.scenario.map, self.scenario.capture_radius,
                                      self._active[:m].copy(), old[:m], new[:m], old[m:],
                                      new[m:], self._target_bounds, moves)
        left = events.left
        if left.any():
            new[:m][left] = events.stops[left]
            self._status[events.captured] = _CAPTURED
            self._status[events.arrived] = _ARRIVED
            self._captured_count += int(events.captured.sum())
            self._arrived_count += int(events.arrived.sum())
            self._active[:m] &= ~left
            if not self._active[:m].any():
                self._active[m:] = False
            self._all_active = False
        self._positions = new
        self._watch.anchor(self._active[:m], new[:m], new[m:])
        if self.observation.egocentric:
            self._velocities = (new - old) / self.scenario.dt
            self._velocities[~self._active] = 0.0
        return events

    def _rewards(self, events: rules.StepEvents, old: np.ndarray,
                 new: np.ndarray) -> np.ndarray:
        """Phase 4: ``(M + N,)`` rewards (``reachavoid_env.rewards``): +1 arrival, -1
        capture, the ``progress`` term for the attackers active at the start of the step;
        each defender gets minus their sum."""
        m = self._m
        if not self.shaping and not events.left.any():
            return self._no_rewards
        attackers = outcomes(events.arrived, events.captured)
        if self.shaping:
            distance = self.scenario.map.target_signed_distance
            started = (self._status == 0) | events.left
            attackers += progress(distance(old[:m]), distance(new[:m]), started, self.shaping)
        return zero_sum(attackers, self._n)

    def _outputs(self, live: list[str], rows: slice | list[int], events: rules.StepEvents,
                 rewards: np.ndarray) -> tuple[dict, dict, dict, dict, dict]:
        """Phase 5: observations, rewards, terminations, truncations and infos of the agents
        live at the start of the step; the agents that ended leave ``agents``."""
        truncate = self._steps >= self.max_cycles
        observations = self._observations(live, rows) if self.observing else {}
        reward_dict = dict(zip(live, rewards[rows].tolist(), strict=True))
        infos = self._infos(live, events.captor)
        if events.left.any() or truncate:
            ended = (~self._active[rows]).tolist()
            terminations = dict(zip(live, ended, strict=True))
            truncations = {name: truncate and not done
                           for name, done in zip(live, ended, strict=True)}
            self.agents = [] if truncate else [name for name, done in zip(live, ended,
                                                                          strict=True)
                                               if not done]
        else:
            terminations = dict.fromkeys(live, False)
            truncations = dict.fromkeys(live, False)
        if self.render_mode == "human":
            self.render()
        return observations, reward_dict, terminations, truncations, infos

    def _stack_actions(self, live: list[str], actions: dict[str, Any]) -> np.ndarray:
        """The live agents' actions as a ``(L, 2)`` float64 array (validated)."""
        for name in live:
            if name not in actions:
                raise KeyError(f"step: no action for live agent {name!r}")
            if getattr(getattr(actions[name], "dtype", None), "kind", "") not in REAL_KINDS:
                _checked_action(name, actions[name])   # a list, or not real numbers: refused
        try:
            stacked = np.array([actions[name] for name in live], dtype=np.float64)
        except (TypeError, ValueError):
            stacked = None
        if stacked is None or stacked.shape != (len(live), 2) \
                or not np.isfinite(stacked).all():
            stacked = np.array([_checked_action(name, actions[name]) for name in live])
        return stacked

    # ----------------------------------------------------------- observations
    def _state_matrix(self) -> np.ndarray:
        """``(M + N, 3)`` float32: normalised x, y and the active flag of every player."""
        return player_table(self._positions, self._active, self._normaliser)

    def observe(self, agents: list[str]) -> dict[str, np.ndarray]:
        """The observations ``step`` would give ``agents`` (in or out of the game) now."""
        return self._observations(agents, [self._index[name] for name in agents])

    def _observations(self, agents: list[str], rows: slice | list[int],
                      ) -> dict[str, np.ndarray]:
        """Observations of ``agents`` (rows ``rows`` of the players), one fresh matrix
        (``reachavoid_env.observations``, the code path of ``observe``)."""
        if not self.observation.egocentric:
            return dict(zip(agents, agent_rows(self._state_matrix(), rows), strict=True))
        table = self._observer(self._positions[None], self._velocities[None],
                               self._active[None], np.array([self._steps]))[0]
        return dict(zip(agents, table[rows], strict=True))

    def _infos(self, agents: list[str], captor: np.ndarray) -> dict[str, dict[str, Any]]:
        """Every agent's info (fresh dicts): the episode's counts, and each attacker's
        ``status`` and ``captured_by`` in ``info_format``."""
        captured, arrived, m = self._captured_count, self._arrived_count, self._m
        codes, captors = self._status.tolist(), captor.tolist()
        numeric = self.info_format == "numeric"
        infos: dict[str, dict[str, Any]] = {}
        for name in agents:
            i = self._index[name]
            if i >= m:
                infos[name] = {"captured": captured, "arrived": arrived}
            elif numeric:
                infos[name] = {"captured": captured, "arrived": arrived, "status": codes[i],
                               "captured_by": captors[i]}
            else:
                infos[name] = {"captured": captured, "arrived": arrived,
                               **self._readable_info(codes[i], captors[i])}
        return infos

    def _readable_info(self, code: int, captor: int) -> dict[str, Any]:
        """``status`` (an ``AttackerStatus``) and, on the step of a capture, ``captured_by``
        (the defender's name) of an attacker."""
        if captor < 0:
            return {"status": _STATUSES[code]}
        return {"status": _STATUSES[code], "captured_by": self.possible_agents[self._m + captor]}

    def state(self) -> np.ndarray:
        """Global state ``(3 (M + N),)`` float32 (layout in the class docstring)."""
        if self._world is None:
            raise RuntimeError("state: call reset() first")
        return self._state_matrix().reshape(-1)

    def game_state(self) -> GameState:
        """The current ``GameState`` (positions in map units, statuses, time in seconds)."""
        if self._world is None:
            raise RuntimeError("game_state: call reset() first")
        sc = self.scenario
        return GameState(
            time=self._steps * sc.dt,
            step=self._steps,
            attacker_positions=self._positions[:self._m],
            defender_positions=self._positions[self._m:],
            attacker_status=tuple(_STATUSES[s] for s in self._status),
            attacker_speed=sc.attacker_speed,
            defender_speed=sc.defender_speed,
            capture_radius=sc.capture_radius,
            velocities=self._velocities if self.observation.egocentric else None,
        )

    # -------------------------------------------------------------- rendering
    def set_overlay(self, overlay: Overlay | None) -> None:
        """Draw ``overlay`` (a policy's assignment edges, text) on the following frames of
        this episode (``reset`` clears it): edges to attackers no longer in play are left
        out; the text stays to the last frame."""
        self._overlay = overlay

    def set_caption(self, caption: str | None) -> None:
        """The title line of the following frames (``None``: the scenario and the seed);
        ``run_episode`` names the scenario, the policies and the seed."""
        self._caption = caption

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gymnasium.logger.warn(
                "You are calling render method without specifying any render mode. "
                "Pass render_mode='rgb_array' or 'human' to the constructor.")
            return None
        if self._world is None:
            raise RuntimeError("render: call reset() first (there is no game to draw yet)")
        if self._renderer is None:
            from reachavoid_env.render import Renderer

            sc = self.scenario
            self._renderer = Renderer(sc.map, sc.capture_radius, width=self.render_width)
            self._renderer_key = (sc.map, sc.capture_radius)
        state = self.game_state()
        caption = self._caption or f"{self.scenario.name}, seed {self.np_random_seed}"
        self._renderer.draw(state, _live_part(self._overlay, state), title=caption,
                            game_over=not self.agents)
        if self.render_mode == "rgb_array":
            return self._renderer.rgb_array()
        self._renderer.show(self.metadata["render_fps"])
        return None

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


REAL_KINDS = ("i", "u", "f")
"""numpy dtype kinds of real numbers (not bool, complex, strings or objects)."""


def _real_number(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) \
        and not isinstance(value, (bool, np.bool_))


def _checked_action(agent: str, action: Any) -> np.ndarray:
    """``action`` as a float64 ``(2,)`` array; ``ValueError`` naming ``agent`` if it is not
    a finite 2-vector of real numbers (an array of a real dtype, or a sequence of ints and
    floats: not strings, booleans or complex numbers, which numpy would convert)."""
    kind = getattr(getattr(action, "dtype", None), "kind", None)
    if kind == "c" or isinstance(action, complex):
        raise ValueError(f"action for {agent}: expected real numbers, got complex {action!r}")
    if kind is None:
        real = not isinstance(action, (str, bytes)) and all(map(_real_number, _items(action)))
    else:
        real = kind in REAL_KINDS
    if not real:
        raise ValueError(f"action for {agent}: expected a 2-vector of real numbers, "
                         f"got {action!r}")
    try:
        array = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"action for {agent}: expected a 2-vector of numbers, "
                         f"got {action!r}") from None
    if array.shape != (2,):
        raise ValueError(f"action for {agent}: expected shape (2,), got {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"action for {agent}: must be finite, got {array.tolist()}")
    return array


def _items(action: Any) -> list[Any]:
    """The elements of a sequence ``action`` (``[action]`` for anything else)."""
    try:
        return list(action)
    except TypeError:
        return [action]


def check_agent_names(actions: dict[str, Any], agents: Sequence[str]) -> None:
    """``KeyError`` naming the first key of ``actions`` that is not one of ``agents``."""
    for name in actions:
        if name not in agents:
            raise KeyError(f"step: {name!r} is not an agent of this env "
                           f"(agents: {', '.join(agents)})")


def _live_part(overlay: Overlay | None, state: GameState) -> Overlay | None:
    """What of a policy's overlay still describes the game: its edges to attackers in play,
    and its text lines (the last decision's, kept to the last frame)."""
    if overlay is None:
        return None
    live = {state.attacker_names[i] for i in np.flatnonzero(state.active_attackers)}
    kept = [edge for edge in overlay.kinded_edges if edge.attacker in live]
    return Overlay(edges=tuple((e.defender, e.attacker) for e in kept), lines=overlay.lines,
                   kinds=tuple(e.kind for e in kept))


def draw_scenario(scenarios: Sequence[Scenario], rng: np.random.Generator,
                  ) -> tuple[Scenario, int]:
    """The scenario of an episode and its index: one drawn with ``rng`` from a library of
    several maps, the only one otherwise (no draw)."""
    index = int(rng.integers(len(scenarios))) if len(scenarios) > 1 else 0
    return scenarios[index], index


def library(source: Any, starts: str) -> tuple[Scenario, ...]:
    """The scenarios an env plays (``maps.load_library``), checked to share the player
    counts (the spaces depend on them); with ``starts="random"`` without start positions,
    so that every reset draws them."""
    scenarios = load_library(source)
    first = scenarios[0]
    for scenario in scenarios[1:]:
        if (scenario.num_attackers, scenario.num_defenders) != (first.num_attackers,
                                                                first.num_defenders):
            raise ScenarioError(f"scenario: {scenario.name!r} has {scenario.num_attackers} "
                                f"attackers and {scenario.num_defenders} defenders, "
                                f"{first.name!r} {first.num_attackers} and "
                                f"{first.num_defenders}; a library's maps share the counts")
    if starts == "random":
        scenarios = tuple(s.with_players(s.num_attackers, s.num_defenders) for s in scenarios)
    return scenarios


def _checked_options(options: Any) -> dict[str, Any]:
    """``options`` as a dict; an unknown key is a ``ValueError`` naming it (a typo must not
    silently give random starts). PettingZoo's API tests probe ``reset`` with
    ``{"options": 1}``; that one key is accepted and ignored so that ``pettingzoo.test``
    runs on this env."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise TypeError(f"reset: options must be a dict with keys from {_RESET_OPTIONS}, "
                        f"got {type(options).__name__}")
    unknown = sorted(str(key) for key in options if key not in _RESET_OPTIONS + ("options",))
    if unknown:
        raise ValueError(f"reset: options[{unknown[0]!r}] is not an option (accepted: "
                         f"{', '.join(_RESET_OPTIONS)})")
    if options.get("attacker_reach") is not None:
        checks.positive(options["attacker_reach"], "options['attacker_reach']")
    return options


def _start_points(value: Any, count: int, role: str) -> tuple[tuple[float, float], ...]:
    try:
        points = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"options['{role}']: expected an array of shape ({count}, 2)") from None
    if points.shape != (count, 2):
        raise ValueError(f"options['{role}']: expected shape ({count}, 2), got {points.shape}")
    for i, p in enumerate(points):
        if not np.isfinite(p).all():
            raise ValueError(f"options['{role}'][{i}] ({role[:-1]}_{i}): must be finite, "
                             f"got {p.tolist()}")
    return tuple((float(x), float(y)) for x, y in points)


def _name_player(err: ScenarioError, attackers: int, defenders: int) -> str:
    """The message of ``err``, with the agent's name when its field is one player's start
    (``players.attackers[i]``)."""
    agents = {f"players.{role}s[{i}]": f"{role}_{i}"
              for role, count in (("attacker", attackers), ("defender", defenders))
              for i in range(count)}
    agent = agents.get(err.field or "")
    return f"{err} ({agent})" if agent else str(err)


def observation_config(value: ObservationConfig | Mapping[str, Any] | None,
                       ) -> ObservationConfig:
    """``value`` as an ``ObservationConfig``: itself, the default (``None``), or built from
    a dict of its fields (an unknown key is a ``ValueError`` naming it)."""
    if value is None:
        return ObservationConfig()
    if isinstance(value, ObservationConfig):
        return value
    if isinstance(value, Mapping):
        fields = ObservationConfig.__dataclass_fields__
        for key in value:
            if key not in fields:
                raise ValueError(f"observation.{key}: not an option (accepted: "
                                 f"{', '.join(fields)})")
        return ObservationConfig(**value)
    raise TypeError(f"observation: expected an ObservationConfig or a dict, got "
                    f"{type(value).__name__}")


def parallel_env(**kwargs: Any) -> ReachAvoidEnv:
    """The parallel env; keyword arguments as ``ReachAvoidEnv``."""
    return ReachAvoidEnv(**kwargs)


def raw_env(**kwargs: Any) -> AECEnv:
    """The AEC env converted from the parallel one, without wrappers."""
    return parallel_to_aec(ReachAvoidEnv(**kwargs))


def env(**kwargs: Any) -> AECEnv:
    """The AEC env with PettingZoo's standard wrappers (clip actions, enforce call order)."""
    return OrderEnforcingWrapper(ClipOutOfBoundsWrapper(raw_env(**kwargs)))

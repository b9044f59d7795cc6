"""The multi-agent reach-avoid game as a PettingZoo ``ParallelEnv`` (design.md section 1).

``ReachAvoidEnv`` is the parallel env; ``env()`` / ``raw_env()`` give the AEC version.
It is the batched core (``reachavoid_env.core``, the rules in ``rules``) at one copy, plus
PettingZoo's agent dicts, removal, infos and rendering.

Version History: in ``reach_avoid_v2`` (v2 plays this env in decisions; v0 and v1 are
this env with the global and the egocentric observation, bit for bit).

M attackers race to a target region; N faster defenders try to capture them first.

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

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium
import numpy as np
from gymnasium.utils import EzPickle, seeding
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils import ClipOutOfBoundsWrapper, OrderEnforcingWrapper, parallel_to_aec

from reachavoid_env import checks
from reachavoid_env.core import Core, Stepped
from reachavoid_env.env_inputs import (
    INFO_FORMATS,
    REAL_KINDS,
    STARTS,
    check_agent_names,
    checked_options,
    draw_scenario,
    episode_scenario,
    library,
    name_player,
    observation_config,
    stack_actions,
)
from reachavoid_env.game_state import AttackerStatus, GameState
from reachavoid_env.maps import ScenarioSource
from reachavoid_env.observations import ObservationConfig, Observer, player_table
from reachavoid_env.overlay import Overlay
from reachavoid_env.scenario import MAX_STEPS, ScenarioError

__all__ = ["INFO_FORMATS", "REAL_KINDS", "STARTS", "ReachAvoidEnv", "check_agent_names",
           "draw_scenario", "env", "library", "observation_config", "parallel_env",
           "raw_env"]

_STATUSES = tuple(AttackerStatus)   # index = AttackerStatus.code
_FIRST = np.zeros(1, dtype=np.intp)  # the one copy (and the one map) of the core


class ReachAvoidEnv(ParallelEnv, EzPickle):
    """M attackers race to a target region; N faster defenders try to capture them first
    (the module docstring describes agents, spaces, rules, rewards, infos and options)."""

    metadata = {
        "name": "reach_avoid_v0",
        "render_modes": ["human", "rgb_array"],
        "render_fps": 50,
        "is_parallelizable": True,
    }

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
        size = self.observation.size(m, n)
        self._observation_spaces = {
            name: gymnasium.spaces.Box(-1.0, 1.0, (size,), np.float32)
            for name in self.possible_agents
        }
        self._action_spaces = {
            name: gymnasium.spaces.Box(-1.0, 1.0, (2,), np.float32)
            for name in self.possible_agents
        }
        self.state_space = gymnasium.spaces.Box(-1.0, 1.0, (3 * (m + n),), np.float32)
        self.np_random: np.random.Generator | None = None
        self.np_random_seed: int | None = None
        self._core: Core | None = None
        self._renderer: Any = None
        self._overlay: Overlay | None = None
        self._caption: str | None = None
        self._observers: dict[int, Observer] = {}
        self._observer_map: Any = None   # the map of _observers (made again for another)
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
            options = checked_options(options)
            scenario = episode_scenario(self.scenarios, options, self.np_random, self._m,
                                        self._n)
            attackers, defenders = scenario.starts(self.np_random, options.get("attacker_reach"))
            self.scenario = scenario.with_starts(attackers, defenders)
        except ScenarioError as err:
            raise ScenarioError(f"reset: {name_player(err, self._m, self._n)}",
                                err.field) from None
        sc = self.scenario
        if self._observer_map is not sc.map:
            self._observers, self._observer_map = {}, sc.map
        self._core = Core((sc,), 1, self.observation, self.max_cycles, self.shaping,
                          copies_per_world=1, velocities=self.observation.egocentric,
                          observers=self._observers)
        self._core.place(_FIRST, _FIRST, np.concatenate([attackers, defenders])[None])
        self._observers = self._core.observers
        self.agents = self.possible_agents[:]
        self._overlay = None  # the last episode's decisions do not describe this one
        if self._renderer is not None:
            if self._renderer_key != (sc.map, sc.capture_radius):
                self._renderer.close()
                self._renderer = None
            else:
                self._renderer.reset()
        observations = self._observations(self.agents, slice(None))
        infos = self._infos(self.agents, np.full(self._m, -1))
        if self.render_mode == "human":
            self.render()
        return observations, infos

    # ------------------------------------------------------------------- step
    def step(self, actions: dict[str, Any]) -> tuple[dict[str, np.ndarray], dict[str, float],
                                                     dict[str, bool], dict[str, bool],
                                                     dict[str, dict[str, Any]]]:
        """One step of ``dt`` seconds: the live agents' controls, the core's step (move,
        events, rewards), then PettingZoo's dicts."""
        if self._core is None:
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
        stepped = self._core.step(self._controls(live, rows, actions))
        return self._outputs(live, rows, stepped)

    def _controls(self, live: list[str], rows: slice | list[int],
                  actions: dict[str, Any]) -> np.ndarray:
        """Every player's control ``(1, M + N, 2)`` (zero for players out of the game)."""
        stacked = stack_actions(live, actions)
        if isinstance(rows, slice):
            return stacked[None]
        controls = np.zeros((1, len(self.possible_agents), 2))
        controls[0, rows] = stacked
        return controls

    def _outputs(self, live: list[str], rows: slice | list[int], stepped: Stepped,
                 ) -> tuple[dict, dict, dict, dict, dict]:
        """Observations, rewards, terminations, truncations and infos of the agents live at
        the start of the step; the agents that ended leave ``agents``."""
        core, events = self._core, stepped.events
        truncate = int(core.steps[0]) >= self.max_cycles
        observations = self._observations(live, rows) if self.observing else {}
        reward_dict = dict(zip(live, stepped.rewards[0, rows].tolist(), strict=True))
        infos = self._infos(live, events.captor[0])
        if stepped.left or truncate:
            ended = (~core.active[0, rows]).tolist()
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

    # ----------------------------------------------------------- observations
    def observe(self, agents: list[str]) -> dict[str, np.ndarray]:
        """The observations ``step`` would give ``agents`` (in or out of the game) now."""
        return self._observations(agents, [self._index[name] for name in agents])

    def _observations(self, agents: list[str], rows: slice | list[int],
                      ) -> dict[str, np.ndarray]:
        """Observations of ``agents`` (rows ``rows`` of the players): the core's table."""
        return dict(zip(agents, self._core.observe()[0][rows], strict=True))

    def _infos(self, agents: list[str], captor: np.ndarray) -> dict[str, dict[str, Any]]:
        """Every agent's info (fresh dicts): the episode's counts, and each attacker's
        ``status`` and ``captured_by`` in ``info_format``."""
        core, m = self._core, self._m
        captured, arrived = core.counts[0].tolist()
        codes, captors = core.status[0].tolist(), captor.tolist()
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
        """Global state ``(3 (M + N),)`` float32: every player's normalised x, y and active
        flag (``observations.player_table``)."""
        if self._core is None:
            raise RuntimeError("state: call reset() first")
        core = self._core
        return player_table(core.positions[0], core.active[0],
                            core.observers[0].normaliser).reshape(-1)

    def game_state(self) -> GameState:
        """The current ``GameState`` (positions in map units, statuses, time in seconds)."""
        if self._core is None:
            raise RuntimeError("game_state: call reset() first")
        core, sc, m = self._core, self.scenario, self._m
        step = int(core.steps[0])
        return GameState(
            time=step * sc.dt,
            step=step,
            attacker_positions=core.positions[0, :m],
            defender_positions=core.positions[0, m:],
            attacker_status=tuple(_STATUSES[s] for s in core.status[0]),
            attacker_speed=sc.attacker_speed,
            defender_speed=sc.defender_speed,
            capture_radius=sc.capture_radius,
            velocities=core.velocities[0] if self.observation.egocentric else None,
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
        if self._core is None:
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


def _live_part(overlay: Overlay | None, state: GameState) -> Overlay | None:
    """What of a policy's overlay still describes the game: its edges to attackers in play,
    and its text lines (the last decision's, kept to the last frame)."""
    if overlay is None:
        return None
    live = {state.attacker_names[i] for i in np.flatnonzero(state.active_attackers)}
    kept = [edge for edge in overlay.kinded_edges if edge.attacker in live]
    return Overlay(edges=tuple((e.defender, e.attacker) for e in kept), lines=overlay.lines,
                   kinds=tuple(e.kind for e in kept))


def parallel_env(**kwargs: Any) -> ReachAvoidEnv:
    """The parallel env; keyword arguments as ``ReachAvoidEnv``."""
    return ReachAvoidEnv(**kwargs)


def raw_env(**kwargs: Any) -> AECEnv:
    """The AEC env converted from the parallel one, without wrappers."""
    return parallel_to_aec(ReachAvoidEnv(**kwargs))


def env(**kwargs: Any) -> AECEnv:
    """The AEC env with PettingZoo's standard wrappers (clip actions, enforce call order)."""
    return OrderEnforcingWrapper(ClipOutOfBoundsWrapper(raw_env(**kwargs)))


class GameView:
    """What a view over a ``ReachAvoidEnv`` (its ``game``: the training views, v2's
    decisions) passes straight to the game."""

    game: ReachAvoidEnv

    def game_state(self) -> GameState:
        """The current ``GameState`` (``ReachAvoidEnv.game_state``)."""
        return self.game.game_state()

    def render(self) -> np.ndarray | None:
        return self.game.render()

    def close(self) -> None:
        self.game.close()


class ParallelView(GameView):
    """A PettingZoo view over a ``ReachAvoidEnv``: its agents' observation spaces are the
    game's, their action spaces the view's own ``_action_spaces``, its infos the game's."""

    _action_spaces: dict[str, gymnasium.spaces.Space]

    def observation_space(self, agent: str) -> gymnasium.spaces.Box:
        return self.game.observation_space(agent)

    def action_space(self, agent: str) -> gymnasium.spaces.Space:
        return self._action_spaces[agent]

    @property
    def info_format(self) -> str:
        """``"numeric"`` or ``"readable"`` (``ReachAvoidEnv``)."""
        return self.game.info_format

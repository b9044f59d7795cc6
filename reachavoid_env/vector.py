"""Many copies of one game stepped together: the vector env.

``ReachAvoidVectorEnv(scenario, num_envs=K, ...)`` holds ``K`` copies of the game of
``ReachAvoidEnv`` and steps them in one call; the rules run in numpy over the copy axis
(axis 0 of every array), the players of up to ``COPIES_PER_WORLD`` copies on one map
share one pymunk ``World`` (players touch only the walls, so copies cannot meet).
**Copy k is the single env**: ``reset(seed=s)`` seeds copy ``k`` with ``s + k``
(Gymnasium's convention), and from then on copy ``k`` plays exactly what
``ReachAvoidEnv(...)`` reset with seed ``s + k`` plays for the same actions, its later
episodes included: the same starts, trajectories, rewards, observations and outcomes, bit
for bit (``tests/test_vector_env.py``).

**Arrays**: ``step(actions)`` takes ``{agent: (K, 2)}`` (every agent of
``possible_agents``; rows of players out of the game are ignored; with
``continuous_actions=False`` ``{agent: (K,)}`` integers, ``reachavoid_env.actions``) and returns
``observations {agent: (K, D)}`` float32, ``rewards {agent: (K,)}`` float64,
``terminations`` / ``truncations {agent: (K,)}`` bool and one ``infos`` dict of arrays.
Agents never leave the dicts: an agent out of the game has ``infos["active"]`` false, a
zero reward, and ``terminations`` true only on the step it left (as in the single env,
where it leaves ``agents`` then).

**Autoreset** (Gymnasium's same-step mode): a copy whose game ended in this step (no
attacker left, or ``max_cycles`` steps) is reset at once; the returned observation is the
new episode's first, and ``infos`` keeps the ended episode's last: ``episode_over`` ``(K,)``
marks those copies, ``final_observation {agent: (K, D)}`` holds their last observations
(rows of other copies are the current ones). ``status`` ``(K, M)`` (``AttackerStatus.code``),
``captured_by`` ``(K, M)`` (the capturing defender's index on the step of the capture, else
-1) and ``captured`` / ``arrived`` ``(K,)`` (the episode's counts) describe the game at the
end of the step, before any reset; ``active`` ``(K, M + N)`` describes the returned
observation (every player of a copy that was reset is active).

**Easy starts** (a curriculum): ``start_reach`` (map units, ``None`` by default) may be set
between steps; episodes that start afterwards draw their random attackers within that
distance of the target (``Scenario.starts``' ``attacker_reach``). Set, it ends the match
with the single env; ``None`` again restores it for later episodes.

**Copies per map** (a library of several maps): ``copies_per_map=g`` takes the copies ``g``
at a time (copies ``0..g-1``, ``g..2g-1``, ...); each map a group draws serves its next ``g``
episodes, whichever of its copies start them (the draw is made with the generator of the
copy whose episode comes first). Every map is still drawn uniformly, and episodes on one
map come in runs of ``g`` per group, so a scripted side with a batched class acts on the
copies of a map in one call (``PerMap``) rather than one copy at a time. With ``g > 1`` the
copies that take their group's map no longer match the single env; ``g = 1`` (the default)
is the single env's draw.

With ``autoreset=False`` a copy whose game ended stands still (no player moves, no reward,
no event) until ``reset_copies`` starts its next episode; the training views use this to
hold a learner's action over several steps without running into the next episode.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium
import numpy as np
from gymnasium.utils import seeding

from reachavoid_env import checks, rules
from reachavoid_env.actions import action_space, controls
from reachavoid_env.environment import (
    REAL_KINDS,
    STARTS,
    check_agent_names,
    draw_scenario,
    library,
    observation_config,
)
from reachavoid_env.game_state import AttackerStatus, BatchState
from reachavoid_env.maps import ScenarioSource
from reachavoid_env.observations import ObservationConfig, Observer
from reachavoid_env.rewards import outcomes, progress, zero_sum
from reachavoid_env.scenario import MAX_STEPS, Scenario, ScenarioError
from reachavoid_env.world import World

_CAPTURED, _ARRIVED = AttackerStatus.CAPTURED.code, AttackerStatus.ARRIVED.code
MAX_COPIES = 65_536
COPIES_PER_WORLD = 64
"""Copies whose players share one pymunk space (per map): a space's broadphase slows past
a few hundred bodies, so larger batches use several spaces."""
VectorStep = tuple[dict[str, np.ndarray], dict[str, np.ndarray], dict[str, np.ndarray],
                   dict[str, np.ndarray], dict[str, Any]]
"""What ``step`` returns: observations, rewards, terminations, truncations, infos."""
_SHARED = ("dt", "attacker_speed", "defender_speed", "capture_radius", "player_radius")


def _check_memory(copies: int, players: int, size: int) -> None:
    """``FieldError`` naming ``num_envs`` when ``copies`` copies of ``players`` players,
    observing ``size`` numbers each, would not fit in the available memory: about three
    float32 observation tables and four float64 player-by-player arrays per copy (what a
    reset and a step hold at once), checked before any copy is made."""
    need = copies * players * (3 * 4 * size + 4 * 8 * players)
    have = checks.available_memory()
    if need > have:
        raise checks.FieldError(
            f"num_envs: {copies} copies of {players} players need about {need / 2**30:.1f} "
            f"GiB (observations and a step's arrays) but {have / 2**30:.1f} GiB is "
            "available; use fewer copies", "num_envs")


class ReachAvoidVectorEnv:
    """``num_envs`` copies of the reach-avoid game, stepped together (module docstring).

    Args as ``ReachAvoidEnv`` (``scenario``: a built-in, file, ``Scenario`` or library, whose
    maps must then share ``dt``, the speeds, ``capture_radius`` and ``player_radius``;
    ``starts`` ``"random"`` by default), plus ``num_envs``, the number of copies,
    ``copies_per_map`` (module docstring) and ``continuous_actions`` (``False``: MPE2's
    discrete actions, ``reachavoid_env.actions``).
    """

    def __init__(self, scenario: ScenarioSource = "paper_2v1", num_envs: int = 1,
                 starts: str = "random", max_cycles: int | None = None, shaping: float = 0.0,
                 observation: ObservationConfig | Mapping[str, Any] | None = None,
                 autoreset: bool = True, copies_per_map: int = 1,
                 continuous_actions: bool = True) -> None:
        self.autoreset = bool(autoreset)
        self.continuous_actions = checks.flag(continuous_actions, "continuous_actions")
        self.num_envs = checks.integer(num_envs, "num_envs", 1, MAX_COPIES)
        self.copies_per_map = checks.integer(copies_per_map, "copies_per_map", 1, MAX_COPIES)
        if starts not in STARTS:
            raise ValueError(f"starts: {starts!r} is not one of {STARTS}")
        self.scenarios = library(scenario, starts)
        base = self.base_scenario = self.scenarios[0]
        for other in self.scenarios[1:]:
            for field in _SHARED:
                if getattr(other, field) != getattr(base, field):
                    raise ScenarioError(f"sim.{field}: {other.name!r} has "
                                        f"{getattr(other, field)}, {base.name!r} "
                                        f"{getattr(base, field)}; the vector env needs one")
        self.observation = observation_config(observation)
        if max_cycles is not None:
            checks.integer(max_cycles, "max_cycles", 1, MAX_STEPS)
        self.max_cycles = max_cycles if max_cycles is not None else base.max_steps
        self.shaping = checks.real(shaping, "shaping", 0.0)
        self._m, self._n = m, n = base.num_attackers, base.num_defenders
        self.possible_agents = base.attacker_names + base.defender_names
        size = self.observation.size(m, n)
        _check_memory(self.num_envs, m + n, size)
        self.single_observation_space = gymnasium.spaces.Box(-1.0, 1.0, (size,), np.float32)
        self.single_action_space = action_space(self.continuous_actions)
        self._speeds = np.concatenate([np.full(m, base.attacker_speed),
                                       np.full(n, base.defender_speed)])[:, None]
        self._fastest = max(base.attacker_speed, base.defender_speed)
        self._longest = rules.longest_move(self._fastest, base.dt)
        self._worlds: dict[tuple[int, int], World] = {}
        self._observers: dict[int, Observer] = {}
        self._generators: list[np.random.Generator] = []
        self._start_reach: float | None = None

    @property
    def start_reach(self) -> float | None:
        """Random attackers of episodes that start from now on lie within this distance of
        the target (map units; ``None``: anywhere); module docstring."""
        return self._start_reach

    @start_reach.setter
    def start_reach(self, reach: float | None) -> None:
        self._start_reach = None if reach is None else checks.positive(reach, "start_reach")

    # ------------------------------------------------------------------ reset
    def reset(self, seed: int | None = None,
              ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Every copy starts an episode; copy ``k`` is seeded with ``seed + k`` (``None``:
        fresh entropy per copy)."""
        k = self.num_envs
        self._generators = [seeding.np_random(None if seed is None else seed + c)[0]
                            for c in range(k)]
        p = self._m + self._n
        self._positions = np.zeros((k, p, 2))
        self._velocities = np.zeros((k, p, 2))
        self._active = np.zeros((k, p), dtype=bool)
        self._status = np.zeros((k, self._m), dtype=np.int8)
        self._steps = np.zeros(k, dtype=np.int64)
        self._counts = np.zeros((k, 2), dtype=np.int64)      # captured, arrived
        self._map_of = np.zeros(k, dtype=np.intp)
        groups = -(-k // self.copies_per_map)
        self._group_map = np.zeros(groups, dtype=np.intp)    # each group's current map
        self._group_served = np.zeros(groups, dtype=np.int64)  # episodes it has started
        self.episode_scenarios: list[Scenario] = [self.base_scenario] * k
        self._worlds, self._observers = {}, {}
        self._running = np.zeros(k, dtype=bool)
        self.reset_copies(np.arange(k))
        infos = self._infos(np.full((k, self._m), -1), np.zeros(k, dtype=bool))
        return self._observations(), infos

    def reset_copies(self, copies: np.ndarray) -> np.ndarray:
        """New episodes in ``copies`` (an int array): each draws its map and starts from
        its generator, as ``ReachAvoidEnv.reset`` does. Returns their first observations
        ``(len(copies), M + N, D)``."""
        copies = np.asarray(copies, dtype=np.intp)
        for c in copies.tolist():
            index = self._draw_map(c)
            drawn = self.scenarios[index]
            attackers, defenders = drawn.starts(self._generators[c], self._start_reach)
            self.episode_scenarios[c] = drawn.with_starts(attackers, defenders)
            self._map_of[c] = index
            self._positions[c] = np.concatenate([attackers, defenders])
        self._velocities[copies] = 0.0
        self._active[copies] = True
        self._status[copies] = 0
        self._steps[copies] = 0
        self._counts[copies] = 0
        self._running[copies] = True
        self._place(copies)
        return self._observations(copies)

    def _draw_map(self, copy: int) -> int:
        """The index of the map of ``copy``'s new episode: its own draw, or its group's
        (module docstring, "Copies per map")."""
        generator = self._generators[copy]
        if self.copies_per_map == 1:
            return draw_scenario(self.scenarios, generator)[1]
        group = copy // self.copies_per_map
        if self._group_served[group] % self.copies_per_map == 0:
            self._group_map[group] = draw_scenario(self.scenarios, generator)[1]
        self._group_served[group] += 1
        return int(self._group_map[group])

    def _chunk(self, chunk: int) -> np.ndarray:
        """The copies whose bodies share a world (``COPIES_PER_WORLD`` consecutive ones)."""
        return np.arange(chunk * COPIES_PER_WORLD,
                         min(self.num_envs, (chunk + 1) * COPIES_PER_WORLD))

    def _place(self, copies: np.ndarray) -> None:
        """Fresh bodies for ``copies`` in the worlds of their maps and chunks (a world and
        a map's observer are made the first time a copy needs them)."""
        p = self._m + self._n
        keys = np.stack([self._map_of[copies], copies // COPIES_PER_WORLD], axis=1)
        for index, chunk in np.unique(keys, axis=0).tolist():
            here = copies[(keys[:, 0] == index) & (keys[:, 1] == chunk)]
            members = self._chunk(chunk)
            if (index, chunk) not in self._worlds:
                scenario = self.scenarios[index]
                # A body per player of every copy of the chunk; those of copies on other
                # maps stand still.
                self._worlds[index, chunk] = World(
                    scenario.map, scenario.player_radius,
                    self._positions[members].reshape(-1, 2), self._fastest, scenario.dt)
            if index not in self._observers:
                self._observers[index] = Observer(self.observation, self.scenarios[index].map,
                                                  self._m, self._n, self._fastest,
                                                  self.max_cycles)
            rows = ((here - members[0])[:, None] * p + np.arange(p)).reshape(-1)
            self._worlds[index, chunk].replace_players(
                rows, self._positions[here].reshape(-1, 2))

    # ------------------------------------------------------------------- step
    def step(self, actions: Mapping[str, Any]) -> VectorStep:
        """One step of ``dt`` seconds in every copy: controls, move, events, rewards,
        outputs, then the reset of the copies whose game ended (module docstring)."""
        if not self._generators:
            raise RuntimeError("step: call reset() first")
        return self.advance(self._stacked(actions))

    def advance(self, wanted: np.ndarray) -> VectorStep:
        """``step`` with every player's continuous action ``(K, P, 2)`` (float64, checked
        by the caller), whatever ``continuous_actions`` is: the training views' path."""
        if not self._generators:
            raise RuntimeError("step: call reset() first")
        live = self._active & self._running[:, None]
        wanted = np.where(live[..., None], wanted, 0.0)
        velocities = rules.bounded_controls(wanted) * self._speeds
        old, new = self._move(velocities)
        events = self._resolve_events(old, new, velocities)
        rewards = self._rewards(events, old, new)
        self._steps += self._running
        return self._outputs(live, events, rewards)

    def _stacked(self, actions: Mapping[str, Any]) -> np.ndarray:
        """Phase 1: every player's continuous action ``(K, P, 2)`` (discrete ones through
        ``actions.TABLE``), checked."""
        if not isinstance(actions, Mapping):
            raise TypeError(f"step: actions must be a dict {{agent name: (K, 2) array}}, got "
                            f"{type(actions).__name__}")
        check_agent_names(actions, self.possible_agents)
        stacked = np.empty((self.num_envs, len(self.possible_agents), 2))
        for i, name in enumerate(self.possible_agents):
            if name not in actions:
                raise KeyError(f"step: no action for agent {name!r}")
            array = np.asarray(actions[name])
            if not self.continuous_actions:
                stacked[:, i] = controls(f"action for {name}", array, (self.num_envs,))
            elif array.dtype.kind not in REAL_KINDS or array.shape != (self.num_envs, 2) \
                    or not np.isfinite(array).all():
                raise ValueError(f"action for {name}: expected finite real numbers of shape "
                                 f"({self.num_envs}, 2), got {array.dtype} of shape "
                                 f"{array.shape}")
            else:
                stacked[:, i] = array
        return stacked

    def _move(self, velocities: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Phase 2: positions before and after every world's step."""
        old, new = self._positions, self._positions.copy()
        p = self._active.shape[1]
        for (index, chunk), world in self._worlds.items():
            members = self._chunk(chunk)
            here = self._map_of[members] == index
            asked = np.where(here[:, None, None], velocities[members], 0.0)
            moved = world.step(asked.reshape(-1, 2)).reshape(len(members), p, 2)
            new[members[here]] = moved[here]
        still = ~(self._active & self._running[:, None])
        new[still] = old[still]
        return old, new

    def _resolve_events(self, old: np.ndarray, new: np.ndarray,
                        velocities: np.ndarray) -> rules.StepEvents:
        """Phase 3: captures and arrivals of every copy along the paths the world moved
        the players along (``rules.resolve_batch``); attackers that left stop where their
        event happened, and the defenders leave with the last."""
        m = self._m
        maps = [scenario.map for scenario in self.scenarios]

        def replay(copy: int, players: np.ndarray) -> np.ndarray:
            world = self._worlds[int(self._map_of[copy]), copy // COPIES_PER_WORLD]
            return world.replay(old[copy, players], velocities[copy, players])

        moves = rules.BatchMoves(velocities, self.base_scenario.dt, replay, self._longest)
        events = rules.resolve_batch(maps, self._map_of, self.base_scenario.capture_radius,
                                     self._active[:, :m] & self._running[:, None],
                                     old[:, :m], new[:, :m], old[:, m:], new[:, m:], moves)
        left = events.left
        if left.any():
            new[:, :m][left] = events.stops[left]
            self._status[events.captured] = _CAPTURED
            self._status[events.arrived] = _ARRIVED
            self._counts[:, 0] += events.captured.sum(axis=1)
            self._counts[:, 1] += events.arrived.sum(axis=1)
            self._active[:, :m] &= ~left
            self._active[~self._active[:, :m].any(axis=1), m:] = False
        self._positions = new
        self._velocities = (new - old) / self.base_scenario.dt
        self._velocities[~(self._active & self._running[:, None])] = 0.0
        return events

    def _rewards(self, events: rules.StepEvents, old: np.ndarray,
                 new: np.ndarray) -> np.ndarray:
        """Phase 4: ``(K, P)`` rewards as ``ReachAvoidEnv._rewards``, copy by copy
        (``reachavoid_env.rewards``)."""
        m = self._m
        attackers = outcomes(events.arrived, events.captured)
        if self.shaping:
            before, after = np.zeros_like(attackers), np.zeros_like(attackers)
            for index in np.unique(self._map_of).tolist():
                here = self._map_of == index
                distance = self.scenarios[index].map.target_signed_distance
                before[here], after[here] = distance(old[here, :m]), distance(new[here, :m])
            started = (self._status == 0) | events.left
            attackers = attackers + progress(before, after, started, self.shaping)
        return zero_sum(attackers, self._n)

    def _outputs(self, live: np.ndarray, events: rules.StepEvents, rewards: np.ndarray,
                 ) -> tuple[dict, dict, dict, dict, dict]:
        """Phase 5: the arrays of every agent (``live``: in the game at the start of the
        step), then the reset of the copies whose game ended."""
        truncate = self._steps >= self.max_cycles
        ended = live & ~self._active
        truncated = live & self._active & truncate[:, None]
        over = self._running & (~self._active[:, :self._m].any(axis=1) | truncate)
        rewards = np.where(live, rewards, 0.0)
        observations = self._observations()
        infos = self._infos(events.captor, over)
        self._running &= ~over
        if over.any() and self.autoreset:
            copies = np.flatnonzero(over)
            infos["final_observation"] = {name: table.copy()
                                          for name, table in observations.items()}
            fresh = self.reset_copies(copies)
            for i, name in enumerate(self.possible_agents):
                observations[name][copies] = fresh[:, i]
            infos["active"] = self._active.copy()
        names = self.possible_agents
        return (observations,
                {name: rewards[:, i] for i, name in enumerate(names)},
                {name: ended[:, i] for i, name in enumerate(names)},
                {name: truncated[:, i] for i, name in enumerate(names)},
                infos)

    # --------------------------------------------------------------- outputs
    def _observations(self, copies: np.ndarray | None = None,
                      ) -> dict[str, np.ndarray] | np.ndarray:
        """Every agent's observation ``{agent: (K, D)}``; with ``copies``, the table
        ``(len(copies), P, D)`` of those copies."""
        rows = np.arange(self.num_envs) if copies is None else copies
        table = np.empty((len(rows), len(self.possible_agents),
                          self.single_observation_space.shape[0]), dtype=np.float32)
        for index in np.unique(self._map_of[rows]).tolist():
            here = self._map_of[rows] == index
            chosen = rows[here]
            table[here] = self._observers[index](self._positions[chosen],
                                                 self._velocities[chosen],
                                                 self._active[chosen], self._steps[chosen])
        if copies is not None:
            return table
        return {name: table[:, i] for i, name in enumerate(self.possible_agents)}

    def _infos(self, captor: np.ndarray, over: np.ndarray) -> dict[str, Any]:
        return {"active": self._active.copy(), "status": self._status.copy(),
                "captured_by": np.where(captor >= 0, captor, -1),
                "captured": self._counts[:, 0].copy(), "arrived": self._counts[:, 1].copy(),
                "episode_over": over.copy()}

    def end_copies(self, copies: np.ndarray) -> None:
        """End the episodes of ``copies`` now: they stand still until ``reset_copies``."""
        self._running[np.asarray(copies, dtype=np.intp)] = False

    @property
    def active(self) -> np.ndarray:
        """``(K, M + N)`` bool: who is in the game in each copy now (a copy)."""
        return self._active.copy()

    def batch_state(self) -> BatchState:
        """Every copy's state (``BatchState``; read-only copies of the arrays)."""
        base = self.base_scenario
        return BatchState(time=self._steps * base.dt, step=self._steps.copy(),
                          attacker_positions=self._positions[:, :self._m].copy(),
                          defender_positions=self._positions[:, self._m:].copy(),
                          attacker_status=self._status.copy(),
                          attacker_speed=base.attacker_speed,
                          defender_speed=base.defender_speed,
                          capture_radius=base.capture_radius,
                          velocities=self._velocities.copy())

    def close(self) -> None:
        self._worlds.clear()


def vector_env(scenario: ScenarioSource = "paper_2v1", num_envs: int = 1,
               starts: str = "random", **env_kwargs: Any) -> ReachAvoidVectorEnv:
    """``num_envs`` copies of the game stepped together (``ReachAvoidVectorEnv``);
    ``env_kwargs``: ``max_cycles``, ``shaping``, ``observation``, ``autoreset``,
    ``copies_per_map``, ``continuous_actions``."""
    return ReachAvoidVectorEnv(scenario, num_envs=num_envs, starts=starts, **env_kwargs)

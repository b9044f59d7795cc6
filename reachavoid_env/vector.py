"""Many copies of one game stepped together: the vector env.

``ReachAvoidVectorEnv(scenario, num_envs=K, ...)`` holds ``K`` copies of the game of
``ReachAvoidEnv`` and steps them in one call: it is the batched core
(``reachavoid_env.core``, the single env's own step) at ``K`` copies, axis 0 of every
array, plus autoreset; the players of up to ``COPIES_PER_WORLD`` copies on one map share
one pymunk ``World`` (players touch only the walls, so copies cannot meet).
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

from reachavoid_env import checks
from reachavoid_env.actions import action_space
from reachavoid_env.core import Core, Stepped
from reachavoid_env.env_inputs import (
    STARTS,
    draw_scenario,
    library,
    observation_config,
    vector_actions,
)
from reachavoid_env.game_state import BatchState
from reachavoid_env.maps import ScenarioSource
from reachavoid_env.observations import ObservationConfig
from reachavoid_env.scenario import MAX_STEPS, Scenario, ScenarioError

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
        self._core: Core | None = None
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
        groups = -(-k // self.copies_per_map)
        self._group_map = np.zeros(groups, dtype=np.intp)    # each group's current map
        self._group_served = np.zeros(groups, dtype=np.int64)  # episodes it has started
        self.episode_scenarios: list[Scenario] = [self.base_scenario] * k
        self._core = Core(self.scenarios, k, self.observation, self.max_cycles, self.shaping,
                          COPIES_PER_WORLD)
        self.reset_copies(np.arange(k))
        infos = self._infos(np.full((k, self._m), -1), np.zeros(k, dtype=bool))
        return self._observations(), infos

    def reset_copies(self, copies: np.ndarray) -> np.ndarray:
        """New episodes in ``copies`` (an int array): each draws its map and starts from
        its generator, as ``ReachAvoidEnv.reset`` does. Returns their first observations
        ``(len(copies), M + N, D)``."""
        copies = np.asarray(copies, dtype=np.intp)
        maps = np.zeros(len(copies), dtype=np.intp)
        positions = np.zeros((len(copies), self._m + self._n, 2))
        for i, c in enumerate(copies.tolist()):
            maps[i] = self._draw_map(c)
            drawn = self.scenarios[maps[i]]
            attackers, defenders = drawn.starts(self._generators[c], self._start_reach)
            self.episode_scenarios[c] = drawn.with_starts(attackers, defenders)
            positions[i] = np.concatenate([attackers, defenders])
        self._core.place(copies, maps, positions)
        return self._core.observe(copies)

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

    # ------------------------------------------------------------------- step
    def step(self, actions: Mapping[str, Any]) -> VectorStep:
        """One step of ``dt`` seconds in every copy: the core's step (controls, move,
        events, rewards), the outputs, then the reset of the copies whose game ended
        (module docstring)."""
        if not self._generators:
            raise RuntimeError("step: call reset() first")
        return self.advance(vector_actions(actions, self.possible_agents, self.num_envs,
                                           self.continuous_actions))

    def advance(self, wanted: np.ndarray) -> VectorStep:
        """``step`` with every player's continuous action ``(K, P, 2)`` (float64, checked
        by the caller), whatever ``continuous_actions`` is: the training views' path."""
        if not self._generators:
            raise RuntimeError("step: call reset() first")
        return self._outputs(self._core.step(wanted))

    def _outputs(self, stepped: Stepped) -> VectorStep:
        """The arrays of every agent, then the reset of the copies whose game ended."""
        core, events = self._core, stepped.events
        live = np.ones_like(core.active) if stepped.live is None else stepped.live
        truncate = core.steps >= self.max_cycles
        ended = live & ~core.active
        truncated = live & core.active & truncate[:, None]
        over = core.running & (~core.active[:, :self._m].any(axis=1) | truncate)
        rewards = np.where(live, stepped.rewards, 0.0)
        observations = self._observations()
        infos = self._infos(events.captor, over)
        if over.any():
            copies = np.flatnonzero(over)
            core.stop(copies)
            if self.autoreset:
                infos["final_observation"] = {name: table.copy()
                                              for name, table in observations.items()}
                fresh = self.reset_copies(copies)
                for i, name in enumerate(self.possible_agents):
                    observations[name][copies] = fresh[:, i]
                infos["active"] = core.active.copy()
        names = self.possible_agents
        return (observations,
                {name: rewards[:, i] for i, name in enumerate(names)},
                {name: ended[:, i] for i, name in enumerate(names)},
                {name: truncated[:, i] for i, name in enumerate(names)},
                infos)

    # --------------------------------------------------------------- outputs
    def _observations(self) -> dict[str, np.ndarray]:
        """Every agent's observation ``{agent: (K, D)}`` (columns of the core's table)."""
        table = self._core.observe()
        return {name: table[:, i] for i, name in enumerate(self.possible_agents)}

    def _infos(self, captor: np.ndarray, over: np.ndarray) -> dict[str, Any]:
        core = self._core
        return {"active": core.active.copy(), "status": core.status.copy(),
                "captured_by": np.where(captor >= 0, captor, -1),
                "captured": core.counts[:, 0].copy(), "arrived": core.counts[:, 1].copy(),
                "episode_over": over.copy()}

    def end_copies(self, copies: np.ndarray) -> None:
        """End the episodes of ``copies`` now: they stand still until ``reset_copies``."""
        self._core.stop(np.asarray(copies, dtype=np.intp))

    @property
    def active(self) -> np.ndarray:
        """``(K, M + N)`` bool: who is in the game in each copy now (a copy)."""
        return self._core.active.copy()

    def batch_state(self) -> BatchState:
        """Every copy's state (``BatchState``; read-only copies of the arrays)."""
        base, core, m = self.base_scenario, self._core, self._m
        return BatchState(time=core.steps * base.dt, step=core.steps.copy(),
                          attacker_positions=core.positions[:, :m].copy(),
                          defender_positions=core.positions[:, m:].copy(),
                          attacker_status=core.status.copy(),
                          attacker_speed=base.attacker_speed,
                          defender_speed=base.defender_speed,
                          capture_radius=base.capture_radius,
                          velocities=core.velocities.copy())

    def close(self) -> None:
        if self._core is not None:
            self._core.worlds.clear()


def vector_env(scenario: ScenarioSource = "paper_2v1", num_envs: int = 1,
               starts: str = "random", **env_kwargs: Any) -> ReachAvoidVectorEnv:
    """``num_envs`` copies of the game stepped together (``ReachAvoidVectorEnv``);
    ``env_kwargs``: ``max_cycles``, ``shaping``, ``observation``, ``autoreset``,
    ``copies_per_map``, ``continuous_actions``."""
    return ReachAvoidVectorEnv(scenario, num_envs=num_envs, starts=starts, **env_kwargs)

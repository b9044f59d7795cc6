"""The game's step, batched: ``K`` copies of one game on ``(K, M + N, 2)`` arrays.

``Core`` holds the state of ``K`` copies (axis 0 of every array; players attackers first,
then defenders, in agent order) and steps them in named phases: bounded controls times
the speeds, the world's move (pymunk: the players of up to ``copies_per_world`` copies on
one map share a ``World``; players touch only the walls, so copies cannot meet), the
events (``rules.resolve_batch``, the one resolver; a step ``rules.EventWatch`` knows to
be quiet skips it), the rewards (``reachavoid_env.rewards``) and the observations
(``observations.Observer``). ``ReachAvoidEnv`` is the core at ``K = 1`` plus PettingZoo's
agent dicts, removal, infos and rendering; ``ReachAvoidVectorEnv`` is the core at ``K``
plus autoreset. Copy ``k`` plays exactly what the core at ``K = 1`` plays for the same
starts and actions (``tests/test_vector_env.py``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from reachavoid_env import rules
from reachavoid_env.game_state import AttackerStatus
from reachavoid_env.observations import ObservationConfig, Observer
from reachavoid_env.rewards import outcomes, progress, zero_sum
from reachavoid_env.scenario import Scenario
from reachavoid_env.world import World

_CAPTURED, _ARRIVED = AttackerStatus.CAPTURED.code, AttackerStatus.ARRIVED.code


class Stepped(NamedTuple):
    """What one step of the core did.

    ``live``: ``(K, M + N)`` bool, the players in the game at the start of the step
    (``None``: every player of every copy); ``events``: ``rules.StepEvents`` of arrays
    ``(K, M)``, read only; ``left``: some attacker left; ``rewards``: ``(K, M + N)``
    float64, read only (both may be shared between steps); the rows of players that were
    not live are no one's reward.
    """

    live: np.ndarray | None
    events: rules.StepEvents
    left: bool
    rewards: np.ndarray


class Core:
    """``copies`` copies of the game of ``scenarios`` (module docstring).

    Args:
        scenarios: the maps the copies may play (a copy plays one per episode, ``place``);
            they share the player counts, ``dt``, the speeds, ``capture_radius`` and
            ``player_radius`` (the first scenario's are used).
        copies: ``K``.
        observation: what the observations hold.
        max_cycles: the steps of an episode (the observations' time left).
        shaping: the ``progress`` reward's weight (0: none).
        copies_per_world: copies whose players share one pymunk space (per map).
        velocities: keep the players' velocities (``False``: they stay zero; v0 needs
            none).
        observers: observers already made, by map index (they are made when needed).

    State (arrays, axis 0 the copy): ``positions`` / ``velocities`` ``(K, P, 2)`` map
    units and map units per second, ``active`` ``(K, P)`` bool, ``status`` ``(K, M)``
    ``AttackerStatus.code``, ``steps`` ``(K,)``, ``counts`` ``(K, 2)`` captured and arrived
    this episode, ``map_of`` ``(K,)`` each copy's map, ``running`` ``(K,)`` bool (a copy
    whose episode ended stands still until it is placed again).
    """

    def __init__(self, scenarios: Sequence[Scenario], copies: int,
                 observation: ObservationConfig, max_cycles: int, shaping: float,
                 copies_per_world: int, velocities: bool = True,
                 observers: dict[int, Observer] | None = None) -> None:
        base = scenarios[0]
        self.scenarios = tuple(scenarios)
        self.maps = tuple(scenario.map for scenario in scenarios)
        self.bounds = tuple(rules.target_bounds(game_map) for game_map in self.maps)
        self.m, self.n = m, n = base.num_attackers, base.num_defenders
        self.dt, self.capture_radius = base.dt, base.capture_radius
        self.fastest = max(base.attacker_speed, base.defender_speed)
        self.longest = rules.longest_move(self.fastest, base.dt)
        self.speeds = np.concatenate([np.full(m, base.attacker_speed),
                                      np.full(n, base.defender_speed)])[:, None]
        self.observation, self.max_cycles, self.shaping = observation, max_cycles, shaping
        self.copies_per_world = copies_per_world
        self.keep_velocities = velocities
        self.observers: dict[int, Observer] = dict(observers or {})
        p = m + n
        self.positions = np.zeros((copies, p, 2))
        self.velocities = np.zeros((copies, p, 2))
        self.active = np.zeros((copies, p), dtype=bool)
        self.status = np.zeros((copies, m), dtype=np.int8)
        self.steps = np.zeros(copies, dtype=np.int64)
        self.counts = np.zeros((copies, 2), dtype=np.int64)
        self.map_of = np.zeros(copies, dtype=np.intp)
        self.running = np.zeros(copies, dtype=bool)
        self.everyone = False
        """Every player of every copy is in the game (the masks are skipped)."""
        self.worlds: dict[tuple[int, int], World] = {}
        self._no_rewards = np.zeros((copies, p))
        self._no_events = rules.no_events(np.zeros((copies, m, 2)))
        # One world holding every copy (one map, few copies): moved without masks.
        self._one_world = len(self.maps) == 1 and copies <= copies_per_world
        # One copy: the watch skips the steps it knows to be quiet (with more copies some
        # copy is nearly always near an event).
        self._watch: rules.EventWatch | None = None

    # ------------------------------------------------------------------ place
    def place(self, copies: np.ndarray, maps: np.ndarray, positions: np.ndarray) -> None:
        """New episodes in ``copies`` (int ``(C,)``): on maps ``maps`` (``(C,)`` indices
        into ``scenarios``) from ``positions`` ``(C, P, 2)`` (map units)."""
        self.map_of[copies] = maps
        self.positions[copies] = positions
        self.velocities[copies] = 0.0
        self.active[copies] = True
        self.status[copies] = 0
        self.steps[copies] = 0
        self.counts[copies] = 0
        self.running[copies] = True
        self.everyone = bool(self.active.all() and self.running.all())
        self._place_bodies(copies)
        if len(self.running) == 1:
            self._watch = rules.EventWatch(self.capture_radius,
                                           self.bounds[self.map_of[0]], self.longest)

    def _chunk(self, chunk: int) -> np.ndarray:
        """The copies whose bodies share a world (``copies_per_world`` consecutive ones)."""
        size = self.copies_per_world
        return np.arange(chunk * size, min(len(self.running), (chunk + 1) * size))

    def _place_bodies(self, copies: np.ndarray) -> None:
        """Fresh bodies for ``copies`` in the worlds of their maps and chunks (a world and
        a map's observer are made the first time a copy needs them)."""
        p = self.m + self.n
        keys = np.stack([self.map_of[copies], copies // self.copies_per_world], axis=1)
        for index, chunk in np.unique(keys, axis=0).tolist():
            here = copies[(keys[:, 0] == index) & (keys[:, 1] == chunk)]
            members = self._chunk(chunk)
            if index not in self.observers:
                self.observers[index] = Observer(self.observation, self.maps[index],
                                                 self.m, self.n, self.fastest,
                                                 self.max_cycles)
            if (index, chunk) not in self.worlds:
                scenario = self.scenarios[index]
                # A body per player of every copy of the chunk, where the copy stands;
                # those of copies on other maps stand still.
                self.worlds[index, chunk] = World(
                    scenario.map, scenario.player_radius,
                    self.positions[members].reshape(-1, 2), self.fastest, scenario.dt)
                continue
            rows = ((here - members[0])[:, None] * p + np.arange(p)).reshape(-1)
            self.worlds[index, chunk].replace_players(rows,
                                                      self.positions[here].reshape(-1, 2))

    def stop(self, copies: np.ndarray) -> None:
        """End the episodes of ``copies`` now: they stand still until placed again."""
        self.running[copies] = False
        self.everyone = False

    # ------------------------------------------------------------------- step
    def step(self, wanted: np.ndarray) -> Stepped:
        """One step of ``dt`` seconds in every copy: controls, move, events, rewards.

        Args:
            wanted: ``(K, P, 2)`` every player's control, a fraction of its speed (longer
                than 1: scaled to 1); rows of players out of the game are ignored.
        """
        live = None if self.everyone else self.active & self.running[:, None]
        if live is not None:
            wanted = np.where(live[..., None], wanted, 0.0)
        velocities = rules.bounded_controls(wanted) * self.speeds
        old, new = self._move(velocities, live)
        events, left = self._events(old, new, velocities)
        rewards = self._rewards(events, left, old, new)
        self.steps = self.steps + (1 if live is None else self.running)
        return Stepped(live, events, left, rewards)

    def _move(self, velocities: np.ndarray, live: np.ndarray | None,
              ) -> tuple[np.ndarray, np.ndarray]:
        """Positions ``(K, P, 2)`` before and after every world's step (walls stop and
        slide; players out of the game stand still)."""
        old = self.positions
        if self._one_world:
            new = self.worlds[0, 0].step(velocities.reshape(-1, 2)).reshape(old.shape)
        else:
            new = old.copy()
            for (index, chunk), world in self.worlds.items():
                members = self._chunk(chunk)
                here = self.map_of[members] == index
                asked = np.where(here[:, None, None], velocities[members], 0.0)
                moved = world.step(asked.reshape(-1, 2)).reshape(len(members), *old.shape[1:])
                new[members[here]] = moved[here]
        if live is not None:
            new[~live] = old[~live]
        return old, new

    def _events(self, old: np.ndarray, new: np.ndarray,
                velocities: np.ndarray) -> tuple[rules.StepEvents, bool]:
        """Captures and arrivals along the paths the world moved the players along
        (``rules.resolve_batch``), and whether some attacker left; attackers that left stop
        where their event happened, and the defenders leave with the last. Updates the
        state."""
        m, watch = self.m, self._watch
        if watch is not None and watch.quiet():
            quiet = self._no_events
            events = rules.StepEvents(quiet.captured, quiet.arrived, quiet.times,
                                      quiet.captor, quiet.left, new[:, :m])
            left = False
        else:
            worlds, per_world = self.worlds, self.copies_per_world
            map_of = self.map_of

            def replay(copy: int, players: np.ndarray) -> np.ndarray:
                world = worlds[int(map_of[copy]), copy // per_world]
                return world.replay(old[copy, players], velocities[copy, players])

            moves = rules.BatchMoves(velocities, self.dt, replay, self.longest)
            active = self.active[:, :m] if self.everyone else (self.active[:, :m]
                                                               & self.running[:, None])
            events = rules.resolve_batch(self.maps, map_of, self.capture_radius, active,
                                         old[:, :m], new[:, :m], old[:, m:], new[:, m:],
                                         moves, self.bounds)
            left = bool(events.left.any())
            if left:
                self._leave(events, new)
            if watch is not None:
                watch.anchor(self.active[0, :m] & self.running[0], new[0, :m], new[0, m:])
        self.positions = new
        if self.keep_velocities:
            self.velocities = (new - old) / self.dt
            if not self.everyone:
                self.velocities[~(self.active & self.running[:, None])] = 0.0
        return events, left

    def _leave(self, events: rules.StepEvents, new: np.ndarray) -> None:
        """The attackers of ``events`` that left stop at their event (in ``new``) and leave
        the game; the defenders of a copy leave with its last attacker."""
        m, left = self.m, events.left
        new[:, :m][left] = events.stops[left]
        self.status[events.captured] = _CAPTURED
        self.status[events.arrived] = _ARRIVED
        self.counts[:, 0] += events.captured.sum(axis=1)
        self.counts[:, 1] += events.arrived.sum(axis=1)
        self.active[:, :m] &= ~left
        self.active[~self.active[:, :m].any(axis=1), m:] = False
        self.everyone = False

    def _rewards(self, events: rules.StepEvents, left: bool, old: np.ndarray,
                 new: np.ndarray) -> np.ndarray:
        """``(K, P)`` rewards (``reachavoid_env.rewards``): +1 arrival, -1 capture, the
        ``progress`` term for the attackers active at the start of the step; each defender
        gets minus their sum."""
        if not self.shaping and not left:
            return self._no_rewards
        m = self.m
        attackers = outcomes(events.arrived, events.captured)
        if self.shaping:
            if len(self.maps) == 1:
                distance = self.maps[0].target_signed_distance
                before, after = distance(old[:, :m]), distance(new[:, :m])
            else:
                before, after = np.zeros_like(attackers), np.zeros_like(attackers)
                for index in np.unique(self.map_of).tolist():
                    here = self.map_of == index
                    distance = self.maps[index].target_signed_distance
                    before[here], after[here] = distance(old[here, :m]), distance(new[here, :m])
            started = (self.status == 0) | events.left
            attackers = attackers + progress(before, after, started, self.shaping)
        return zero_sum(attackers, self.n)

    # ----------------------------------------------------------- observations
    def observe(self, copies: np.ndarray | None = None) -> np.ndarray:
        """Every player's observation ``(C, P, D)`` float32 of ``copies`` (``None``: every
        copy, ``C = K``); ``observations.Observer``."""
        if copies is None and len(self.maps) == 1:
            return self.observers[0](self.positions, self.velocities, self.active,
                                     self.steps)
        rows = np.arange(len(self.running)) if copies is None else copies
        table = np.empty((len(rows), self.m + self.n,
                          self.observation.size(self.m, self.n)), dtype=np.float32)
        for index in np.unique(self.map_of[rows]).tolist():
            here = self.map_of[rows] == index
            chosen = rows[here]
            table[here] = self.observers[index](self.positions[chosen],
                                                self.velocities[chosen],
                                                self.active[chosen], self.steps[chosen])
        return table

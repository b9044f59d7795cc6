"""The game's state as policies and the renderer read it, and the one Policy protocol;
K copies of a game at once (``BatchState``), the ``BatchPolicy`` protocol that acts on
them, and ``PerCopy``, the batched policy made of one ``Policy`` per copy."""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol, runtime_checkable

import numpy as np

if TYPE_CHECKING:
    from reachavoid_env.scenario import Scenario


class AttackerStatus(str, Enum):
    """Where an attacker stands in the game.

    ``code`` is the integer that the env's numeric infos carry (``info_format="numeric"``,
    the default): ACTIVE 0, CAPTURED 1, ARRIVED 2; ``AttackerStatus.from_code`` reads it back.
    """

    ACTIVE = "active"       # code 0
    CAPTURED = "captured"   # code 1
    ARRIVED = "arrived"     # code 2

    @property
    def code(self) -> int:
        """The integer code of this status (its position in the class: 0, 1, 2)."""
        return list(AttackerStatus).index(self)

    @classmethod
    def from_code(cls, code: int) -> AttackerStatus:
        """The status whose ``code`` is ``code``; ``ValueError`` for any other value."""
        statuses = list(cls)
        if isinstance(code, bool) or not 0 <= int(code) < len(statuses) or int(code) != code:
            raise ValueError(f"status code: expected 0, 1 or 2, got {code!r}")
        return statuses[int(code)]


@dataclass(frozen=True, eq=False)
class GameState:
    """A snapshot of the game.

    Positions are map units, ``(x, y)`` per row, float64, for every player of the scenario
    in name order (``attacker_0..M-1``, ``defender_0..N-1``); a captured or arrived attacker
    keeps the position where it left the game. ``time`` is seconds since reset.
    ``velocities`` (optional, ``(M + N, 2)`` map units per second, attackers then
    defenders) is each player's displacement over the last step divided by ``dt`` (zero
    at reset and for players out of the game), as the egocentric observations carry it.
    The arrays are read-only copies.
    """

    time: float
    step: int
    attacker_positions: np.ndarray
    defender_positions: np.ndarray
    attacker_status: tuple[AttackerStatus, ...]
    attacker_speed: float
    defender_speed: float
    capture_radius: float
    velocities: np.ndarray | None = None

    def __post_init__(self) -> None:
        for name in ("attacker_positions", "defender_positions", "velocities"):
            if getattr(self, name) is None:
                continue
            array = np.array(getattr(self, name), dtype=np.float64)
            array.setflags(write=False)
            object.__setattr__(self, name, array)

    @property
    def active_attackers(self) -> np.ndarray:
        """Boolean mask ``(M,)`` of attackers still in the game."""
        return np.array([s is AttackerStatus.ACTIVE for s in self.attacker_status], dtype=bool)

    @property
    def attacker_names(self) -> list[str]:
        return [f"attacker_{i}" for i in range(len(self.attacker_status))]

    @property
    def defender_names(self) -> list[str]:
        return [f"defender_{j}" for j in range(len(self.defender_positions))]

    @property
    def captured(self) -> list[str]:
        return [n for n, s in zip(self.attacker_names, self.attacker_status, strict=True)
                if s is AttackerStatus.CAPTURED]

    @property
    def arrived(self) -> list[str]:
        return [n for n, s in zip(self.attacker_names, self.attacker_status, strict=True)
                if s is AttackerStatus.ARRIVED]


class EdgeKind(str, Enum):
    """Which game an overlay edge belongs to; each kind is drawn in its own style."""

    ASSIGN = "assign"  # one defender on one attacker (a 1 vs 1 game)
    PAIR = "pair"      # one defender on two attackers (a 2 vs 1 game): both its edges
    TEAM = "team"      # two defenders on one attacker (a 1 vs 2 game): both edges to it
    RACE = "race"      # a defender racing to intercept an attacker, in no certified game


class Edge(NamedTuple):
    """One defender-attacker edge of an overlay, with the kind of game it is."""

    defender: str
    attacker: str
    kind: EdgeKind


class Route(NamedTuple):
    """The way an overlay edge runs, where it is no straight line: ``points`` (map units,
    at least two) from the ``defender``'s position to the ``attacker``'s, around the
    obstacles (a racing defender's way to its race point, then the attacker's path back
    from there)."""

    defender: str
    attacker: str
    points: tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class Overlay:
    """What a policy asks the renderer to draw on top of the game.

    ``edges`` are ``(defender name, attacker name)`` pairs (the paper's assignment edges);
    ``kinds`` optionally gives each edge's ``EdgeKind``, in the same order (empty: every
    edge is a 1 vs 1 assignment). ``lines`` are extra text lines shown under the clock.
    ``routes`` give the way of some edges (``Route``): the renderer draws such an edge
    along its route (its ends at the players' current positions), any other straight.
    They are made by ``ways`` when first read: a route may cost a geodesic solve, and
    only a frame reads them (``reachavoid.rollout`` reads every step's overlay for its
    text).
    """

    edges: tuple[tuple[str, str], ...] = ()
    lines: tuple[str, ...] = ()
    kinds: tuple[EdgeKind, ...] = ()
    ways: Callable[[], tuple[Route, ...]] | None = dataclasses.field(
        default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.kinds and len(self.kinds) != len(self.edges):
            raise ValueError(f"kinds: expected one per edge ({len(self.edges)}), got "
                             f"{len(self.kinds)}")
        kinds = tuple(EdgeKind(k) for k in self.kinds)
        # one form per meaning: all-ASSIGN kinds are stored as ()
        object.__setattr__(self, "kinds", () if set(kinds) <= {EdgeKind.ASSIGN} else kinds)

    @functools.cached_property
    def routes(self) -> tuple[Route, ...]:
        """The ``Route`` of each edge that has one (made by ``ways`` on first read); a route
        of no edge, or of fewer than two points, is a ``ValueError``."""
        routes = () if self.ways is None else tuple(self.ways())
        edges = set(self.edges)
        for route in routes:
            if (route.defender, route.attacker) not in edges or len(route.points) < 2:
                raise ValueError(f"routes: ({route.defender!r}, {route.attacker!r}) is no "
                                 f"edge of the overlay or has fewer than 2 points")
        return routes

    @property
    def kinded_edges(self) -> tuple[Edge, ...]:
        """Every edge with its kind (``ASSIGN`` where ``kinds`` is empty)."""
        kinds = self.kinds or (EdgeKind.ASSIGN,) * len(self.edges)
        return tuple(Edge(d, a, k) for (d, a), k in zip(self.edges, kinds, strict=True))


def outcome_line(num_attackers: int, captured: int, arrived: int) -> str:
    """How a game ended, in words: the banner of a video's last frame and the summary of
    ``reachavoid play``. Attackers neither captured nor arrived were held off until the
    time ran out."""
    if captured == num_attackers:
        return f"All {num_attackers} attackers captured"
    held = num_attackers - captured - arrived
    parts = [f"{captured} captured", f"{arrived} reached the target"]
    if held:
        parts.append(f"{held} held off (time up)")
    return f"{num_attackers} attackers: " + ", ".join(parts)


class PolicyMismatch(ValueError):
    """A policy that cannot play a scenario (for example a learned model trained for other
    player counts): bad input, reported in one line by the command line."""


@runtime_checkable
class Policy(Protocol):
    """Controls one side (all attackers or all defenders) of a game.

    ``reset(scenario)`` is called once per episode with the scenario in play (starts
    included). ``act(state)`` returns an action for every live agent the policy controls,
    keyed by agent name: a float32 array ``(2,)`` in ``[-1, 1]``, the desired velocity as a
    fraction of that player's speed (the env's action space). A policy that has something
    to show (assignment edges, text) also defines ``overlay() -> Overlay | None``; it is
    optional, and read only through ``merged_overlay``.
    """

    def reset(self, scenario: Scenario) -> None: ...

    def act(self, state: GameState) -> dict[str, np.ndarray]: ...


def merged_overlay(*policies: Policy) -> Overlay | None:
    """The union of the policies' overlays (edges with their kinds and routes, text lines);
    ``None`` if none draws."""
    overlays = []
    for policy in policies:
        overlay = getattr(policy, "overlay", None)
        if callable(overlay) and (drawn := overlay()) is not None:
            overlays.append(drawn)
    if not overlays:
        return None
    routed = [o for o in overlays if o.ways is not None]
    return Overlay(edges=tuple(e for o in overlays for e in o.edges),
                   lines=tuple(line for o in overlays for line in o.lines),
                   kinds=tuple(e.kind for o in overlays for e in o.kinded_edges),
                   ways=(lambda: tuple(r for o in routed for r in o.routes)) if routed else None)


_STATUSES = tuple(AttackerStatus)
"""The statuses by ``code``."""
_CODES = {status: code for code, status in enumerate(_STATUSES)}


class BatchState(NamedTuple):
    """K copies of one game at once (axis 0 = copy). Map units, seconds.

    ``time`` ``(K,)`` seconds, ``step`` ``(K,)`` int, ``attacker_positions`` ``(K, M, 2)``,
    ``defender_positions`` ``(K, N, 2)``, ``attacker_status`` ``(K, M)`` int8 (the
    ``AttackerStatus.code``: 0 active, 1 captured, 2 arrived); the speeds and the capture
    radius are the game's, the same in every copy."""

    time: np.ndarray
    step: np.ndarray
    attacker_positions: np.ndarray
    defender_positions: np.ndarray
    attacker_status: np.ndarray
    attacker_speed: float
    defender_speed: float
    capture_radius: float
    velocities: np.ndarray | None = None

    @classmethod
    def of(cls, states: Sequence[GameState]) -> BatchState:
        """The copies ``states`` (of one game: speeds and radius from the first) stacked."""
        first = states[0]
        return cls(np.array([s.time for s in states]), np.array([s.step for s in states]),
                   np.stack([s.attacker_positions for s in states]),
                   np.stack([s.defender_positions for s in states]),
                   np.array([[_CODES[a] for a in s.attacker_status] for s in states],
                            dtype=np.int8).reshape(len(states), -1),
                   first.attacker_speed, first.defender_speed, first.capture_radius)

    def game_state(self, k: int) -> GameState:
        """Copy ``k`` as the single env's ``GameState``, bit for bit."""
        return GameState(
            time=float(self.time[k]),
            step=int(self.step[k]),
            attacker_positions=self.attacker_positions[k],
            defender_positions=self.defender_positions[k],
            attacker_status=tuple(_STATUSES[s] for s in self.attacker_status[k].tolist()),
            attacker_speed=self.attacker_speed,
            defender_speed=self.defender_speed,
            capture_radius=self.capture_radius,
            velocities=None if self.velocities is None else self.velocities[k],
        )


@runtime_checkable
class BatchPolicy(Protocol):
    """Controls one side of K copies of a game in one call.

    ``reset_copies(copies, scenarios)``: a new episode starts in each copy of ``copies``
    (an int array) with ``scenarios[i]`` (starts included) for ``copies[i]``; called for
    every copy after the vector env's reset, and for the copies that autoreset after each
    step. ``act_batch(states)``: ``(K, n, 2)`` float32 controls, ``|u| <= 1``, for the
    players this policy drives (``n = N`` for a defender policy, ``M`` for an attacker
    policy), rows in agent order; the env ignores the rows of players out of the game.
    Copy ``k``'s rows are exactly (bit for bit) what the single-game policy's ``act``
    gives for ``states.game_state(k)``.
    """

    def reset_copies(self, copies: np.ndarray, scenarios: Sequence[Scenario]) -> None: ...

    def act_batch(self, states: BatchState) -> np.ndarray: ...


def checked_copies(copies: np.ndarray, scenarios: Sequence[Scenario]) -> np.ndarray:
    """``copies`` of ``BatchPolicy.reset_copies`` as an int array, checked to have one
    scenario each."""
    copies = np.asarray(copies, dtype=np.int64).reshape(-1)
    if len(copies) != len(scenarios):
        raise ValueError(f"scenarios: expected one per copy ({len(copies)}), got "
                         f"{len(scenarios)}")
    return copies


def map_key(scenario: Scenario) -> Scenario:
    """``scenario`` without its starts: what a policy built for a map depends on."""
    return dataclasses.replace(scenario, attackers=None, defenders=None)


class PerCopy:
    """A ``BatchPolicy`` made of one ordinary ``Policy`` per copy: ``factory(scenario)``
    builds copy ``k``'s policy for each map it plays (kept for later episodes on that
    map), and ``act_batch`` loops ``act(states.game_state(k))``. The fallback for policies
    without a batched class, and the reference the batched ones are tested against.

    ``side`` (``"defenders"`` or ``"attackers"``) says which players' rows ``act_batch``
    returns; a player the policy gives no action (one out of the game) gets zeros.
    """

    def __init__(self, factory: Callable[[Scenario], Policy], side: str = "defenders") -> None:
        if side not in ("defenders", "attackers"):
            raise ValueError(f"side: expected 'defenders' or 'attackers', got {side!r}")
        self.factory = factory
        self.side = side
        self.policies: list[Policy | None] = []
        self._built: list[dict[Any, Policy]] = []

    def reset_copies(self, copies: np.ndarray, scenarios: Sequence[Scenario]) -> None:
        copies = checked_copies(copies, scenarios)
        if len(copies):
            grow = int(copies.max()) + 1 - len(self.policies)
            self.policies += [None] * max(grow, 0)
            self._built += [{} for _ in range(max(grow, 0))]
        for k, scenario in zip(copies.tolist(), scenarios, strict=True):
            key = map_key(scenario)
            built = self._built[k]
            if key not in built:
                built[key] = self.factory(key)
            self.policies[k] = built[key]
            built[key].reset(scenario)

    def act_batch(self, states: BatchState) -> np.ndarray:
        players = states.defender_positions if self.side == "defenders" else \
            states.attacker_positions
        count, n = players.shape[:2]
        if len(self.policies) < count or any(p is None for p in self.policies[:count]):
            raise RuntimeError("act_batch: call reset_copies for every copy first")
        prefix = "defender_" if self.side == "defenders" else "attacker_"
        actions = np.zeros((count, n, 2), dtype=np.float32)
        for k in range(count):
            for name, action in self.policies[k].act(states.game_state(k)).items():
                actions[k, int(name.removeprefix(prefix))] = action
        return actions


class PerMap:
    """A ``BatchPolicy`` made of one ``BatchPolicy`` per map, for copies that play several
    maps: ``factory(scenario)`` builds a map's policy the first time a copy plays it (the
    scenario without its starts), and ``act_batch`` asks each map's policy once for all the
    copies on that map. Each map's policy sees every copy's row (its own copy slots, as on
    one map); the rows of copies on other maps reach it with every attacker out of the game,
    and their actions are not taken. So each copy gets what its map's policy gives it, and a
    batched class that matches its single policy bit for bit keeps doing so over many maps.
    """

    def __init__(self, factory: Callable[[Scenario], BatchPolicy]) -> None:
        self.factory = factory
        self.policies: list[BatchPolicy] = []
        self._maps: dict[Any, int] = {}             # a map's scenario -> its policy's index
        self._map_of = np.zeros(0, dtype=np.intp)  # copy -> its map's index (-1: not reset)

    def reset_copies(self, copies: np.ndarray, scenarios: Sequence[Scenario]) -> None:
        copies = checked_copies(copies, scenarios)
        if len(copies):
            self._grow(int(copies.max()) + 1)
        for k, scenario in zip(copies.tolist(), scenarios, strict=True):
            key = map_key(scenario)
            if key not in self._maps:
                self._maps[key] = len(self.policies)
                self.policies.append(policy := self.factory(key))
                slots = np.arange(len(self._map_of))
                policy.reset_copies(slots, [key] * len(slots))
            self._map_of[k] = self._maps[key]
            self.policies[self._map_of[k]].reset_copies(np.array([k]), [scenario])

    def _grow(self, count: int) -> None:
        """Slots for copies up to ``count``, reset on every map built so far."""
        new = np.arange(len(self._map_of), count)
        if not len(new):
            return
        self._map_of = np.concatenate([self._map_of, np.full(len(new), -1, dtype=np.intp)])
        for key, index in self._maps.items():
            self.policies[index].reset_copies(new, [key] * len(new))

    def act_batch(self, states: BatchState) -> np.ndarray:
        count = len(states.step)
        maps = self._map_of[:count]
        if len(maps) < count or (maps < 0).any():
            raise RuntimeError("act_batch: call reset_copies for every copy first")
        actions: np.ndarray | None = None
        for index in np.unique(maps).tolist():
            here = maps == index
            status = np.where(here[:, None], states.attacker_status,
                              AttackerStatus.CAPTURED.code).astype(np.int8)
            acted = self.policies[index].act_batch(states._replace(attacker_status=status))
            if actions is None:
                actions = np.zeros_like(acted)
            actions[here] = acted[here]
        return actions


class Single:
    """A ``BatchPolicy`` played as an ordinary ``Policy``: one game, copy 0 of ``batch``.

    ``reset(scenario)`` resets copy 0; ``act(state)`` gives copy 0's rows of
    ``batch.act_batch`` keyed by agent name: every defender (``side="defenders"``) or every
    active attacker (``side="attackers"``), float32 ``(2,)`` each. ``overlay()`` is
    ``batch.overlay(0)`` where the batched policy draws (``None`` otherwise); any other
    attribute is read from ``batch``, but for ``BatchPolicy``'s own methods: a ``Single``
    is a ``Policy``, never taken for a ``BatchPolicy`` (whose copies it would share).
    """

    _UNSHARED = frozenset({"batch", "side", "reset_copies", "act_batch"})

    def __init__(self, batch: BatchPolicy, side: str = "defenders") -> None:
        if side not in ("defenders", "attackers"):
            raise ValueError(f"side: expected 'defenders' or 'attackers', got {side!r}")
        self.batch = batch
        self.side = side

    def reset(self, scenario: Scenario) -> None:
        self.batch.reset_copies(np.zeros(1, dtype=np.int64), [scenario])

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        batch = BatchState.of([state])
        if state.velocities is not None:
            batch = batch._replace(velocities=state.velocities[None])
        rows = self.batch.act_batch(batch)[0]
        if self.side == "defenders":
            return dict(zip(state.defender_names, rows, strict=True))
        return {name: rows[i] for i, name in enumerate(state.attacker_names)
                if state.attacker_status[i] is AttackerStatus.ACTIVE}

    def overlay(self) -> Overlay | None:
        overlay = getattr(self.batch, "overlay", None)
        return overlay(0) if callable(overlay) else None

    def __getattr__(self, name: str) -> Any:
        if name in self._UNSHARED or name.startswith("__"):
            raise AttributeError(name)   # not forwarded (or, while copying, not set yet)
        return getattr(self.batch, name)

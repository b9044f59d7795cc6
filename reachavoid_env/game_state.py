"""The game's state as policies and the renderer read it, and the one Policy protocol."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from enum import Enum
from typing import TYPE_CHECKING, NamedTuple, Protocol, runtime_checkable

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


@dataclass(frozen=True)
class Overlay:
    """What a policy asks the renderer to draw on top of the game.

    ``edges`` are ``(defender name, attacker name)`` pairs (the paper's assignment edges);
    ``kinds`` optionally gives each edge's ``EdgeKind``, in the same order (empty: every
    edge is a 1 vs 1 assignment). ``lines`` are extra text lines shown under the clock.
    """

    edges: tuple[tuple[str, str], ...] = ()
    lines: tuple[str, ...] = ()
    kinds: tuple[EdgeKind, ...] = ()

    def __post_init__(self) -> None:
        if self.kinds and len(self.kinds) != len(self.edges):
            raise ValueError(f"kinds: expected one per edge ({len(self.edges)}), got "
                             f"{len(self.kinds)}")
        kinds = tuple(EdgeKind(k) for k in self.kinds)
        # one form per meaning: all-ASSIGN kinds are stored as ()
        object.__setattr__(self, "kinds", () if set(kinds) <= {EdgeKind.ASSIGN} else kinds)

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


class BatchState(NamedTuple):
    """``K`` copies of one game at once (axis 0: the copy), as the vector env holds them.

    Positions ``(K, M, 2)`` / ``(K, N, 2)`` and ``velocities`` ``(K, M + N, 2)`` (or
    ``None``) in map units and map units per second; ``time`` ``(K,)`` seconds; ``step``
    ``(K,)``; ``attacker_status`` ``(K, M)`` ``AttackerStatus.code``.
    """

    time: np.ndarray
    step: np.ndarray
    attacker_positions: np.ndarray
    defender_positions: np.ndarray
    attacker_status: np.ndarray
    attacker_speed: float
    defender_speed: float
    capture_radius: float
    velocities: np.ndarray | None = None

    def game_state(self, k: int) -> GameState:
        """Copy ``k`` as a ``GameState``: what the single env gives for the same game."""
        statuses = tuple(AttackerStatus)
        return GameState(time=float(self.time[k]), step=int(self.step[k]),
                         attacker_positions=self.attacker_positions[k],
                         defender_positions=self.defender_positions[k],
                         attacker_status=tuple(statuses[s] for s in self.attacker_status[k]),
                         attacker_speed=self.attacker_speed,
                         defender_speed=self.defender_speed,
                         capture_radius=self.capture_radius,
                         velocities=None if self.velocities is None else self.velocities[k])


@runtime_checkable
class BatchPolicy(Protocol):
    """Controls one side of ``K`` copies of a game at once (the vector env's scripted side).

    ``reset_copies(copies, scenarios)``: a new episode starts in each copy of ``copies``
    (int array) with ``scenarios[i]`` (starts included) for ``copies[i]``; called for every
    copy after the vector env's reset and for the copies that reset after a step.
    ``act_batch(states)``: ``(K, n, 2)`` controls in ``[-1, 1]`` for the ``n`` players of
    the side, rows in agent order (rows of players out of the game are ignored). A batched
    policy gives, for every copy, exactly the actions its single-game policy gives for that
    copy's ``states.game_state(k)``.
    """

    def reset_copies(self, copies: np.ndarray, scenarios: Sequence[Scenario]) -> None: ...

    def act_batch(self, states: BatchState) -> np.ndarray: ...


class PerCopy:
    """A ``BatchPolicy`` from a single-game policy: ``factory(scenario)`` builds one
    ``Policy`` per copy (per map of a library, kept), and ``act_batch`` asks each copy's
    policy in turn. The fallback for policies with no batched form, and their reference.

    Args:
        factory: ``scenario -> Policy``.
        side: ``"attackers"`` or ``"defenders"``, the players it drives.
    """

    def __init__(self, factory: Callable[[Scenario], Policy], side: str) -> None:
        if side not in ("attackers", "defenders"):
            raise ValueError(f"side: expected 'attackers' or 'defenders', got {side!r}")
        self.factory, self.side = factory, side
        self.current: dict[int, Policy] = {}
        self._built: dict[int, dict[Scenario, Policy]] = {}

    def reset_copies(self, copies: np.ndarray, scenarios: Sequence[Scenario]) -> None:
        for copy, scenario in zip(np.asarray(copies).tolist(), scenarios, strict=True):
            key = replace(scenario, attackers=None, defenders=None)
            built = self._built.setdefault(copy, {})
            if key not in built:
                built[key] = self.factory(key)
            self.current[copy] = built[key]
            built[key].reset(scenario)

    def act_batch(self, states: BatchState) -> np.ndarray:
        count = (states.attacker_positions if self.side == "attackers"
                 else states.defender_positions).shape[1]
        prefix = "attacker_" if self.side == "attackers" else "defender_"
        out = np.zeros((len(states.step), count, 2))
        for k in range(len(states.step)):
            for name, action in self.current[k].act(states.game_state(k)).items():
                if name.startswith(prefix):
                    out[k, int(name[len(prefix):])] = action
        return out


def merged_overlay(*policies: Policy) -> Overlay | None:
    """The union of the policies' overlays (edges with their kinds, text lines); ``None`` if
    none draws."""
    overlays = []
    for policy in policies:
        overlay = getattr(policy, "overlay", None)
        if callable(overlay) and (drawn := overlay()) is not None:
            overlays.append(drawn)
    if not overlays:
        return None
    return Overlay(edges=tuple(e for o in overlays for e in o.edges),
                   lines=tuple(line for o in overlays for line in o.lines),
                   kinds=tuple(e.kind for o in overlays for e in o.kinded_edges))

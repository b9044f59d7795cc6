"""The game's state as policies and the renderer read it: one game (``GameState``) and K
copies of a game at once (``BatchState``, axis 0 the copy). The policy protocols that act
on them are in ``reachavoid_env.policy``, what a policy draws in ``reachavoid_env.overlay``."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum
from typing import NamedTuple

import numpy as np


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

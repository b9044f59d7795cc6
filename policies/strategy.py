"""How an assignment defender plays, as one frozen record of small strategy objects.

``Strategy`` gathers the choices that the assignment defenders
(``policies.batch_defenders.BatchAssignmentDefenders``) play by (as
``solvers.hj.SolverSettings`` gathers a solve's):

- ``program`` (decide): which assignment program each step solves (``Program``);
- ``margin_cells`` (keep): the certificate margin; games that clear it are kept
  (``policies.certificate``; 0: nothing is kept, the paper's rule);
- ``spare`` (plan): what the defenders outside the games played do (``Spare``): race
  the team's intercept plan (and steer the certified 1 vs 1 games towards it,
  ``policies.steering``), or play the assignment's games and shadow, pursue or stand.

Each choice is an enum member, equal to its name (``Spare.STAND == "stand"``); the
constructors take either, as the command line's ``--defender-option`` gives a name.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from policies.lookups import DecisionTables
from policies.tube_states import team_states
from reachavoid_env import GameState, checks
from solvers.assignment import Assignment, AssignmentSolver
from solvers.hj import ValueFunction

CERTIFICATE_CELLS = 1.0
"""Default certificate margin in grid cells of each tube: a game becomes certified where
its value exceeds this many of the tube's largest grid spacing (map units). It lies
above every tube error measured on the paper map (the figures: BENCHMARKS.md
"Guarantee")."""

MAX_MARGIN_CELLS = 10.0
"""The largest certificate margin accepted (grid cells)."""


def check_margin_cells(value: float, field: str = "margin_cells") -> float:
    """The one rule for a certificate margin: a number in [0, ``MAX_MARGIN_CELLS``]."""
    return checks.real(value, field, 0.0, MAX_MARGIN_CELLS)


class Program(str, enum.Enum):
    """The assignment program solved each step (``solvers.assignment``)."""

    MIP = "mip"
    """The paper's MIP (c1)-(c5); with a 1 vs 2 tube, its teams (c6)-(c9)."""
    MATCHING = "matching"
    """The maximum-matching baseline: one attacker per defender."""

    def solver(self) -> AssignmentSolver:
        """A fresh solver of this program (its cache answers an unchanged program)."""
        return AssignmentSolver(self.value)

    def solve(self, solver: AssignmentSolver, tables: DecisionTables,
              teams: np.ndarray | None = None) -> Assignment:
        """The assignment of the program's active attackers (``tables.active``) from its
        1 vs 1 table ``tables.beats`` (attacker ``i`` beats defender ``j``) and, for the
        MIP, its 2 vs 1 table and, given ``teams``, the 1 vs 2 table ``(M, N, N)`` where
        a team could form (``team_table``); ``tables.busy`` defenders take nothing."""
        if self is Program.MATCHING:
            return solver.solve(tables.beats, None, tables.active)
        if teams is None:
            return solver.solve(tables.beats, tables.beats_2v1, tables.active)
        return solver.solve(tables.beats, tables.beats_2v1, tables.active, beats_1v2=teams)


def team_table(vf12: ValueFunction, state: GameState, tables: DecisionTables) -> np.ndarray:
    """The 1 vs 2 table ``(M, N, N)``, looked up where a team could be formed (the
    attacker active and beating both defenders alone, neither defender ``busy``); true
    elsewhere."""
    beats, active, busy = tables.beats, tables.active, tables.busy
    m, n = beats.shape
    table = np.ones((m, n, n), dtype=bool)
    free = ~busy
    open_ = (beats[:, :, None] & beats[:, None, :] & np.triu(np.ones((n, n), bool), 1)
             & (free[:, None] & free[None, :])[None])
    teams = np.argwhere(open_ & active[:, None, None])
    if len(teams):
        wins = vf12.value(team_states(state.attacker_positions, state.defender_positions,
                                      teams)) <= 0.0
        table[teams[:, 0], teams[:, 1], teams[:, 2]] = wins
        table[teams[:, 0], teams[:, 2], teams[:, 1]] = wins
    return table


class Spare(str, enum.Enum):
    """What the defenders outside the games played do."""

    INTERCEPT = "intercept"
    """Race the team's intercept plan (``policies.intercept``); the certified games are
    played, a certified 1 vs 1 game's defender steering towards the plan as far as its
    certificate allows, and so are the program's games whose defender the plan sends after
    the game's attacker or one of its pair (``policies.steering.game_keepers``)."""
    SHADOW = "shadow"
    """Play the assignment's games; an unassigned defender shadows, with the 1 vs 1
    optimal control, the unassigned attacker it is best placed against (largest 1 vs 1
    value; any attacker if none is unassigned)."""
    STAND = "stand"
    """Play the assignment's games; an unassigned defender stands still (the paper)."""
    PURSUE = "pursue"
    """Play the assignment's games; an unassigned defender pursues the nearest active
    attacker with the 1 vs 1 optimal control."""

    @classmethod
    def named(cls, value: str | Spare, field: str, choices: tuple[Spare, ...]) -> Spare:
        """``value`` (a member or its name) if it is one of ``choices``, else a
        ``ValueError`` naming ``field``."""
        spare = next((s for s in choices if value is s or value == s.value), None)
        if spare is None:
            raise ValueError(f"{field}: expected one of "
                             f"{', '.join(s.value for s in choices)}, got {value!r}")
        return spare

    def targets(self, state: GameState, assignment: Assignment, idle: list[int],
                values11: np.ndarray) -> list[tuple[int, int]]:
        """``(attacker, defender)``: the attacker whose 1 vs 1 optimal control each of the
        unassigned defenders ``idle`` plays (those left out stand still; ``INTERCEPT``
        plays the plan instead); ``values11 (M, N)`` is the step's 1 vs 1 table."""
        if self is Spare.SHADOW:
            active = state.active_attackers.tolist()
            taken = {i for i, _ in assignment.pairs} | {i for i, *_ in assignment.shared}
            pool = ([i for i, on in enumerate(active) if on and i not in taken]
                    or [i for i, on in enumerate(active) if on])
            values = values11.tolist()
            return [(max(pool, key=lambda i, j=j: values[i][j]), j) for j in idle]
        if self is Spare.PURSUE:
            active = np.flatnonzero(state.active_attackers)
            gaps = (state.attacker_positions[active][:, None, :]
                    - state.defender_positions[idle][None, :, :])
            nearest = active[np.argmin(np.hypot(gaps[..., 0], gaps[..., 1]), axis=0)]
            return [(int(i), j) for j, i in zip(idle, nearest, strict=True)]
        return []


@dataclass(frozen=True)
class Strategy:
    """How an assignment defender plays (module docstring): its ``program``, its
    certificate margin ``margin_cells`` (grid cells of each tube) and what its ``spare``
    defenders do. Names are taken for the enums."""

    program: Program = Program.MIP
    margin_cells: float = CERTIFICATE_CELLS
    spare: Spare = Spare.INTERCEPT

    def __post_init__(self) -> None:
        object.__setattr__(self, "program", _member(Program, self.program, "strategy.program"))
        object.__setattr__(self, "spare", _member(Spare, self.spare, "strategy.spare"))
        object.__setattr__(self, "margin_cells", check_margin_cells(self.margin_cells))

    @property
    def certifies(self) -> bool:
        """Whether games are certified and kept (a margin above 0)."""
        return self.margin_cells > 0.0

    @property
    def plans(self) -> bool:
        """Whether the spare defenders race the intercept plan (else the assignment's
        games are played)."""
        return self.spare is Spare.INTERCEPT

    def replace(self, **changes: Any) -> Strategy:
        return replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Every field by name, the enums by their names."""
        return {"program": self.program.value, "margin_cells": self.margin_cells,
                "spare": self.spare.value}


def _member(kind: type[enum.Enum], value: Any, field: str) -> Any:
    """``value`` as a member of ``kind`` (a member or its name), else a ``ValueError``
    naming ``field``."""
    try:
        return kind(value)
    except ValueError:
        raise ValueError(f"{field}: expected one of {', '.join(m.value for m in kind)}, "
                         f"got {value!r}") from None

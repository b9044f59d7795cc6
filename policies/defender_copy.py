"""What the assignment defenders carry for one copy of a game from step to step, and what
they tell of it (``DefenderCopy``): the certified games, the games played, the captures
guaranteed, the overlay. ``policies.batch_defenders.BatchAssignmentDefenders`` keeps one
per copy; ``policies.assignment_defender.AssignmentDefender`` reads copy 0's.
Index pairs are ``(attacker, defender)``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from policies import drawing
from policies.certificate import Match, games_of, roles_of
from policies.intercept import Plan
from policies.lookups import DecisionTables
from reachavoid_env import BatchState, GameState, Overlay
from reachavoid_env.geodesic import DistanceField
from solvers.assignment import Assignment, AssignmentSolver


class Decision(NamedTuple):
    """One step's decision in one copy: the copy's tables (``DecisionTables`` without the
    copy axis), the certified games of the last decision still on (``kept``), the
    assignment played (the program's answer with ``kept`` joined) and the open-space
    wins ``(M, N)`` (all false without the certificate); the step's ``states`` and the
    copy's index ``k`` in them (``state``)."""

    tables: DecisionTables
    kept: list[Match]
    assignment: Assignment
    wins: np.ndarray
    states: BatchState
    k: int

    @property
    def state(self) -> GameState:
        """The copy's ``GameState`` of the step."""
        return self.states.game_state(self.k)


class StepPlan(NamedTuple):
    """The step's plan of every live copy, as ``policies.steering.play_plan`` gave it
    (``plan`` ``(L, N)`` targets, ``(L, N, 2)`` aims; the keepers as ``copies``,
    ``keepers`` rows), and which copy of it is this one (``index``): read when asked."""

    plan: Plan
    copies: np.ndarray
    keepers: np.ndarray
    index: int


def _no_games(columns: int) -> np.ndarray:
    return np.zeros((0, columns), dtype=np.int64)


@dataclass
class DefenderCopy:
    """One copy's defenders (module docstring): the program's ``solver`` and the
    ``nominal`` one (``BatchAssignmentDefenders.nominal_captures``), the ``certified``
    games, the attackers' ``previous``
    positions (``None`` before the first decision or after a game without attackers),
    the program's 1 vs 1 and pair games of the step (``Roles.singles``, ``doubles``:
    the plan reads them), the step's ``decision`` and ``step_plan`` (``None`` where none:
    its ``plan`` and ``keepers``, the defenders of the program's games that keep the game's
    control, read from it),
    the ``nominal`` count once asked, and the single each uncertified pair game's defender
    keeps won (``hedges``, defender -> attacker: ``policies.steering.hedge_pairs``)."""

    solver: AssignmentSolver
    nominal_solver: AssignmentSolver
    certified: list[Match] = field(default_factory=list)
    previous: np.ndarray | None = None
    singles: np.ndarray = field(default_factory=lambda: _no_games(2))
    doubles: np.ndarray = field(default_factory=lambda: _no_games(3))
    decision: Decision | None = None
    step_plan: StepPlan | None = None
    nominal: int | None = None
    hedges: dict[int, int] = field(default_factory=dict)

    def clear(self) -> None:
        """A step without attackers in the game: no decision, nothing certified."""
        self.certified, self.previous = [], None
        self.decision = self.step_plan = self.nominal = None

    @property
    def plan(self) -> Plan | None:
        """The step's intercept plan of this copy (``None`` without one)."""
        step = self.step_plan
        if step is None:
            return None
        return Plan(step.plan.targets[step.index], step.plan.aims[step.index])

    @property
    def keepers(self) -> np.ndarray:
        """The defenders of this copy that keep their game's control this step."""
        step = self.step_plan
        if step is None:
            return np.zeros(0, dtype=np.int64)
        return step.keepers[step.copies == step.index]

    @property
    def played(self) -> list[Match]:
        """With the plan: the certified games and the program's games whose defender is
        one of the step's ``keepers`` (``policies.steering.game_keepers``)."""
        if self.decision is None or not len(self.keepers):
            return list(self.certified)
        keepers = set(self.keepers.tolist())
        return self.certified + [match for match in roles_of(self.decision.assignment).games
                                 if len(match.defenders) == 1
                                 and match.defenders[0] in keepers]

    def played_games(self, plans: bool) -> list[Match]:
        """The games of the last decision played by their own controls: with the intercept
        plan (``plans``), the certified games and the program's games whose defender
        keeps the game's control (``policies.steering.game_keepers``); without it, every
        game of the assignment."""
        if plans or self.decision is None:
            return list(self.played)
        return games_of(self.decision.assignment)

    @property
    def guaranteed_captures(self) -> int | None:
        """Attackers certified never to reach the target from now on: those of the
        certified games of the last decision (``None`` before the first decision)."""
        if self.decision is None:
            return None
        return sum(len(game.attackers) for game in self.certified)

    def races(self) -> tuple[tuple[int, int], ...]:
        """``(attacker, defender)``: the plan's race of every defender outside the games
        played (none without the plan)."""
        if self.plan is None:
            return ()
        free = np.ones(len(self.plan.targets), dtype=bool)
        free[[j for game in self.played for j in game.defenders]] = False
        return tuple((int(self.plan.targets[j]), int(j)) for j in np.flatnonzero(free)
                     if self.plan.targets[j] >= 0)

    def overlay(self, plans: bool, nominal: int | None, paths: DistanceField | None) -> Overlay:
        """The games played and the races along their ways (``policies.drawing``), with
        the counts line (``nominal``: the program's count)."""
        decision = self.decision
        if decision is None:
            return Overlay()
        state = decision.state
        line = (f"guaranteed: {self.guaranteed_captures} of "
                f"{int(state.active_attackers.sum())}, program's count: {nominal}")
        races = self.races()
        ways = (functools.partial(drawing.race_routes, paths, state, self.plan, races)
                if races else None)
        return drawing.overlay(self.played_games(plans), races, line, ways)

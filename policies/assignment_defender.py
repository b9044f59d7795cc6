"""The assignment defenders in one game: ``AssignmentDefender`` is the one engine
(``policies.batch_defenders.BatchAssignmentDefenders``) played at one copy
(``reachavoid_env.Single``); ``policies.defenders`` composes the reference defenders from
it. Index pairs are ``(attacker, defender)`` throughout (``solvers.assignment`` states
the order).
"""

from __future__ import annotations

from policies.batch_defenders import BatchAssignmentDefenders
from policies.certificate import Match
from policies.defender_copy import DefenderCopy
from policies.intercept import Plan
from policies.strategy import Strategy
from reachavoid_env import Overlay
from reachavoid_env.policy import Single
from solvers.assignment import Assignment, AssignmentSolver
from solvers.hj import ValueFunction


class AssignmentDefender(Single):
    """Defenders that solve an assignment of the tubes' games every step (``strategy``
    says which program, which margin, and what the spare defenders do): the engine
    ``BatchAssignmentDefenders`` (its docstring tells the play) at one copy.

    Besides ``reset`` and ``act``, it tells of its game: ``certified_games``,
    ``played_games``, ``guaranteed_captures``, ``nominal_captures``,
    ``last_assignment``, ``plan``, ``overlay()``; ``solver`` (an ``AssignmentSolver``)
    counts the solves and the reused answers. The engine's ``vf11``, ``vf21``, ``vf12``,
    ``strategy``, ``tubes``, ``margin_cells`` and ``margin(vf)`` are read through.
    """

    def __init__(self, vf11: ValueFunction, vf21: ValueFunction | None,
                 vf12: ValueFunction | None, strategy: Strategy) -> None:
        super().__init__(BatchAssignmentDefenders(vf11, vf21, vf12, strategy))
        program = strategy.program
        self._before = DefenderCopy(program.solver(), program.solver())

    @property
    def _copy(self) -> DefenderCopy:
        """The game's ``DefenderCopy`` (an empty one before the first reset)."""
        copies = self.batch.copies
        return copies[0] if copies and copies[0] is not None else self._before

    @property
    def solver(self) -> AssignmentSolver:
        """The program's solver (its counts go on from episode to episode)."""
        return self._copy.solver

    @property
    def assignment(self) -> list[tuple[str, str]]:
        """The current ``(defender, attacker)`` assignment edges (names, as the overlay's)."""
        if self.last_assignment is None:
            return []
        return [(f"defender_{j}", f"attacker_{i}") for i, j in self.last_assignment.pairs]

    @property
    def certified_games(self) -> list[Match]:
        """The games of the last decision that are certified (``policies.certificate``)."""
        return list(self._copy.certified)

    @property
    def played_games(self) -> list[Match]:
        """The games of the last decision played by their own controls
        (``DefenderCopy.played_games``)."""
        return self._copy.played_games(self.batch.strategy.plans)

    @property
    def guaranteed_captures(self) -> int | None:
        """Attackers certified never to reach the target from now on (``None`` before the
        first decision)."""
        return self._copy.guaranteed_captures

    @property
    def nominal_captures(self) -> int | None:
        """The paper's count at this step (``BatchAssignmentDefenders.nominal_captures``)."""
        return self.batch.nominal_captures(0)

    @property
    def last_assignment(self) -> Assignment | None:
        """The last step's ``Assignment`` (indices), ``None`` before the first step."""
        decision = self._copy.decision
        return None if decision is None else decision.assignment

    @property
    def plan(self) -> Plan | None:
        """The last step's intercept plan (``None`` without one)."""
        return self._copy.plan

    def overlay(self) -> Overlay:
        """The games played and the races along their ways, with the counts line."""
        return self.batch.overlay(0)

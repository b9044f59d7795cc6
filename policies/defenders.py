"""Scripted and solver-backed defender policies (``GreedyDefender`` comes from
``policies.greedy``).

Each follows ``reachavoid_env.Policy``: ``reset(scenario)`` then ``act(state)``, which
returns a float32 ``(2,)`` action in ``[-1, 1]`` (a velocity as a fraction of the
defender's speed) for every defender. The certificate margin's default and rule live in
``policies.strategy``.
"""

from __future__ import annotations

import numpy as np

from policies.assignment_defender import AssignmentDefender
from policies.greedy import GreedyDefender
from policies.strategy import CERTIFICATE_CELLS, Program, Spare, Strategy
from policies.tubes import tube_1v1, tube_1v2, tube_2v1
from reachavoid_env import GameState, Scenario
from solvers.hj import PAPER_GRIDS, ValueFunction

__all__ = ["GreedyDefender", "HJDefenderPolicy", "HJPairsDefenderPolicy", "IdleDefender",
           "MatchingDefenderPolicy"]


class IdleDefender:
    """Every defender stands still."""

    def reset(self, scenario: Scenario) -> None:
        """Nothing to prepare: the defender names come with each state."""

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        return {name: np.zeros(2, dtype=np.float32) for name in state.defender_names}


class HJDefenderPolicy(AssignmentDefender):
    """The reference defenders: the paper's iterative capture algorithm (Algorithm 1, HJ
    tubes + the assignment MIP) with its certificate, and the strongest play we know
    where the certificate does not reach.

    Every step: ``I_j`` from the 1 vs 1 tube, ``P_j`` from the 2 vs 1 tube at the current
    positions, the MIP (c1)-(c5) solved to optimality on CP-SAT; a defender with two
    attackers plays the 2 vs 1 optimal control, with one the 1 vs 1 optimal control.
    Certified games are kept (``margin_cells``, see ``AssignmentDefender``):
    ``guaranteed_captures`` counts them, ``nominal_captures`` is the MIP objective of the
    paper's rule. ``vf12`` (a 1 vs 2 tube) lets the program form teams
    (``HJPairsDefenderPolicy``).

    ``idle`` says what the defenders outside the certified games do
    (``policies.strategy.Spare``): ``"intercept"`` (default) play the team's intercept plan
    (``policies.intercept``; a certified 1 vs 1 game's defender too, as far as its
    certificate allows; the defender of an uncertified game of the program keeps the
    game's optimal control while the plan sends it after the game's attacker or one of
    its pair, ``policies.steering.game_keepers``); ``"shadow"`` plays the assignment's games and
    shadows, with the 1 vs 1 optimal control, the unassigned attacker it is best placed against;
    ``"stand"`` plays the assignment's games and stands still unassigned, as in the
    paper's simulations. ``paper`` builds the paper's method exactly (``"stand"``,
    ``margin_cells=0``).
    """

    IDLE = (Spare.INTERCEPT, Spare.SHADOW, Spare.STAND)
    """The choices of ``idle``."""

    def __init__(self, vf11: ValueFunction, vf21: ValueFunction | None,
                 idle: str | Spare = "intercept", margin_cells: float = CERTIFICATE_CELLS,
                 *, vf12: ValueFunction | None = None) -> None:
        spare = Spare.named(idle, "idle", self.IDLE)
        if vf11.game != "1v1" or (vf21 is not None and vf21.game != "2v1"):
            raise ValueError(f"vf11, vf21: expected a 1v1 and a 2v1 value function, got "
                             f"{vf11.game!r} and {None if vf21 is None else vf21.game!r}")
        super().__init__(vf11, vf21, vf12, Strategy(Program.MIP, margin_cells, spare))

    @property
    def idle(self) -> Spare:
        """What the defenders outside the certified games do."""
        return self.strategy.spare

    @classmethod
    def for_scenario(cls, scenario: Scenario, grid1: int = PAPER_GRIDS.grid1,
                     grid2: int = PAPER_GRIDS.grid2, idle: str | Spare = "intercept",
                     margin_cells: float = CERTIFICATE_CELLS,
                     progress: bool = True) -> HJDefenderPolicy:
        """Load (or solve, with a progress bar, and cache) the scenario's tubes: the 1 vs 1
        tube, and the 2 vs 1 tube where the scenario has two attackers or more (with one,
        no pair can form)."""
        if scenario.num_attackers < 2:
            return cls(tube_1v1(scenario, grid1, progress), None, idle=idle,
                       margin_cells=margin_cells)
        return cls(*tube_2v1(scenario, grid1, grid2, progress), idle=idle,
                   margin_cells=margin_cells)

    @classmethod
    def paper(cls, scenario: Scenario, grid1: int = PAPER_GRIDS.grid1,
              grid2: int = PAPER_GRIDS.grid2, progress: bool = True) -> HJDefenderPolicy:
        """The paper's Algorithm 1 exactly (registry name ``paper``): every value > 0 a
        defender win (``margin_cells=0``), unassigned defenders stand still."""
        return cls.for_scenario(scenario, grid1, grid2, idle=Spare.STAND, margin_cells=0.0,
                                progress=progress)


class HJPairsDefenderPolicy(HJDefenderPolicy):
    """Algorithm 1 with defender teams (beyond the paper): the MIP with pairs.

    As ``HJDefenderPolicy``, and each step the 1 vs 2 tube gives, for every attacker that
    two defenders each lose to alone, whether the two together stop it (``Q_jk``,
    ``policies.strategy.team_table``); the assignment (c1)-(c9)
    (``solvers.assignment.solve_assignment``) may then give that attacker to the pair,
    which plays the 1 vs 2 optimal controls (both defenders' from the 1 vs 2 value's
    gradient). A defender in a team takes nothing else.
    """

    def __init__(self, vf11: ValueFunction, vf21: ValueFunction, vf12: ValueFunction,
                 idle: str | Spare = "intercept",
                 margin_cells: float = CERTIFICATE_CELLS) -> None:
        if vf12.game != "1v2":
            raise ValueError(f"vf12: expected a 1v2 value function, got {vf12.game!r}")
        super().__init__(vf11, vf21, idle, margin_cells, vf12=vf12)

    @classmethod
    def for_scenario(cls, scenario: Scenario, grid1: int = PAPER_GRIDS.grid1,
                     grid2: int = PAPER_GRIDS.grid2, idle: str | Spare = "intercept",
                     margin_cells: float = CERTIFICATE_CELLS,
                     progress: bool = True) -> HJPairsDefenderPolicy:
        """Load (or solve and cache) the scenario's tubes; both 6D games on ``grid2``^6."""
        vf11, vf21 = tube_2v1(scenario, grid1, grid2, progress)
        return cls(vf11, vf21, tube_1v2(scenario, grid1, grid2, progress), idle=idle,
                   margin_cells=margin_cells)


class MatchingDefenderPolicy(AssignmentDefender):
    """The maximum-matching baseline (Chen, Zhou, Tomlin 2014) as the paper ran it.

    Each step a defender is matched to at most one attacker it beats 1 vs 1 (maximum
    cardinality matching) and plays the 1 vs 1 optimal control against it. Unmatched
    defenders stand still (``unmatched="stand"``, the paper) or pursue the nearest active
    attacker with the 1 vs 1 optimal control (``unmatched="pursue"``; straight at it where
    that control vanishes). Certified pairs are kept (``margin_cells``, see
    ``AssignmentDefender``); ``margin_cells=0`` is the paper's baseline exactly.
    """

    UNMATCHED = (Spare.STAND, Spare.PURSUE)
    """The choices of ``unmatched``."""

    def __init__(self, vf11: ValueFunction, unmatched: str | Spare = "stand",
                 margin_cells: float = CERTIFICATE_CELLS) -> None:
        spare = Spare.named(unmatched, "unmatched", self.UNMATCHED)
        if vf11.game != "1v1":
            raise ValueError(f"vf11: expected a 1v1 value function, got {vf11.game!r}")
        super().__init__(vf11, None, None, Strategy(Program.MATCHING, margin_cells, spare))

    @property
    def unmatched(self) -> Spare:
        """What the unmatched defenders do."""
        return self.strategy.spare

    @classmethod
    def for_scenario(cls, scenario: Scenario, grid1: int = PAPER_GRIDS.grid1,
                     unmatched: str | Spare = "stand",
                     margin_cells: float = CERTIFICATE_CELLS,
                     progress: bool = True) -> MatchingDefenderPolicy:
        """Load (or solve and cache) the scenario's 1 vs 1 tube."""
        return cls(tube_1v1(scenario, grid1, progress), unmatched=unmatched,
                   margin_cells=margin_cells)

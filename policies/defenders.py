"""Scripted and solver-backed defender policies.

Each follows ``reachavoid_env.Policy``: ``reset(scenario)`` then ``act(state)``, which
returns a float32 ``(2,)`` action in ``[-1, 1]`` (a velocity as a fraction of the
defender's speed) for every defender.
"""

from __future__ import annotations

import functools
from abc import ABC, abstractmethod

import numpy as np

from policies.certificate import (
    Game,
    Tubes,
    game_rows,
    games_of,
    joined,
    kept_games,
    no_team_values,
)
from policies.lookups import DecisionTables, TubeArrays, decision_controls, decision_tables
from policies.tubes import tube_1v1, tube_1v2, tube_2v1
from reachavoid_env import GameState, Overlay, Scenario, checks
from reachavoid_env.game_state import EdgeKind
from reachavoid_env.rules import unit_vectors
from solvers.assignment import Assignment, AssignmentSolver
from solvers.hj import ValueFunction


class IdleDefender:
    """Every defender stands still."""

    def reset(self, scenario: Scenario) -> None:
        """Nothing to prepare: the defender names come with each state."""

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        return {name: np.zeros(2, dtype=np.float32) for name in state.defender_names}


class GreedyDefender:
    """Every defender runs at full speed straight at the nearest active attacker.

    Defenders stand still once no attacker is left. ``overlay()`` shows each defender's
    current quarry as an edge.
    """

    def __init__(self) -> None:
        self._edges: tuple[tuple[str, str], ...] = ()

    def reset(self, scenario: Scenario) -> None:
        self._edges = ()

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        active = np.flatnonzero(state.active_attackers)
        names = state.defender_names
        if len(active) == 0:
            self._edges = ()
            return {name: np.zeros(2, dtype=np.float32) for name in names}
        gaps = state.attacker_positions[active][None, :, :] - state.defender_positions[:, None, :]
        distances = np.linalg.norm(gaps, axis=-1)
        nearest = np.argmin(distances, axis=1)
        rows = np.arange(len(names))
        chase, length = gaps[rows, nearest], distances[rows, nearest][:, None]
        actions = np.divide(chase, length, out=np.zeros_like(chase), where=length > 0)
        self._edges = tuple((name, f"attacker_{active[k]}") for name, k in zip(names, nearest,
                                                                                 strict=True))
        return {name: actions[j].astype(np.float32) for j, name in enumerate(names)}

    def overlay(self) -> Overlay:
        return Overlay(edges=self._edges)


def pair_states(attackers: np.ndarray, defenders: np.ndarray) -> np.ndarray:
    """1 vs 1 states ``(M, N, 4)``: every attacker against every defender, axes
    ``(xA, yA, xD, yD)``."""
    states = np.empty((len(attackers), len(defenders), 4))
    states[..., :2] = attackers[:, None, :]
    states[..., 2:] = defenders[None, :, :]
    return states


@functools.lru_cache(maxsize=1024)
def _roles(assignment: Assignment) -> tuple[np.ndarray, np.ndarray, tuple[int, ...],
                                            tuple[Game, ...]]:
    """What each defender of ``assignment`` plays: int64 rows ``(defender, attacker)``
    alone against one, ``(defender, first, second)`` against two; the idle defenders (in
    no game); and its games (``games_of``). Made once per distinct assignment: answers
    recur step after step."""
    in_team = {d for _, j, k in assignment.shared for d in (j, k)}
    singles, doubles, idle = [], [], []
    for j, mine in enumerate(assignment.by_defender):
        if j in in_team:
            continue
        if len(mine) == 2:
            doubles.append((j, *mine))
        elif len(mine) == 1:
            singles.append((j, mine[0]))
        else:
            idle.append(j)
    return (np.array(singles, dtype=np.int64).reshape(-1, 2),
            np.array(doubles, dtype=np.int64).reshape(-1, 3), tuple(idle),
            tuple(games_of(assignment)))


def triple_states(attackers: np.ndarray, pairs: np.ndarray, defenders: np.ndarray) -> np.ndarray:
    """2 vs 1 states ``(P, N, 6)`` for attacker index pairs ``(P, 2)`` against every defender,
    axes ``(xA1, yA1, xA2, yA2, xD, yD)``."""
    p, n = len(pairs), len(defenders)
    first = np.broadcast_to(attackers[pairs[:, 0]][:, None, :], (p, n, 2))
    second = np.broadcast_to(attackers[pairs[:, 1]][:, None, :], (p, n, 2))
    return np.concatenate([first, second, np.broadcast_to(defenders[None], (p, n, 2))], axis=-1)


def team_states(attackers: np.ndarray, defenders: np.ndarray, teams: np.ndarray) -> np.ndarray:
    """1 vs 2 states ``(T, 6)`` for ``teams (T, 3)`` rows ``(attacker, j, k)``: defenders
    ``j`` and ``k`` against the attacker, axes ``(xD1, yD1, xD2, yD2, xA, yA)``."""
    return np.concatenate([defenders[teams[:, 1]], defenders[teams[:, 2]],
                           attackers[teams[:, 0]]], axis=1)


CERTIFICATE_CELLS = 1.0
"""Default certificate margin in grid cells of each tube: a game becomes certified where
its value exceeds this many of the tube's largest grid spacing (map units). Above every
tube error measured on the paper map (BENCHMARKS.md "Guarantee"; the largest coarse value
at random states where a finer tube says the attacker side wins): 1 vs 1 with the paper's
faster defenders 0.23-0.33 cells (25^4-45^4 against 81^4), with equal speeds 0.50-0.56
cells (about 0.8 against the exact value, adding the 81^4 tube's own error), where half a
cell let two certified games be lost in 1,260 episodes; 2 vs 1 0.18-0.24 cells (13^6-20^6
against 30^6), 1 vs 2 0.28 cells (13^6 against 21^6)."""

MAX_MARGIN_CELLS = 10.0
"""The largest certificate margin accepted (grid cells)."""


def check_margin_cells(value: float, field: str = "margin_cells") -> float:
    """The one rule for a certificate margin: a number in [0, ``MAX_MARGIN_CELLS``]."""
    return checks.real(value, field, 0.0, MAX_MARGIN_CELLS)


def _headings(controls: np.ndarray, fallbacks: np.ndarray) -> np.ndarray:
    """``controls (K, 2)`` where non-zero, else the unit vectors along ``fallbacks``."""
    still = ~controls.any(axis=1)
    controls = controls.astype(np.float32)
    if still.any():
        controls[still] = unit_vectors(fallbacks[still])
    return controls


class _AssignmentDefender(ABC):
    """Shared machinery of the HJ + MIP defenders and the matching baseline.

    Each step it reads the 1 vs 1 tube (and the 2 vs 1 tube for the MIP, the 1 vs 2 tube
    with teams) at the current positions (multilinear interpolation), solves the
    assignment, and drives each assigned defender by the optimal control of its game
    (both defenders of a team by the 1 vs 2 controls). ``solver`` (an
    ``AssignmentSolver``) counts the solves and the reused answers.

    **The certificate** (``policies.certificate``). The assignment played is the paper's
    (every value > 0 a defender win), except that the games already certified are kept:
    a game becomes certified when its value clears its tube's margin (``margin_cells`` of
    the tube's grid spacing, above the measured tube error) and stays certified, and
    played, while its value is > 0; the rest of the defenders and attackers are assigned
    by the paper's program. ``guaranteed_captures`` counts the attackers of the certified
    games; ``nominal_captures`` is the paper's count, the objective of the program with
    nothing kept (solved on demand on a second solver, so the training envs, which never
    read it, never pay for it). ``margin_cells=0`` is the paper's Algorithm 1 exactly:
    nothing is kept, and both counts are the program's objective.
    """

    vf12: ValueFunction | None = None

    def __init__(self, vf11: ValueFunction, vf21: ValueFunction | None, method: str,
                 margin_cells: float = CERTIFICATE_CELLS) -> None:
        self.vf11 = vf11
        self.vf21 = vf21
        self.margin_cells = check_margin_cells(margin_cells)
        self.solver = AssignmentSolver(method)
        self._nominal_solver = AssignmentSolver(method)
        self._assignment: Assignment | None = None
        self._certified: list[Game] = []
        self._joined: tuple[Assignment, list[Game], Assignment] | None = None
        self._step: tuple[GameState, bool] | None = None
        self._nominal: int | None = None

    def reset(self, scenario: Scenario) -> None:
        _check_tube(self.vf11, scenario, "vf11")
        self.solver.reset()
        self._nominal_solver.reset()
        self._assignment = self._step = self._nominal = self._joined = None
        self._certified = []

    @property
    def assignment(self) -> list[tuple[str, str]]:
        """The current ``(defender, attacker)`` assignment edges."""
        if self._assignment is None:
            return []
        return [(f"defender_{j}", f"attacker_{i}") for i, j in self._assignment.pairs]

    @property
    def certified_games(self) -> list[Game]:
        """The games of the last decision that are certified (``policies.certificate``)."""
        return list(self._certified)

    @property
    def guaranteed_captures(self) -> int:
        """Attackers certified never to reach the target from now on: those of the
        certified games of the last decision."""
        return sum(len(game.attackers) for game in self._certified)

    @property
    def nominal_captures(self) -> int:
        """The paper's count at this step: the size of the assignment (the MIP objective; the
        matching size for the baseline) with every value > 0 a defender win."""
        if self._assignment is None:
            return 0
        state, fixed_any = self._step
        if not fixed_any:
            return self._assignment.captures
        if self._nominal is None:
            tables = self._tables(state, state.active_attackers, [])
            self._nominal = self._solve(self._nominal_solver, state, tables).captures
        return self._nominal

    def margin(self, vf: ValueFunction) -> float:
        """The certificate margin of ``vf``'s game (map units)."""
        return self.margin_cells * float(max(vf.grid.spacing))

    @functools.cached_property
    def tubes(self) -> Tubes:
        """The tubes and margins the certificate reads."""
        return Tubes(self.vf11, self.vf21, self.vf12,
                     tuple(0.0 if vf is None else self.margin(vf)
                           for vf in (self.vf11, self.vf21, self.vf12)))

    @property
    def last_assignment(self) -> Assignment | None:
        """The last step's ``Assignment`` (indices), ``None`` before the first step."""
        return self._assignment

    def overlay(self) -> Overlay:
        """The assignment edges, and the guaranteed and nominal captures as a text line."""
        if self._assignment is None:
            return Overlay()
        method = "MIP" if self.solver.method == "mip" else "matching"
        teams = tuple((f"defender_{d}", f"attacker_{i}") for i, j, k in self._assignment.shared
                      for d in (j, k))
        # a defender with two attackers plays a 2 vs 1 game (pair); a shared attacker a
        # 1 vs 2 game (team)
        by_defender = self._assignment.by_defender
        kinds = tuple(EdgeKind.PAIR if len(by_defender[j]) == 2 else EdgeKind.ASSIGN
                      for _, j in self._assignment.pairs) + (EdgeKind.TEAM,) * len(teams)
        return Overlay(edges=tuple(self.assignment) + teams, kinds=kinds,
                       lines=(f"{method}: {self.guaranteed_captures} guaranteed, "
                              f"{self.nominal_captures} nominal",))

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        """One decision: the step's tables and the certified games still on (one lookup),
        the assignment keeping those games, the certificate, then every assigned or
        shadowing defender's optimal control (one lookup for the 1 vs 1 and 2 vs 1 games,
        one for teams)."""
        active = state.active_attackers
        names = state.defender_names
        actions = np.zeros((len(names), 2), dtype=np.float32)
        self._nominal = None
        if not active.any():
            self._assignment = self._step = None
            self._certified = []
            return dict(zip(names, actions, strict=True))
        attackers, defenders = state.attacker_positions, state.defender_positions
        certify = self.margin_cells > 0.0
        certified = self._certified if certify else []
        tables = self._tables(state, active, certified)
        kept = kept_games(certified, tables.kept, tables.left)
        assignment = self._solve(self.solver, state, tables)
        if kept:
            last = self._joined
            if last is None or last[0] is not assignment or last[1] != kept:
                self._joined = last = (assignment, kept, joined(assignment, kept, len(names)))
            assignment = last[2]
        self._assignment, self._step = assignment, (state, bool(kept))
        singles, doubles, idle, games = _roles(assignment)
        fresh = [game for game in games if game not in kept]
        if idle:
            shadows = np.array(self._idle_targets(state, list(idle), tables.values11),
                               dtype=np.int64)
            singles = np.concatenate([singles, shadows.reshape(-1, 2)])
        rows, teams = game_rows(tuple(fresh) if certify else ())
        slack = decision_controls(attackers, defenders, singles, doubles, rows, self._margins,
                                  tables.values11, tables.values21, *self._tube_arrays,
                                  actions)
        if certify:
            if len(teams):
                slack[teams] = self.tubes.slack([fresh[g] for g in teams], state,
                                                tables.values11)
            fresh = [game for game, on in zip(fresh, (slack > 0.0).tolist(), strict=True)
                     if on]
        self._certified = kept + fresh
        if assignment.shared:
            teams = np.array(assignment.shared)
            states = team_states(attackers, defenders, teams)
            for column, player in ((1, "D1"), (2, "D2")):
                j = teams[:, column]
                actions[j] = _headings(self.vf12.control(states, player),
                                       attackers[teams[:, 0]] - defenders[j])
        return dict(zip(names, actions, strict=True))

    @functools.cached_property
    def _margins(self) -> np.ndarray:
        """The tubes' certificate margins as ``decision_controls`` takes them."""
        return np.array(self.tubes.margins, dtype=np.float64)

    @functools.cached_property
    def _tube_arrays(self) -> tuple[TubeArrays, TubeArrays | None]:
        """The 1 vs 1 and 2 vs 1 tubes as the batched lookups take them."""
        return TubeArrays.of(self.vf11), None if self.vf21 is None else TubeArrays.of(self.vf21)

    def _tables(self, state: GameState, active: np.ndarray, certified: list[Game]
                ) -> DecisionTables:
        """``decision_tables`` of ``state`` with the ``certified`` games of the last
        decision (the 1 vs 2 values of their teams looked up first)."""
        rows, teams = game_rows(tuple(certified))
        team_values = no_team_values(len(rows))
        if len(teams):
            team_values = np.full(len(rows), np.nan)
            team_values[teams] = self.vf12.value(team_states(
                state.attacker_positions, state.defender_positions, rows[teams][:, [2, 0, 1]]))
        return decision_tables(state.attacker_positions, state.defender_positions, active,
                               rows, team_values, *self._tube_arrays)

    @abstractmethod
    def _solve(self, solver: AssignmentSolver, state: GameState, tables: DecisionTables
               ) -> Assignment:
        """The assignment of the program's active attackers (``tables.active``) from its
        1 vs 1 table ``tables.beats`` (attacker ``i`` beats defender ``j``) and 2 vs 1
        table, reading the 1 vs 2 tube where it binds; ``tables.busy`` defenders take
        nothing."""

    @abstractmethod
    def _idle_targets(self, state: GameState, idle: list[int], values11: np.ndarray
                      ) -> list[tuple[int, int]]:
        """``(defender, attacker)``: the attacker whose 1 vs 1 optimal control each of the
        unassigned defenders ``idle`` plays (those left out stand still); ``values11
        (M, N)`` is this step's 1 vs 1 table."""


def _check_tube(vf: ValueFunction, scenario: Scenario, name: str) -> None:
    """Refuse a tube solved for another map, other speeds or another capture radius."""
    mismatches = [
        field for field, ours, theirs in (
            ("attacker_speed", scenario.attacker_speed, vf.attacker_speed),
            ("defender_speed", scenario.defender_speed, vf.defender_speed),
            ("capture_radius", scenario.capture_radius, vf.capture_radius),
        ) if not np.isclose(ours, theirs)
    ]
    if vf.game_map.to_dict() != scenario.map.to_dict():
        mismatches.append("map")
    if mismatches:
        raise ValueError(f"{name}: the value function was solved for another game "
                         f"(differs in {', '.join(mismatches)}) than scenario {scenario.name!r}")


class HJDefenderPolicy(_AssignmentDefender):
    """The paper's iterative capture algorithm (Algorithm 1): HJ tubes + the assignment MIP.

    Every step: ``I_j`` from the 1 vs 1 tube, ``P_j`` from the 2 vs 1 tube at the current
    positions, the MIP (c1)-(c5) solved to optimality on CP-SAT; a defender with two
    attackers plays the 2 vs 1 optimal control, with one the 1 vs 1 optimal control.

    ``idle`` says what an unassigned defender does: ``"shadow"`` (default) plays the 1 vs 1
    optimal control against the unassigned attacker it is best placed against (largest
    1 vs 1 value; any attacker if none is unassigned), which touches no other defender's
    guarantee; ``"stand"`` stands still, as in the paper's simulations.
    Certified games are kept (``margin_cells``, see the base class):
    ``guaranteed_captures`` counts them, ``nominal_captures`` is the MIP objective of the
    paper's rule; ``margin_cells=0`` is the paper's method exactly.
    """

    def __init__(self, vf11: ValueFunction, vf21: ValueFunction, idle: str = "shadow",
                 margin_cells: float = CERTIFICATE_CELLS) -> None:
        if idle not in ("shadow", "stand"):
            raise ValueError(f"idle: expected 'shadow' or 'stand', got {idle!r}")
        if vf11.game != "1v1" or vf21.game != "2v1":
            raise ValueError(f"vf11, vf21: expected a 1v1 and a 2v1 value function, got "
                             f"{vf11.game!r} and {vf21.game!r}")
        super().__init__(vf11, vf21, "mip", margin_cells)
        self.vf21: ValueFunction = vf21
        self.idle = idle

    @classmethod
    def for_scenario(cls, scenario: Scenario, grid1: int = 45, grid2: int = 30,
                     idle: str = "shadow", margin_cells: float = CERTIFICATE_CELLS,
                     progress: bool = True) -> HJDefenderPolicy:
        """Load (or solve, with a progress bar, and cache) the scenario's tubes."""
        return cls(*tube_2v1(scenario, grid1, grid2, progress), idle=idle,
                   margin_cells=margin_cells)

    def reset(self, scenario: Scenario) -> None:
        super().reset(scenario)
        _check_tube(self.vf21, scenario, "vf21")

    def _solve(self, solver: AssignmentSolver, state: GameState, tables: DecisionTables
               ) -> Assignment:
        return solver.solve(tables.beats, tables.beats_2v1, tables.active)

    def _idle_targets(self, state: GameState, idle: list[int], values11: np.ndarray
                      ) -> list[tuple[int, int]]:
        if self.idle == "stand":
            return []
        active = state.active_attackers.tolist()
        taken = {i for i, _ in self._assignment.pairs} | {i for i, *_ in self._assignment.shared}
        pool = ([i for i, on in enumerate(active) if on and i not in taken]
                or [i for i, on in enumerate(active) if on])
        values = values11.tolist()
        return [(j, max(pool, key=lambda i, j=j: values[i][j])) for j in idle]


class HJPairsDefenderPolicy(HJDefenderPolicy):
    """Algorithm 1 with defender teams (beyond the paper): the MIP with pairs.

    As ``HJDefenderPolicy``, and each step the 1 vs 2 tube gives, for every attacker that
    two defenders each lose to alone, whether the two together stop it (``Q_jk``); the
    assignment (c1)-(c9) (``solvers.assignment.solve_assignment``) may then give that
    attacker to the pair, which plays the 1 vs 2 optimal controls (both defenders' from
    the 1 vs 2 value's gradient). A defender in a team takes nothing else.
    """

    def __init__(self, vf11: ValueFunction, vf21: ValueFunction, vf12: ValueFunction,
                 idle: str = "shadow", margin_cells: float = CERTIFICATE_CELLS) -> None:
        if vf12.game != "1v2":
            raise ValueError(f"vf12: expected a 1v2 value function, got {vf12.game!r}")
        super().__init__(vf11, vf21, idle, margin_cells)
        self.vf12: ValueFunction = vf12

    @classmethod
    def for_scenario(cls, scenario: Scenario, grid1: int = 45, grid2: int = 30,
                     idle: str = "shadow", margin_cells: float = CERTIFICATE_CELLS,
                     progress: bool = True) -> HJPairsDefenderPolicy:
        """Load (or solve and cache) the scenario's tubes; both 6D games on ``grid2``^6."""
        vf11, vf21 = tube_2v1(scenario, grid1, grid2, progress)
        return cls(vf11, vf21, tube_1v2(scenario, grid1, grid2, progress), idle=idle,
                   margin_cells=margin_cells)

    def reset(self, scenario: Scenario) -> None:
        super().reset(scenario)
        _check_tube(self.vf12, scenario, "vf12")

    def _solve(self, solver: AssignmentSolver, state: GameState, tables: DecisionTables
               ) -> Assignment:
        return solver.solve(tables.beats, tables.beats_2v1, tables.active,
                            beats_1v2=self._beats_1v2(state, tables.beats, tables.active,
                                                      tables.busy))

    def _beats_1v2(self, state: GameState, beats: np.ndarray, active: np.ndarray,
                   busy: np.ndarray) -> np.ndarray:
        """The 1 vs 2 table ``(M, N, N)``, looked up where a team could be formed (the
        attacker active and beating both defenders alone, neither defender ``busy``); true
        elsewhere."""
        m, n = beats.shape
        table = np.ones((m, n, n), dtype=bool)
        free = ~busy
        open_ = (beats[:, :, None] & beats[:, None, :] & np.triu(np.ones((n, n), bool), 1)
                 & (free[:, None] & free[None, :])[None])
        teams = np.argwhere(open_ & active[:, None, None])
        if len(teams):
            wins = self.vf12.value(team_states(state.attacker_positions,
                                               state.defender_positions, teams)) <= 0.0
            table[teams[:, 0], teams[:, 1], teams[:, 2]] = wins
            table[teams[:, 0], teams[:, 2], teams[:, 1]] = wins
        return table


class MatchingDefenderPolicy(_AssignmentDefender):
    """The maximum-matching baseline (Chen, Zhou, Tomlin 2014) as the paper ran it.

    Each step a defender is matched to at most one attacker it beats 1 vs 1 (maximum
    cardinality matching) and plays the 1 vs 1 optimal control against it. Unmatched
    defenders stand still (``unmatched="stand"``, the paper) or pursue the nearest active
    attacker with the 1 vs 1 optimal control (``unmatched="pursue"``; straight at it where
    that control vanishes). Certified pairs are kept (``margin_cells``, see the base class);
    ``margin_cells=0`` is the paper's baseline exactly.
    """

    def __init__(self, vf11: ValueFunction, unmatched: str = "stand",
                 margin_cells: float = CERTIFICATE_CELLS) -> None:
        if unmatched not in ("stand", "pursue"):
            raise ValueError(f"unmatched: expected 'stand' or 'pursue', got {unmatched!r}")
        if vf11.game != "1v1":
            raise ValueError(f"vf11: expected a 1v1 value function, got {vf11.game!r}")
        super().__init__(vf11, None, "matching", margin_cells)
        self.unmatched = unmatched

    @classmethod
    def for_scenario(cls, scenario: Scenario, grid1: int = 45, unmatched: str = "stand",
                     margin_cells: float = CERTIFICATE_CELLS,
                     progress: bool = True) -> MatchingDefenderPolicy:
        """Load (or solve and cache) the scenario's 1 vs 1 tube."""
        return cls(tube_1v1(scenario, grid1, progress), unmatched=unmatched,
                   margin_cells=margin_cells)

    def _solve(self, solver: AssignmentSolver, state: GameState, tables: DecisionTables
               ) -> Assignment:
        return solver.solve(tables.beats, None, tables.active)

    def _idle_targets(self, state: GameState, idle: list[int], values11: np.ndarray
                      ) -> list[tuple[int, int]]:
        if self.unmatched == "stand":
            return []
        active = np.flatnonzero(state.active_attackers)
        gaps = (state.attacker_positions[active][:, None, :]
                - state.defender_positions[idle][None, :, :])
        nearest = active[np.argmin(np.hypot(gaps[..., 0], gaps[..., 1]), axis=0)]
        return [(j, int(i)) for j, i in zip(idle, nearest, strict=True)]

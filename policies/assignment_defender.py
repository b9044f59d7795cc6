"""The engine of the HJ + assignment defenders and the matching baseline.

``AssignmentDefender`` plays a ``policies.strategy.Strategy`` with the tubes it is given;
``policies.defenders`` composes the reference defenders from it. Index pairs are
``(attacker, defender)`` throughout (``solvers.assignment`` states the order).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from policies import drawing
from policies.certificate import (
    Basis,
    Match,
    OpenSpace,
    Tubes,
    games_of,
    joined_once,
    kept_games,
    match_arrays,
    open_games,
    roles_of,
)
from policies.intercept import Plan
from policies.lookups import DecisionTables, TubeArrays, decision_controls, decision_tables
from policies.steering import PlanGames, Tempo, play_plan
from policies.strategy import Program, Strategy
from policies.tube_states import control_headings, pair_states, team_states, team_values
from policies.tubes import check_tube
from reachavoid_env import GameState, Overlay, Scenario
from reachavoid_env.geodesic import DistanceField, distance_field
from solvers.assignment import Assignment
from solvers.hj import ValueFunction


class Decision(NamedTuple):
    """One step's decision before its controls: the step's tables, the certified games of
    the last decision still on (``kept``), the assignment played (the program's answer
    with ``kept`` joined) and the open-space wins ``(M, N)`` (``OpenSpace.wins``; all
    false without it)."""

    state: GameState
    tables: DecisionTables
    kept: list[Match]
    assignment: Assignment
    wins: np.ndarray


class AssignmentDefender:
    """Defenders that solve an assignment of the tubes' games every step (``strategy``
    says which program, which margin, and what the spare defenders do).

    Each step it reads the 1 vs 1 tube (and the 2 vs 1 tube for the MIP, the 1 vs 2 tube
    with teams) at the current positions (multilinear interpolation), solves the
    assignment, and drives each defender of a certified game by the optimal control of its
    game (both defenders of a team by the 1 vs 2 controls). ``solver`` (an
    ``AssignmentSolver``) counts the solves and the reused answers.

    **The certificate** (``policies.certificate``). The assignment played is the paper's
    (every value > 0 a defender win), except that the games already certified are kept:
    a game becomes certified when its value clears its tube's margin (``margin_cells`` of
    the tube's grid spacing, above the measured tube error) and stays certified, and
    played, while its value is > 0; the rest of the defenders and attackers are assigned
    by the program. ``guaranteed_captures`` counts the attackers of the certified
    games; ``nominal_captures`` is the paper's count, the objective of the program with
    nothing kept (solved on demand on a second solver, so the training envs, which never
    read it, never pay for it). ``margin_cells=0`` is the paper's Algorithm 1 exactly:
    nothing is kept, and both counts are the program's objective. Where defenders are
    faster, a 1 vs 1 game is also certified by the open-space condition
    (``policies.certificate.OpenSpace``), which the program sees as a win, and is then
    played by parallel navigation (``_play_open``, over whatever the free play wrote).

    **The spare defenders** (``policies.strategy.Spare``). ``INTERCEPT``: the plan
    proposes, the certificate filters. One ``policies.intercept.plan_intercepts`` plan of
    the whole team each step; every defender outside the certified games (with
    ``margin_cells=0`` every game of the assignment is one) plays it, but for the defender
    of an uncertified game of the program whom the plan sends after the game's attacker
    (or one of its pair), which keeps the game's optimal control
    (``policies.steering.game_keepers``: an attacker off its shortest path beats the
    plan); the defender of a certified 1 vs 1 game plays the plan as far as the value
    allows (``policies.steering.steer``); certified pairs and teams keep their optimal
    controls. The others: every assigned
    defender plays its game's optimal control and the unassigned ones the attacker
    ``Spare.targets`` gives them.
    """

    def __init__(self, vf11: ValueFunction, vf21: ValueFunction | None,
                 vf12: ValueFunction | None, strategy: Strategy) -> None:
        self.vf11 = vf11
        self.vf21 = vf21
        self.vf12 = vf12
        self.strategy = strategy
        self.tubes = Tubes.of(vf11, vf21, vf12, strategy.margin_cells)
        self._margins = np.array(self.tubes.margins, dtype=np.float64)
        self._tube_arrays = (TubeArrays.of(vf11), None if vf21 is None else TubeArrays.of(vf21))
        self.solver = strategy.program.solver()
        self._nominal_solver = strategy.program.solver()
        self._decision: Decision | None = None
        self._certified: list[Match] = []
        self._played: list[Match] = []
        self._nominal: int | None = None
        self._plan: Plan | None = None
        self._field: DistanceField | None = None
        self._open: OpenSpace | None = None
        self._previous: np.ndarray | None = None
        self._dt = 0.0

    @property
    def margin_cells(self) -> float:
        """The certificate margin (grid cells of each tube)."""
        return self.strategy.margin_cells

    def reset(self, scenario: Scenario) -> None:
        check_tube(self.vf11, scenario, "vf11")
        if self.vf21 is not None:
            check_tube(self.vf21, scenario, "vf21")
        elif self.strategy.program is Program.MIP and scenario.num_attackers > 1:
            raise ValueError(f"vf21: {scenario.name!r} has {scenario.num_attackers} "
                             f"attackers; these defenders were built without the 2 vs 1 tube")
        if self.vf12 is not None:
            check_tube(self.vf12, scenario, "vf12")
        self.solver.reset()
        self._nominal_solver.reset()
        self._decision = self._nominal = self._plan = None
        self._certified, self._played = [], []
        self._dt = scenario.dt
        self._open = OpenSpace.of(scenario) if self.strategy.certifies else None
        self._previous = None
        if self.strategy.plans:
            self._field = distance_field(scenario.map, scenario.player_radius)

    @property
    def assignment(self) -> list[tuple[str, str]]:
        """The current ``(defender, attacker)`` assignment edges (names, as the overlay's)."""
        if self.last_assignment is None:
            return []
        return [(f"defender_{j}", f"attacker_{i}") for i, j in self.last_assignment.pairs]

    @property
    def certified_games(self) -> list[Match]:
        """The games of the last decision that are certified (``policies.certificate``)."""
        return list(self._certified)

    @property
    def played_games(self) -> list[Match]:
        """The games of the last decision played by their own controls: with the intercept
        plan, the certified games and the program's games whose defender keeps the game's
        control (``policies.steering.game_keepers``); without it, every game of the
        assignment."""
        if self.strategy.plans or self._decision is None:
            return list(self._played)
        return games_of(self._decision.assignment)

    @property
    def guaranteed_captures(self) -> int | None:
        """Attackers certified never to reach the target from now on: those of the
        certified games of the last decision (``None`` before the first decision)."""
        if self._decision is None:
            return None
        return sum(len(game.attackers) for game in self._certified)

    @property
    def nominal_captures(self) -> int | None:
        """The paper's count at this step: the size of the assignment (the MIP objective; the
        matching size for the baseline) with every value > 0 a defender win (``None``
        before the first decision)."""
        decision = self._decision
        if decision is None:
            return None
        if not decision.kept:
            return decision.assignment.captures
        if self._nominal is None:
            state = decision.state
            tables = self._tables(state, state.active_attackers, [], decision.wins)
            self._nominal = self.strategy.program.solve(self._nominal_solver, state, tables,
                                                        self.vf12).captures
        return self._nominal

    def margin(self, vf: ValueFunction) -> float:
        """The certificate margin of ``vf``'s game (map units)."""
        return self.margin_cells * float(max(vf.grid.spacing))

    @property
    def last_assignment(self) -> Assignment | None:
        """The last step's ``Assignment`` (indices), ``None`` before the first step."""
        return None if self._decision is None else self._decision.assignment

    def overlay(self) -> Overlay:
        """The games played (with the intercept plan the certified ones and the pair games
        whose defender keeps the pair's control, else the assignment's) and the races
        along their ways (``policies.drawing``)."""
        decision = self._decision
        if decision is None:
            return Overlay()
        games = self.played_games
        line = (f"guaranteed: {self.guaranteed_captures} of "
                f"{int(decision.state.active_attackers.sum())}, "
                f"program's count: {self.nominal_captures}")
        races = self._races()
        ways = (functools.partial(drawing.race_routes, self._field, decision.state, self._plan,
                                  races) if races else None)
        return drawing.overlay(games, races, line, ways)

    def _races(self) -> tuple[tuple[int, int], ...]:
        """``(attacker, defender)``: the plan's race of every defender outside the games
        played (none without the plan)."""
        if self._plan is None:
            return ()
        free = np.ones(len(self._plan.targets), dtype=bool)
        free[[j for game in self._played for j in game.defenders]] = False
        return tuple((int(self._plan.targets[j]), int(j)) for j in np.flatnonzero(free)
                     if self._plan.targets[j] >= 0)

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        """One decision: the assignment keeping the certified games (``_decide``), the
        optimal controls of its games and the certificate of the new ones
        (``_play_games``), the teams' controls (``_play_teams``), then, with the
        intercept plan, the plan (``_play_plan``); last, parallel navigation in the
        open-space games (``_play_open``)."""
        names = state.defender_names
        actions = np.zeros((len(names), 2), dtype=np.float32)
        self._nominal = None
        if not state.active_attackers.any():
            self._decision = self._plan = None
            self._certified, self._played = [], []
            self._previous = None
            return dict(zip(names, actions, strict=True))
        decision = self._decision = self._decide(state)
        fresh = self._play_games(decision, actions)
        self._certified = decision.kept + fresh
        self._play_teams(decision, actions)
        if self.strategy.plans:
            self._play_plan(state, actions)
        self._play_open(state, actions)
        self._previous = state.attacker_positions.copy()
        return dict(zip(names, actions, strict=True))

    def _decide(self, state: GameState) -> Decision:
        """The step's tables (one lookup), the certified games still on, and the program's
        answer with them joined."""
        certified = self._certified if self.strategy.certifies else []
        wins = self._open_wins(state)
        held = (np.zeros(len(certified), dtype=bool) if self._open is None
                else self._open.held([certified], *_one_copy(state), wins[None])[0])
        tables = self._tables(state, state.active_attackers, certified, wins, held)
        kept = kept_games(certified, tables.kept, tables.left, held, tables.values11)
        assignment = self.strategy.program.solve(self.solver, state, tables, self.vf12)
        if kept:
            assignment = joined_once(assignment, tuple(kept), len(state.defender_positions))
        return Decision(state, tables, kept, assignment, wins)

    def _open_wins(self, state: GameState) -> np.ndarray:
        """``OpenSpace.wins`` (all false without it), asked where a reader before the
        program reads it: where the 1 vs 1 value is <= 0 (the program's table; a certified
        tube game's ``held``, read only there). Where the value lies in (0, margin] it can
        change something only for a new 1 vs 1 game, and is asked then
        (``_ask_new_games``); above the margin the tube certifies the game."""
        shape = len(state.attacker_positions), len(state.defender_positions)
        if self._open is None:
            return np.zeros(shape, dtype=bool)
        values = self.vf11.value(pair_states(state.attacker_positions,
                                             state.defender_positions))
        asked = (values <= 0.0) & state.active_attackers[:, None]
        return self._open.wins(*_one_copy(state)[:2], asked[None])[0]

    def _ask_new_games(self, decision: Decision, games: list[Match]) -> None:
        """``OpenSpace.wins`` of the 1 vs 1 ``games`` whose 1 vs 1 value lies in (0,
        margin] (not asked by ``_open_wins``), into ``decision.wins``."""
        if self._open is None:
            return
        values = decision.tables.values11
        asked = np.zeros(values.shape, dtype=bool)
        for game in games:
            if len(game.defenders) == len(game.attackers) == 1:
                asked[game.attackers[0], game.defenders[0]] = True
        asked &= ((values > 0.0) & (values <= self.tubes.margins.m11)
                  & decision.state.active_attackers[:, None])
        if asked.any():
            decision.wins[asked] = self._open.wins(*_one_copy(decision.state)[:2],
                                                   asked[None])[0][asked]

    def _play_games(self, decision: Decision, actions: np.ndarray) -> list[Match]:
        """Write the optimal control of every defender alone in a game of the assignment
        (and of every spare one the strategy gives an attacker) into ``actions``; return
        the new games (not kept) that the certificate takes (with ``margin_cells=0``,
        every game: the paper's rule); a 1 vs 1 game the tube does not certify is an
        open-space game where ``decision.wins`` says the defender wins it."""
        state, tables, kept, assignment, wins = decision
        roles = roles_of(assignment)
        singles = roles.singles
        if roles.idle and not self.strategy.plans:
            spare = np.array(self.strategy.spare.targets(state, assignment, list(roles.idle),
                                                         tables.values11), dtype=np.int64)
            singles = np.concatenate([singles, spare.reshape(-1, 2)])
        fresh = [game for game in roles.games if game not in kept]
        certifies = self.strategy.certifies
        games = match_arrays(tuple(fresh) if certifies else ())
        slack = decision_controls(state.attacker_positions, state.defender_positions, singles,
                                  roles.doubles, games, team_values(self.vf12, state, games),
                                  self._margins, tables.values11, tables.values21,
                                  *self._tube_arrays, actions)
        if not certifies:
            return fresh
        self._ask_new_games(decision, fresh)
        return [game if on else Match(game.defenders, game.attackers, Basis.OPEN)
                for game, on, open_ in zip(fresh, (slack > 0.0).tolist(),
                                           open_games(fresh, wins), strict=True)
                if on or open_]

    def _play_open(self, state: GameState, actions: np.ndarray) -> None:
        """Every defender of an open-space game plays parallel navigation (over whatever
        ``actions`` holds): the strategy its certificate is proved for."""
        if self._open is not None:
            self._open.play([self._certified], *_one_copy(state)[:2], [self._previous],
                            actions[None])

    def _play_teams(self, decision: Decision, actions: np.ndarray) -> None:
        """Both defenders of every team play the 1 vs 2 optimal controls."""
        if not decision.assignment.shared:
            return
        attackers = decision.state.attacker_positions
        defenders = decision.state.defender_positions
        teams = np.array(decision.assignment.shared)
        states = team_states(attackers, defenders, teams)
        for column, player in ((1, "D1"), (2, "D2")):
            j = teams[:, column]
            actions[j] = control_headings(self.vf12.control(states, player),
                                          attackers[teams[:, 0]] - defenders[j])

    def _play_plan(self, state: GameState, actions: np.ndarray) -> None:
        """Every defender outside a certified game plays the intercept plan of the whole
        team, but for the defenders of the program's games that keep the game's control
        and the certified games' (``policies.steering.play_plan``, this game as its one
        copy)."""
        roles = roles_of(self._decision.assignment)
        plan, (keepers,) = play_plan(
            self._field, state.attacker_positions[None], state.defender_positions[None],
            state.active_attackers[None], [PlanGames(self._certified, roles.singles,
                                                     roles.doubles)],
            self.vf11, self.tubes.margins.m11,
            Tempo((state.attacker_speed, state.defender_speed), state.capture_radius,
                  self._dt), actions[None])
        self._plan = Plan(plan.targets[0], plan.aims[0])
        self._played = self._certified + [
            game for game in roles.games
            if len(game.defenders) == 1 and game.defenders[0] in keepers]

    def _tables(self, state: GameState, active: np.ndarray, certified: list[Match],
                wins: np.ndarray, held: np.ndarray | None = None) -> DecisionTables:
        """``decision_tables`` of ``state`` with the ``certified`` games of the last
        decision (the 1 vs 2 values of their teams looked up first), the open-space
        ``wins`` and the certified games it ``held`` (none held by default)."""
        games = match_arrays(tuple(certified))
        if held is None:
            held = np.zeros(len(certified), dtype=bool)
        return decision_tables(state.attacker_positions, state.defender_positions, active,
                               games, team_values(self.vf12, state, games), held, wins,
                               *self._tube_arrays)


def _one_copy(state: GameState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``state``'s attackers ``(1, M, 2)``, defenders ``(1, N, 2)`` and active attackers
    ``(1, M)``: the one game as one copy of the batched functions."""
    return (state.attacker_positions[None], state.defender_positions[None],
            state.active_attackers[None])

"""Scripted and solver-backed defender policies.

Each follows ``reachavoid_env.Policy``: ``reset(scenario)`` then ``act(state)``, which
returns a float32 ``(2,)`` action in ``[-1, 1]`` (a velocity as a fraction of the
defender's speed) for every defender.
"""

from __future__ import annotations

import functools
from abc import ABC, abstractmethod
from typing import NamedTuple

import numpy as np

from policies.certificate import (
    Basis,
    Margins,
    Match,
    OpenSpace,
    Tubes,
    games_of,
    joined,
    kept_games,
    match_arrays,
    no_team_values,
)
from policies.geodesic import DistanceField, distance_field
from policies.intercept import headings as intercept_headings
from policies.intercept import plan_intercepts, race_all
from policies.lookups import (
    HEADING_FLOOR,
    DecisionTables,
    Matches,
    TubeArrays,
    decision_controls,
    decision_tables,
)
from policies.tubes import tube_1v1, tube_1v2, tube_2v1
from reachavoid_env import GameState, Overlay, Scenario, checks
from reachavoid_env.game_state import EdgeKind
from reachavoid_env.rules import unit_vectors
from solvers.assignment import Assignment, AssignmentSolver
from solvers.hj import PAPER_GRIDS, ValueFunction


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


class Roles(NamedTuple):
    """What each defender of an assignment plays: int64 rows ``singles (S, 2)``
    ``(defender, attacker)`` alone against one, ``doubles (D, 3)`` ``(defender, first,
    second)`` against two; the ``idle`` defenders (in no game); and its ``games``
    (``games_of``)."""

    singles: np.ndarray
    doubles: np.ndarray
    idle: tuple[int, ...]
    games: tuple[Match, ...]


@functools.lru_cache(maxsize=1024)
def roles_of(assignment: Assignment) -> Roles:
    """``Roles`` of ``assignment``, made once per distinct assignment: answers recur step
    after step."""
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
    return Roles(np.array(singles, dtype=np.int64).reshape(-1, 2),
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
its value exceeds this many of the tube's largest grid spacing (map units). It lies
above every tube error measured on the paper map (the figures: BENCHMARKS.md
"Guarantee")."""

MAX_MARGIN_CELLS = 10.0
"""The largest certificate margin accepted (grid cells)."""


def check_margin_cells(value: float, field: str = "margin_cells") -> float:
    """The one rule for a certificate margin: a number in [0, ``MAX_MARGIN_CELLS``]."""
    return checks.real(value, field, 0.0, MAX_MARGIN_CELLS)


def control_headings(controls: np.ndarray, fallbacks: np.ndarray) -> np.ndarray:
    """``controls (K, 2)`` where non-zero, else the unit vectors along ``fallbacks``."""
    still = ~controls.any(axis=1)
    controls = controls.astype(np.float32)
    if still.any():
        controls[still] = unit_vectors(fallbacks[still])
    return controls


CONE_SLACK = 0.05
"""Added to the cosine a certified defender's heading keeps with its optimal control
(``_AssignmentDefender._steer_certified``), beyond what holds the value to first order."""

_ANGLES = np.linspace(0.0, 2.0 * np.pi, 32, endpoint=False)
ATTACKER_MOVES = np.concatenate([np.stack([np.cos(_ANGLES), np.sin(_ANGLES)], axis=1),
                                 np.zeros((1, 2))])
"""The attacker's moves the one-step check of a certified game tries (``_held_one_step``):
32 headings at full speed, and standing still."""

FREE_PLAY = ("intercept", "assignment")
"""What the defenders outside the held games do (``_AssignmentDefender``)."""

IDLE = ("intercept", "shadow", "stand")
"""``HJDefenderPolicy``'s choices for the defenders outside the certified games."""


class _Decision(NamedTuple):
    """One step's decision before its controls: the step's tables, the certified games of
    the last decision still on (``kept``), the assignment played (the program's answer
    with ``kept`` joined) and the open-space wins ``(M, N)`` (``OpenSpace.wins``; all
    false without it)."""

    state: GameState
    tables: DecisionTables
    kept: list[Match]
    assignment: Assignment
    wins: np.ndarray


@functools.lru_cache(maxsize=1024)
def joined_once(rest: Assignment, kept: tuple[Match, ...], num_defenders: int) -> Assignment:
    """``policies.certificate.joined``, made once per distinct answer and kept games."""
    return joined(rest, list(kept), num_defenders)


class _AssignmentDefender(ABC):
    """Shared machinery of the HJ + MIP defenders and the matching baseline.

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
    by the paper's program. ``guaranteed_captures`` counts the attackers of the certified
    games; ``nominal_captures`` is the paper's count, the objective of the program with
    nothing kept (solved on demand on a second solver, so the training envs, which never
    read it, never pay for it). ``margin_cells=0`` is the paper's Algorithm 1 exactly:
    nothing is kept, and both counts are the program's objective. Where defenders are
    faster, a 1 vs 1 game is also certified by the open-space condition
    (``policies.certificate.OpenSpace``), which the program sees as a win, and is then
    played by parallel navigation (``_play_open``, over whatever the free play wrote).

    **The free defenders.** ``free="intercept"``: the plan proposes, the certificate
    filters. One ``policies.intercept.plan_intercepts`` plan of the whole team (every
    defender, every active attacker) each step; every defender outside the certified games
    (with ``margin_cells=0`` every game of the assignment is one) plays it, and the
    defender of a certified 1 vs 1 game plays it as far as the value allows
    (``_steer_certified``); certified pairs and teams keep their optimal controls.
    ``free="assignment"``: every assigned defender plays its game's optimal control and
    the unassigned ones do what ``_idle_targets`` says.
    """

    def __init__(self, vf11: ValueFunction, vf21: ValueFunction | None,
                 vf12: ValueFunction | None, method: str,
                 margin_cells: float = CERTIFICATE_CELLS, free: str = "intercept") -> None:
        if free not in FREE_PLAY:
            raise ValueError(f"free: expected one of {', '.join(FREE_PLAY)}, got {free!r}")
        self.vf11 = vf11
        self.vf21 = vf21
        self.vf12 = vf12
        self.margin_cells = check_margin_cells(margin_cells)
        self.free = free
        self.solver = AssignmentSolver(method)
        self._nominal_solver = AssignmentSolver(method)
        self._decision: _Decision | None = None
        self._certified: list[Match] = []
        self._nominal: int | None = None
        self._field: DistanceField | None = None
        self._open: OpenSpace | None = None
        self._previous: np.ndarray | None = None

    def reset(self, scenario: Scenario) -> None:
        check_tube(self.vf11, scenario, "vf11")
        self.solver.reset()
        self._nominal_solver.reset()
        self._decision = self._nominal = None
        self._certified = []
        self._races: tuple[tuple[int, int], ...] = ()
        self._dt = scenario.dt
        self._open = OpenSpace.of(scenario) if self._certifies else None
        self._previous = None
        if self.free == "intercept":
            self._field = distance_field(scenario.map, scenario.player_radius)

    @property
    def _assignment(self) -> Assignment | None:
        return None if self._decision is None else self._decision.assignment

    @property
    def assignment(self) -> list[tuple[str, str]]:
        """The current ``(defender, attacker)`` assignment edges."""
        if self._assignment is None:
            return []
        return [(f"defender_{j}", f"attacker_{i}") for i, j in self._assignment.pairs]

    @property
    def certified_games(self) -> list[Match]:
        """The games of the last decision that are certified (``policies.certificate``)."""
        return list(self._certified)

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
            self._nominal = self._solve(self._nominal_solver, state, tables).captures
        return self._nominal

    def margin(self, vf: ValueFunction) -> float:
        """The certificate margin of ``vf``'s game (map units)."""
        return self.margin_cells * float(max(vf.grid.spacing))

    @functools.cached_property
    def tubes(self) -> Tubes:
        """The tubes and margins the certificate reads."""
        return Tubes(self.vf11, self.vf21, self.vf12,
                     Margins(*(0.0 if vf is None else self.margin(vf)
                               for vf in (self.vf11, self.vf21, self.vf12))))

    @property
    def last_assignment(self) -> Assignment | None:
        """The last step's ``Assignment`` (indices), ``None`` before the first step."""
        return self._assignment

    def overlay(self) -> Overlay:
        """The games played, as edges by kind, and the guaranteed and nominal captures as
        a text line. With ``free="assignment"`` the games are the assignment's; with
        ``free="intercept"`` the certified games, and an ``EdgeKind.RACE`` edge from every
        other defender to the attacker it races (the program's uncertified games are not
        played)."""
        if self._assignment is None:
            return Overlay()
        games = (games_of(self._assignment) if self.free == "assignment"
                 else self._certified)
        edges, kinds = [], []
        for game in games:
            # a defender with two attackers plays a 2 vs 1 game (pair); two defenders on one
            # attacker a 1 vs 2 game (team)
            kind = (EdgeKind.TEAM if len(game.defenders) == 2 else
                    EdgeKind.PAIR if len(game.attackers) == 2 else EdgeKind.ASSIGN)
            edges += [(f"defender_{j}", f"attacker_{i}") for j in game.defenders
                      for i in game.attackers]
            kinds += [kind] * (len(game.defenders) * len(game.attackers))
        if self.free == "intercept":
            edges += [(f"defender_{j}", f"attacker_{i}") for j, i in self._races]
            kinds += [EdgeKind.RACE] * len(self._races)
        return Overlay(edges=tuple(edges), kinds=tuple(kinds),
                       lines=(f"guaranteed: {self.guaranteed_captures} of "
                              f"{int(self._decision.state.active_attackers.sum())}, "
                              f"program's count: {self.nominal_captures}",))

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        """One decision: the assignment keeping the certified games (``_decide``), the
        optimal controls of its games and the certificate of the new ones
        (``_play_games``), the teams' controls (``_play_teams``), then, with
        ``free="intercept"``, the plan (``_play_plan``); last, parallel navigation in the
        open-space games (``_play_open``)."""
        names = state.defender_names
        actions = np.zeros((len(names), 2), dtype=np.float32)
        self._nominal = None
        if not state.active_attackers.any():
            self._decision = None
            self._certified = []
            self._previous = None
            return dict(zip(names, actions, strict=True))
        decision = self._decision = self._decide(state)
        fresh = self._play_games(decision, actions)
        self._certified = decision.kept + fresh
        self._play_teams(decision, actions)
        if self.free == "intercept":
            self._play_plan(state, actions)
        self._play_open(state, actions)
        self._previous = state.attacker_positions.copy()
        return dict(zip(names, actions, strict=True))

    @property
    def _certifies(self) -> bool:
        return self.margin_cells > 0.0

    def _decide(self, state: GameState) -> _Decision:
        """The step's tables (one lookup), the certified games still on, and the program's
        answer with them joined."""
        certified = self._certified if self._certifies else []
        wins = self._open_wins(state)
        held = (np.zeros(len(certified), dtype=bool) if self._open is None
                else self._open.held(certified, state, wins))
        tables = self._tables(state, state.active_attackers, certified, wins, held)
        kept = kept_games(certified, tables.kept, tables.left, held, tables.values11)
        assignment = self._solve(self.solver, state, tables)
        if kept:
            assignment = joined_once(assignment, tuple(kept), len(state.defender_positions))
        return _Decision(state, tables, kept, assignment, wins)

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
        return self._open.wins(state, values <= 0.0)

    def _ask_new_games(self, decision: _Decision, games: list[Match]) -> None:
        """``OpenSpace.wins`` of the 1 vs 1 ``games`` whose 1 vs 1 value lies in (0,
        margin] (not asked by ``_open_wins``), into ``decision.wins``."""
        if self._open is None:
            return
        values = decision.tables.values11
        asked = np.zeros(values.shape, dtype=bool)
        for game in games:
            if len(game.defenders) == len(game.attackers) == 1:
                asked[game.attackers[0], game.defenders[0]] = True
        asked &= (values > 0.0) & (values <= self.tubes.margins.m11)
        if asked.any():
            decision.wins[asked] = self._open.wins(decision.state, asked)[asked]

    def _play_games(self, decision: _Decision, actions: np.ndarray) -> list[Match]:
        """Write the optimal control of every defender alone in a game of the assignment
        (and of every shadowing one) into ``actions``; return the new games (not kept)
        that the certificate takes (with ``margin_cells=0``, every game: the paper's
        rule); a 1 vs 1 game the tube does not certify is an open-space game where
        ``decision.wins`` says the defender wins it."""
        state, tables, kept, assignment, wins = decision
        roles = roles_of(assignment)
        singles = roles.singles
        if roles.idle and self.free == "assignment":
            shadows = np.array(self._idle_targets(state, list(roles.idle), tables.values11),
                               dtype=np.int64)
            singles = np.concatenate([singles, shadows.reshape(-1, 2)])
        fresh = [game for game in roles.games if game not in kept]
        games = match_arrays(tuple(fresh) if self._certifies else ())
        slack = decision_controls(state.attacker_positions, state.defender_positions, singles,
                                  roles.doubles, games, self._team_values(state, games),
                                  self._margins, tables.values11, tables.values21,
                                  *self._tube_arrays, actions)
        if not self._certifies:
            return fresh
        self._ask_new_games(decision, fresh)
        return [game if on else Match(game.defenders, game.attackers, Basis.OPEN)
                for game, on, open_ in zip(fresh, (slack > 0.0).tolist(),
                                           open_games(fresh, wins), strict=True)
                if on or open_]

    def _play_open(self, state: GameState, actions: np.ndarray) -> None:
        """Every defender of an open-space game plays parallel navigation (over whatever
        ``actions`` holds): the strategy its certificate is proved for."""
        games = [game for game in self._certified if game.basis is Basis.OPEN]
        if games:
            actions[[game.defenders[0] for game in games]] = self._open.headings(
                games, state, self._previous)

    def _play_teams(self, decision: _Decision, actions: np.ndarray) -> None:
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
        team (``policies.intercept.plan_intercepts``: every defender, every active
        attacker); a certified 1 vs 1 game's defender plays it as far as the certificate
        allows (``_steer_certified``); the other certified games keep their optimal
        controls."""
        plan = plan_intercepts(race_all(self._field, state),
                               np.ones(len(actions), dtype=bool), state.active_attackers)
        desired = intercept_headings(plan, state.defender_positions, state.attacker_positions)
        free = np.ones(len(actions), dtype=bool)
        free[[j for game in self._certified for j in game.defenders]] = False
        actions[free] = desired[free]
        self._races = tuple((j, int(plan.targets[j])) for j in np.flatnonzero(free)
                            if plan.targets[j] >= 0)
        self._steer_certified(state, desired, actions)

    def _steer_certified(self, state: GameState, desired: np.ndarray,
                         actions: np.ndarray) -> None:
        """Within each certified 1 vs 1 game, take the heading ``desired`` (unit vectors
        ``(N, 2)``, zero for none: then straight at the attacker) as far as the value
        allows, over the optimal control already in ``actions``: the certificate is the
        filter, the plan proposes.

        Where the value clears the game's margin by more than one step of both players
        can change it (``(v_A + v_D) dt`` map units, taking the value 1-Lipschitz in each
        position), or where the tube's value one step on stays above the margin whatever
        the attacker does (``_held_one_step``: 32 headings and standing still; every other
        move lies within ``v_A dt / 2`` of a sampled one, and the game stays certified
        down to a value of 0, a whole margin below), the desired heading. Where the
        value sits in a thin band above the margin (coarse tubes: a cell is nearly the
        capture radius) its gradient is small and noisy and the cone below flips from
        step to step, so certified games stalled there; the one-step check closes them.
        Else, among the
        headings ``u`` that keep the value from falling whatever the attacker does to
        first order, ``v_D grad_D V . u >= v_A |grad_A V|`` (a cone around the optimal
        control, narrowed by ``CONE_SLACK``), the one nearest the desired heading; the
        optimal control where the cone is empty."""
        games = [game for game in self._certified if game.basis is Basis.TUBE
                 and len(game.defenders) == 1 and len(game.attackers) == 1]
        if not games:  # open-space games are played by _play_open
            return
        i = np.array([game.attackers[0] for game in games])
        j = np.array([game.defenders[0] for game in games])
        attackers, defenders = state.attacker_positions, state.defender_positions
        value, gradient = self.vf11.value_and_gradient(pair_states(attackers, defenders)[i, j])
        axes = [2 * self.vf11.players.index(p) + np.arange(2)
                for p in (self.vf11.attackers[0], self.vf11.defenders[0])]
        grad_a, grad_d = gradient[:, axes[0]], gradient[:, axes[1]]
        size_d = np.hypot(grad_d[:, 0], grad_d[:, 1])
        floor = size_d > HEADING_FLOOR
        cone = np.where(floor, state.attacker_speed * np.hypot(grad_a[:, 0], grad_a[:, 1])
                        / (state.defender_speed * np.maximum(size_d, HEADING_FLOOR)), np.inf)
        cone = cone + CONE_SLACK
        best = grad_d / np.maximum(size_d, HEADING_FLOOR)[:, None]
        aim = np.where(desired[j].any(axis=1)[:, None], desired[j],
                       unit_vectors(attackers[i] - defenders[j]))
        along = np.einsum("kd,kd->k", aim, best)
        across = aim - along[:, None] * best
        width = np.hypot(across[:, 0], across[:, 1])
        across = across / np.maximum(width, 1e-12)[:, None]
        rim = np.minimum(cone, 1.0)  # the cone's edge; used only where cone < 1
        edge = rim[:, None] * best + np.sqrt(1.0 - rim**2)[:, None] * across
        step = (state.attacker_speed + state.defender_speed) * self._dt
        clear = value - self.tubes.margins.m11 > step
        close = ~clear
        if close.any():
            clear[close] = self._held_one_step(state, i[close], j[close], aim[close])
        heading = np.where((clear | (along >= cone))[:, None], aim, edge)
        steer = clear | (cone < 1.0) & (width > 1e-9) | (along >= cone)
        actions[j[steer]] = heading[steer]

    def _held_one_step(self, state: GameState, i: np.ndarray, j: np.ndarray,
                       headings: np.ndarray) -> np.ndarray:
        """Whether the 1 vs 1 value of each game (attackers ``i``, defenders ``j``) stays
        above its margin one step on, with the defender on ``headings`` (unit vectors
        ``(G, 2)``) and the attacker on each of ``ATTACKER_MOVES`` (the worst counts)."""
        moves = ATTACKER_MOVES * (state.attacker_speed * self._dt)
        a = state.attacker_positions[i][:, None, :] + moves[None]
        d = (state.defender_positions[j] + headings * (state.defender_speed * self._dt))
        states = np.concatenate([a, np.broadcast_to(d[:, None, :], a.shape)], axis=-1)
        after = self.vf11.value(states.reshape(-1, 4)).reshape(len(i), -1)
        return after.min(axis=1) > self.tubes.margins.m11

    @functools.cached_property
    def _margins(self) -> np.ndarray:
        """The tubes' certificate margins as ``decision_controls`` takes them."""
        return np.array(self.tubes.margins, dtype=np.float64)

    @functools.cached_property
    def _tube_arrays(self) -> tuple[TubeArrays, TubeArrays | None]:
        """The 1 vs 1 and 2 vs 1 tubes as the batched lookups take them."""
        return TubeArrays.of(self.vf11), None if self.vf21 is None else TubeArrays.of(self.vf21)

    def _tables(self, state: GameState, active: np.ndarray, certified: list[Match],
                wins: np.ndarray, held: np.ndarray | None = None) -> DecisionTables:
        """``decision_tables`` of ``state`` with the ``certified`` games of the last
        decision (the 1 vs 2 values of their teams looked up first), the open-space
        ``wins`` and the certified games it ``held`` (none held by default)."""
        games = match_arrays(tuple(certified))
        if held is None:
            held = np.zeros(len(certified), dtype=bool)
        return decision_tables(state.attacker_positions, state.defender_positions, active,
                               games, self._team_values(state, games), held, wins,
                               *self._tube_arrays)

    def _team_values(self, state: GameState, games: Matches) -> np.ndarray:
        """``(G,)``: the 1 vs 2 value of every team of ``games`` (two defenders), NaN for
        the other games (read-only where there is no team; a policy without a 1 vs 2 tube
        plays none)."""
        if self.vf12 is None:
            return no_team_values(len(games.defenders))
        teams = np.flatnonzero(games.defenders[:, 0] != games.defenders[:, 1])
        if not len(teams):
            return no_team_values(len(games.defenders))
        values = np.full(len(games.defenders), np.nan)
        values[teams] = self.vf12.value(team_states(
            state.attacker_positions, state.defender_positions,
            np.column_stack([games.attackers[teams, 0], games.defenders[teams]])))
        return values

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
        unassigned defenders ``idle`` plays with ``free="assignment"`` (those left out
        stand still); ``values11 (M, N)`` is this step's 1 vs 1 table."""


def open_games(games: list[Match], wins: np.ndarray) -> list[bool]:
    """Whether each of ``games`` is one defender against one attacker that ``wins``
    ``(M, N)`` (``OpenSpace.wins``) says the defender wins."""
    return [len(game.defenders) == len(game.attackers) == 1
            and bool(wins[game.attackers[0], game.defenders[0]]) for game in games]


def check_tube(vf: ValueFunction, scenario: Scenario, name: str) -> None:
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
    """The reference defenders: the paper's iterative capture algorithm (Algorithm 1, HJ
    tubes + the assignment MIP) with its certificate, and the strongest play we know
    where the certificate does not reach.

    Every step: ``I_j`` from the 1 vs 1 tube, ``P_j`` from the 2 vs 1 tube at the current
    positions, the MIP (c1)-(c5) solved to optimality on CP-SAT; a defender with two
    attackers plays the 2 vs 1 optimal control, with one the 1 vs 1 optimal control.
    Certified games are kept (``margin_cells``, see the base class):
    ``guaranteed_captures`` counts them, ``nominal_captures`` is the MIP objective of the
    paper's rule.

    ``idle`` says what the defenders outside the certified games do: ``"intercept"``
    (default) play the team's intercept plan (``policies.intercept``; a certified 1 vs 1
    game's defender too, as far as its certificate allows); ``"shadow"`` plays the
    assignment's games and shadows, with the 1 vs 1 optimal control, the unassigned
    attacker it is best placed against (largest 1 vs 1 value; any attacker if none is
    unassigned); ``"stand"`` plays the assignment's games and stands still unassigned, as
    in the paper's simulations. ``paper`` builds the paper's method exactly (``"stand"``,
    ``margin_cells=0``).
    """

    def __init__(self, vf11: ValueFunction, vf21: ValueFunction | None,
                 idle: str = "intercept", margin_cells: float = CERTIFICATE_CELLS) -> None:
        if idle not in IDLE:
            raise ValueError(f"idle: expected one of {', '.join(IDLE)}, got {idle!r}")
        if vf11.game != "1v1" or (vf21 is not None and vf21.game != "2v1"):
            raise ValueError(f"vf11, vf21: expected a 1v1 and a 2v1 value function, got "
                             f"{vf11.game!r} and {None if vf21 is None else vf21.game!r}")
        super().__init__(vf11, vf21, self._team_tube(), "mip", margin_cells,
                         "intercept" if idle == "intercept" else "assignment")
        self.idle = idle

    def _team_tube(self) -> ValueFunction | None:
        """The 1 vs 2 tube the policy plays teams with (none: the paper's program)."""
        return None

    @classmethod
    def for_scenario(cls, scenario: Scenario, grid1: int = PAPER_GRIDS.grid1,
                     grid2: int = PAPER_GRIDS.grid2, idle: str = "intercept",
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
        return cls.for_scenario(scenario, grid1, grid2, idle="stand", margin_cells=0.0,
                                progress=progress)

    def reset(self, scenario: Scenario) -> None:
        super().reset(scenario)
        if self.vf21 is not None:
            check_tube(self.vf21, scenario, "vf21")
        elif scenario.num_attackers > 1:
            raise ValueError(f"vf21: {scenario.name!r} has {scenario.num_attackers} "
                             f"attackers; these defenders were built without the 2 vs 1 tube")

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
                 idle: str = "intercept", margin_cells: float = CERTIFICATE_CELLS) -> None:
        if vf12.game != "1v2":
            raise ValueError(f"vf12: expected a 1v2 value function, got {vf12.game!r}")
        self._vf12 = vf12
        super().__init__(vf11, vf21, idle, margin_cells)

    def _team_tube(self) -> ValueFunction | None:
        return self._vf12

    @classmethod
    def for_scenario(cls, scenario: Scenario, grid1: int = PAPER_GRIDS.grid1,
                     grid2: int = PAPER_GRIDS.grid2, idle: str = "intercept",
                     margin_cells: float = CERTIFICATE_CELLS,
                     progress: bool = True) -> HJPairsDefenderPolicy:
        """Load (or solve and cache) the scenario's tubes; both 6D games on ``grid2``^6."""
        vf11, vf21 = tube_2v1(scenario, grid1, grid2, progress)
        return cls(vf11, vf21, tube_1v2(scenario, grid1, grid2, progress), idle=idle,
                   margin_cells=margin_cells)

    def reset(self, scenario: Scenario) -> None:
        super().reset(scenario)
        check_tube(self.vf12, scenario, "vf12")

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
        super().__init__(vf11, None, None, "matching", margin_cells, "assignment")
        self.unmatched = unmatched

    @classmethod
    def for_scenario(cls, scenario: Scenario, grid1: int = PAPER_GRIDS.grid1,
                     unmatched: str = "stand", margin_cells: float = CERTIFICATE_CELLS,
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

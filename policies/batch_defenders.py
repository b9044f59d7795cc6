"""The assignment defenders' one engine, on K copies of a game in one call.

``BatchAssignmentDefenders`` is a ``reachavoid_env.BatchPolicy`` that plays a
``policies.strategy.Strategy`` with the tubes it is given (the paper's iterative capture
algorithm and its extensions: the program, the certificate, the spare defenders; the
class docstring); ``policies.assignment_defender.AssignmentDefender`` is it at one copy
(``reachavoid_env.Single``), which ``policies.defenders`` composes into the reference
defenders (``hj``, ``hj-pairs``, ``paper``, ``matching``), and ``BatchHJDefenders`` is
the registry's batched ``hj``.

What reads many points runs over every copy's players at once: the 1 vs 1 lookups and
the open-space certificate of the step's open wins (asked only where read), the
certificate check of the open-space games held, the decision tables before the program
and the controls after it (one numba call each: ``policies.lookups.batch_decision_tables``
/ ``batch_decision_controls``), the attackers' shortest paths, races and the intercept
plan (``policies.steering.play_plan``), the certified defenders' steering and parallel
navigation. What each copy decides alone stays per copy: the kept certified games, the
assignment program (solved on CP-SAT only where its inputs changed: each copy has its
``AssignmentSolver``, whose cache answers an unchanged program), the spare defenders'
attackers and the teams' controls. Every batched computation applies the same arithmetic
to each row alone, so copy ``k`` plays exactly (bit for bit) what it plays alone
(``tests/test_batch_defenders.py`` plays K = 1 against K = n). Index pairs are
``(attacker, defender)`` throughout (``solvers.assignment`` states the order).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from policies.certificate import (
    Basis,
    Match,
    OpenSpace,
    Tubes,
    joined_once,
    kept_games,
    match_arrays,
    open_games,
    roles_of,
)
from policies.defender_copy import Decision, DefenderCopy, StepPlan
from policies.lookups import (
    DecisionTables,
    Matches,
    Ragged,
    TubeArrays,
    batch_decision_controls,
    batch_decision_tables,
)
from policies.steering import PlanGames, Tempo, copy_rows, hedge_pairs, play_plan
from policies.strategy import CERTIFICATE_CELLS, Program, Spare, Strategy, team_table
from policies.tube_states import play_teams, team_values
from policies.tubes import check_tube, tube_1v1, tube_2v1
from reachavoid_env import BatchState, GameState, Overlay, Scenario
from reachavoid_env.game_state import AttackerStatus
from reachavoid_env.geodesic import DistanceField, distance_field
from reachavoid_env.policy import checked_copies
from solvers.hj import PAPER_GRIDS, ValueFunction

ACTIVE = AttackerStatus.ACTIVE.code


class BatchAssignmentDefenders:
    """Defenders that solve an assignment of the tubes' games every step, in each of K
    copies of one game (``strategy`` says which program, which margin, and what the spare
    defenders do; module docstring).

    Each step it reads the 1 vs 1 tube (and the 2 vs 1 tube for the MIP, the 1 vs 2 tube
    with teams) at the current positions (multilinear interpolation), solves the
    assignment, and drives each defender of a game by the optimal control of its game
    (both defenders of a team by the 1 vs 2 controls).

    **The certificate** (``policies.certificate``). The assignment played is the paper's
    (every value > 0 a defender win), except that the games already certified are kept:
    a game becomes certified when its value clears its tube's margin (``margin_cells`` of
    the tube's grid spacing, above the measured tube error) and stays certified, and
    played, while its value is > 0; the rest of the defenders and attackers are assigned
    by the program. ``margin_cells=0`` is the paper's Algorithm 1 exactly: nothing is
    kept. Where defenders are faster, a 1 vs 1 game is also certified by the open-space
    condition (``OpenSpace``), which the program sees as a win, and is then played by
    parallel navigation (``OpenSpace.play``, over whatever the free play wrote).

    **The spare defenders** (``policies.strategy.Spare``). ``INTERCEPT``: the plan
    proposes, the certificate filters (``policies.steering.play_plan``): every defender
    outside the certified games plays the team's intercept plan, but for the defender of
    an uncertified game of the program whom the plan sends after the game's attacker (or
    one of its pair), which keeps the game's optimal control (the defender of an
    uncertified pair keeps its better single game won: ``policies.steering.hedge_pairs``,
    with or without the plan, wherever games are certified); the defender of a
    certified 1 vs 1 game plays the plan as far as the value allows; certified pairs and
    teams keep their optimal controls. The others: every assigned defender plays its
    game's optimal control and the unassigned ones the attacker ``Spare.targets`` gives
    them.

    The copies share one game: the scenarios of ``reset_copies`` must have the map,
    speeds, capture radius, player radius, step and attackers of the copies not reset
    (a reset of every copy may start another game). ``copies[k]`` is copy ``k``'s
    ``DefenderCopy``; ``overlay(k)`` and ``nominal_captures(k)`` tell of it.
    """

    def __init__(self, vf11: ValueFunction, vf21: ValueFunction | None,
                 vf12: ValueFunction | None, strategy: Strategy) -> None:
        for name, vf, game in (("vf11", vf11, "1v1"), ("vf21", vf21, "2v1"),
                               ("vf12", vf12, "1v2")):
            if vf is not None and vf.game != game:
                raise ValueError(f"{name}: expected a {game} value function, got {vf.game!r}")
        self.vf11 = vf11
        self.vf21 = vf21
        self.vf12 = vf12
        self.strategy = strategy
        self.tubes = Tubes.of(vf11, vf21, vf12, strategy.margin_cells)
        self.margins = np.array(self.tubes.margins, dtype=np.float64)
        self._tubes = (TubeArrays.of(vf11), None if vf21 is None else TubeArrays.of(vf21))
        self.copies: list[DefenderCopy | None] = []
        self._game: tuple | None = None
        self._open: OpenSpace | None = None
        self._field: DistanceField | None = None
        self._dt = 0.0

    @property
    def margin_cells(self) -> float:
        """The certificate margin (grid cells of each tube)."""
        return self.strategy.margin_cells

    def margin(self, vf: ValueFunction) -> float:
        """The certificate margin of ``vf``'s game (map units)."""
        return self.margin_cells * float(max(vf.grid.spacing))

    def reset_copies(self, copies: np.ndarray, scenarios: Sequence[Scenario]) -> None:
        copies = checked_copies(copies, scenarios)
        if set(range(len(self.copies))) <= set(copies.tolist()):
            self._game = None   # every copy starts again: the game may change
        for k, scenario in zip(copies.tolist(), scenarios, strict=True):
            self._prepare(scenario)
            self.copies += [None] * (k + 1 - len(self.copies))
            old = self.copies[k]
            if old is None:
                program = self.strategy.program
                self.copies[k] = DefenderCopy(program.solver(), program.solver())
            else:   # the solvers' counts go on from episode to episode
                old.solver.reset()
                old.nominal_solver.reset()
                self.copies[k] = DefenderCopy(old.solver, old.nominal_solver)

    def _prepare(self, scenario: Scenario) -> None:
        """Check ``scenario`` against the tubes and the copies' game (the first scenario
        sets it)."""
        game = (scenario.map, scenario.attacker_speed, scenario.defender_speed,
                scenario.capture_radius, scenario.player_radius, scenario.dt,
                scenario.num_attackers)
        if game == self._game:
            return
        if self._game is not None:
            raise ValueError(f"scenarios: {scenario.name!r} is another game than the copies' "
                             f"(map, speeds, capture radius, player radius, step or attackers)")
        check_tube(self.vf11, scenario, "vf11")
        if self.vf21 is not None:
            check_tube(self.vf21, scenario, "vf21")
        elif self.strategy.program is Program.MIP and scenario.num_attackers > 1:
            raise ValueError(f"vf21: {scenario.name!r} has {scenario.num_attackers} "
                             f"attackers; these defenders were built without the 2 vs 1 tube")
        if self.vf12 is not None:
            check_tube(self.vf12, scenario, "vf12")
        self._game = game
        self._dt = scenario.dt
        self._open = OpenSpace.of(scenario) if self.strategy.certifies else None
        self._field = (distance_field(scenario.map, scenario.player_radius)
                       if self.strategy.plans else None)

    def act_batch(self, states: BatchState) -> np.ndarray:
        """One decision in every copy: the assignment keeping the certified games, the
        optimal controls of its games and the certificate of the new ones, the teams'
        controls, then, with the intercept plan, the plan; last, parallel navigation in
        the open-space games. ``(K, N, 2)`` float32 headings (fractions of the
        defenders' speed)."""
        attackers = np.asarray(states.attacker_positions, dtype=np.float64)
        defenders = np.asarray(states.defender_positions, dtype=np.float64)
        active = np.asarray(states.attacker_status) == ACTIVE
        count, n = attackers.shape[0], defenders.shape[1]
        if len(self.copies) < count or any(c is None for c in self.copies[:count]):
            raise RuntimeError("act_batch: call reset_copies for every copy first")
        actions = np.zeros((count, n, 2), dtype=np.float32)
        live = np.flatnonzero(active.any(axis=1))
        for k in np.flatnonzero(~active.any(axis=1)).tolist():
            self.copies[k].clear()
        if not len(live):
            return actions
        game = _Batch(attackers[live], defenders[live], active[live], states, live,
                      [self.copies[k] for k in live.tolist()])
        for copy in game.copies:
            copy.nominal = None
        wins = _OpenWins.of(self._open, self.vf11, self.margins[0], game)
        out = actions[live]
        held = wins.held(game, self.strategy.certifies)
        decided = self._decide(game, wins, held)
        self._play_games(game, wins, decided, out)
        for c, copy in enumerate(game.copies):
            play_teams(self.vf12, copy.decision.assignment.shared, game.attackers[c],
                       game.defenders[c], out[c])
        if self.strategy.certifies:
            self._hedge_pairs(game, decided[0].values11, out)
        if self.strategy.plans:
            self._play_plan(game, out)
        if self._open is not None:
            self._open.play([copy.certified for copy in game.copies], game.attackers,
                            game.defenders, [copy.previous for copy in game.copies], out)
        for c, copy in enumerate(game.copies):
            copy.previous = game.attackers[c].copy()
        actions[live] = out
        return actions

    def _decide(self, game: _Batch, wins: _OpenWins,
                held: list[np.ndarray]) -> tuple[DecisionTables, list[list[Match]]]:
        """The tables of all copies in one call, then per copy the certified games still
        on and the program's answer with them joined (``DefenderCopy.decision``); returns
        the tables (copy axis first) and each copy's new games (not kept)."""
        n = game.defenders.shape[1]
        certified = [copy.certified if self.strategy.certifies else []
                     for copy in game.copies]
        tables = self._tables(game, certified, held, wins.table)
        offsets = np.cumsum([0] + [len(games) for games in certified]).tolist()
        fresh = []
        for c, copy in enumerate(game.copies):
            lo, hi = offsets[c], offsets[c + 1]
            mine = _copy_tables(tables, c, slice(lo, hi))
            kept = kept_games(certified[c], mine.kept, mine.left, held[c], mine.values11)
            teams = (team_table(self.vf12, game.state(c), mine) if self.vf12 is not None
                     and self.strategy.program is Program.MIP else None)
            assignment = self.strategy.program.solve(copy.solver, mine, teams)
            if kept:
                assignment = joined_once(assignment, tuple(kept), n)
            roles = roles_of(assignment)
            fresh.append([match for match in roles.games if match not in kept])
            copy.certified, copy.singles, copy.doubles = kept, roles.singles, roles.doubles
            copy.decision = Decision(mine, kept, assignment, wins.table[c], game.states,
                                     int(game.index[c]))
        return tables, fresh

    def _tables(self, game: _Batch, certified: list[list[Match]], held: list[np.ndarray],
                wins: np.ndarray) -> DecisionTables:
        """``batch_decision_tables`` of the live copies with each copy's ``certified``
        games of the last decision (the 1 vs 2 values of their teams looked up first),
        those the open-space certificate ``held`` and its ``wins`` ``(L, M, N)``."""
        before = [match_arrays(tuple(games)) for games in certified]
        return batch_decision_tables(
            game.attackers, game.defenders, game.active,
            (Ragged.of([g.defenders for g in before]), Ragged.of([g.attackers for g in before])),
            self._team_values(game, before), np.concatenate(held), wins, *self._tubes)

    def _team_values(self, game: _Batch, games: list[Matches]) -> np.ndarray:
        """The 1 vs 2 values of each copy's ``games`` (``team_values``), ragged as they
        are; NaN without a 1 vs 2 tube (read for teams only)."""
        if self.vf12 is None:
            return np.full(sum(len(g.defenders) for g in games), np.nan)
        return np.concatenate([team_values(self.vf12, game.state(c), g)
                               for c, g in enumerate(games)])

    def _play_games(self, game: _Batch, wins: _OpenWins, decided: tuple[DecisionTables,
                    list[list[Match]]], actions: np.ndarray) -> None:
        """Write the optimal control of every defender alone in a game of each copy's
        assignment (and of every spare one the strategy gives an attacker) into
        ``actions`` ``(L, N, 2)``, all copies in one call; then each copy's new games
        that the certificate takes join its certified ones (with ``margin_cells=0``,
        every game: the paper's rule); a 1 vs 1 game the tube does not certify is an
        open-space game where the open-space certificate says the defender wins it."""
        tables, fresh = decided
        certifies = self.strategy.certifies
        singles = []
        for c, copy in enumerate(game.copies):
            roles = roles_of(copy.decision.assignment)
            mine = copy.singles
            if roles.idle and not self.strategy.plans:
                spare = self.strategy.spare.targets(game.state(c), copy.decision.assignment,
                                                    list(roles.idle),
                                                    copy.decision.tables.values11)
                mine = np.concatenate([mine, np.array(spare, dtype=np.int64).reshape(-1, 2)])
            singles.append(mine)
        if certifies:
            wins.ask(game, _pairs_of(fresh, wins.unasked.shape))
        new = [match_arrays(tuple(games) if certifies else ()) for games in fresh]
        slack = batch_decision_controls(
            game.attackers, game.defenders, Ragged.of(singles),
            Ragged.of([copy.doubles for copy in game.copies]),
            (Ragged.of([g.defenders for g in new]), Ragged.of([g.attackers for g in new])),
            self._team_values(game, new), self.margins, tables.values11,
            tables.values21, *self._tubes, actions)
        lo = 0
        for c, copy in enumerate(game.copies):
            games = fresh[c]
            if certifies:
                on = (slack[lo:lo + len(games)] > 0.0).tolist()
                lo += len(games)
                games = [match if certain else Match(match.defenders, match.attackers,
                                                      Basis.OPEN)
                         for match, certain, open_ in zip(games, on,
                                                          open_games(games, wins.table[c]),
                                                          strict=True)
                         if certain or open_]
            copy.certified = copy.certified + games

    def _hedge_pairs(self, game: _Batch, values11: np.ndarray, actions: np.ndarray) -> None:
        """The defender of every uncertified pair game keeps its better single game won
        (``policies.steering.hedge_pairs``), all copies at once."""
        doubles = copy_rows(game.copies, "doubles")
        if not len(doubles):
            return
        busy = np.zeros(game.defenders.shape[:2], dtype=bool)
        held = [(c, j) for c, copy in enumerate(game.copies) for match in copy.certified
                for j in match.defenders]
        if held:
            busy[tuple(np.array(held).T)] = True
        hedge_pairs(self.vf11, doubles[~busy[doubles[:, 0], doubles[:, 3]]], values11,
                    [copy.hedges for copy in game.copies], game.attackers, game.defenders,
                    sum(game.speeds) * self._dt, actions)

    def _play_plan(self, game: _Batch, actions: np.ndarray) -> None:
        """The team's intercept plan in every live copy at once
        (``policies.steering.play_plan``); each copy's games played are its certified
        games and the program's games whose defender keeps the game's control."""
        plan, copies, keepers = play_plan(
            self._field, game.attackers, game.defenders, game.active,
            [PlanGames(copy.certified, copy.singles, copy.doubles) for copy in game.copies],
            self.vf11, self.margins[0],
            Tempo(game.speeds, game.states.capture_radius, self._dt), actions)
        for c, copy in enumerate(game.copies):
            copy.step_plan = StepPlan(plan, copies, keepers, c)

    def nominal_captures(self, k: int) -> int | None:
        """The paper's count in copy ``k`` at this step: the size of the assignment (the
        MIP objective; the matching size for the baseline) with every value > 0 a
        defender win (``None`` before the first decision). Where games are kept, the
        program with nothing kept is solved on demand (on the copy's second solver, so
        the training copies, which never ask, never pay for it)."""
        copy = self.copies[k] if k < len(self.copies) else None
        decision = None if copy is None else copy.decision
        if decision is None:
            return None
        if not decision.kept:
            return decision.assignment.captures
        if copy.nominal is None:
            state = decision.state
            alone = _Batch(state.attacker_positions[None], state.defender_positions[None],
                           state.active_attackers[None], decision.states,
                           np.array([decision.k]), [copy])
            tables = _copy_tables(self._tables(alone, [[]], [np.zeros(0, dtype=bool)],
                                               decision.wins[None]), 0, slice(0, 0))
            teams = (team_table(self.vf12, state, tables) if self.vf12 is not None
                     and self.strategy.program is Program.MIP else None)
            copy.nominal = self.strategy.program.solve(copy.nominal_solver, tables,
                                                       teams).captures
        return copy.nominal

    def overlay(self, k: int) -> Overlay:
        """Copy ``k``'s games played and races, with its counts (``DefenderCopy.overlay``)."""
        copy = self.copies[k] if k < len(self.copies) else None
        if copy is None:
            return Overlay()
        return copy.overlay(self.strategy.plans, self.nominal_captures(k), self._field)


def _copy_tables(tables: DecisionTables, c: int, games: slice) -> DecisionTables:
    """Copy ``c``'s tables of ``batch_decision_tables`` (its certified games' rows
    ``games`` of ``kept`` and ``left``)."""
    return DecisionTables(tables.values11[c], tables.values21[c], tables.kept[games],
                          tables.left[games], tables.beats[c], tables.beats_2v1[c],
                          tables.active[c], tables.busy[c])


def _pairs_of(games: list[list[Match]], shape: tuple[int, ...]) -> np.ndarray:
    """``(L, M, N)`` bool: the pairs of each copy's 1 vs 1 ``games``."""
    pairs = np.zeros(shape, dtype=bool)
    for c, mine in enumerate(games):
        for match in mine:
            if len(match.defenders) == len(match.attackers) == 1:
                pairs[c, match.attackers[0], match.defenders[0]] = True
    return pairs


@dataclass(frozen=True)
class _OpenWins:
    """A step's open-space wins ``table`` ``(L, M, N)`` as far as asked of the
    certificate ``space`` (``None``: none, all false), and the pairs to be asked (active
    attacker, 1 vs 1 value up to the margin) that are ``unasked`` yet. The certificate
    is row by row, so a pair asked only where it is read gets the same answer as asked
    anywhere; it is read at value <= 0 (the program's table, the held tube games) and
    for the step's new 1 vs 1 games, and an unasked pair (false) is read nowhere else."""

    table: np.ndarray
    unasked: np.ndarray
    space: OpenSpace | None

    @classmethod
    def of(cls, space: OpenSpace | None, vf11: ValueFunction, margin: float,
           game: _Batch) -> _OpenWins:
        """The wins of every live copy, asked at once for every copy's pairs that the
        program's tables read (1 vs 1 value <= 0; a certified tube game's ``held``, read
        only there); the other pairs up to the ``margin`` (map units) are asked when a
        new 1 vs 1 game needs them (``ask``); above it the tube certifies the game."""
        shape = game.active.shape + (game.defenders.shape[1],)
        wins = cls(np.zeros(shape, dtype=bool), np.zeros(shape, dtype=bool), space)
        if space is None:
            return wins
        states = np.empty(shape + (4,))
        states[..., :2] = game.attackers[:, :, None, :]
        states[..., 2:] = game.defenders[:, None, :, :]
        values = vf11.value(states)
        wins.unasked[...] = (values <= margin) & game.active[:, :, None]
        wins.ask(game, values <= 0.0)
        return wins

    def ask(self, game: _Batch, needed: np.ndarray) -> None:
        """Ask the certificate for the pairs of ``needed`` ``(L, M, N)`` that are to be
        asked and not asked yet, all copies at once."""
        asked = needed & self.unasked
        if asked.any():
            self.table[asked] = self.space.wins(game.attackers, game.defenders, asked)[asked]
            self.unasked[asked] = False

    def held(self, game: _Batch, certifies: bool) -> list[np.ndarray]:
        """Each copy's ``OpenSpace.held`` of its certified games, asked once for all
        copies (none held without the certificate)."""
        if self.space is None:
            return [np.zeros(len(copy.certified) if certifies else 0, dtype=bool)
                    for copy in game.copies]
        return self.space.held([copy.certified for copy in game.copies], game.attackers,
                               game.defenders, game.active, self.table)


@dataclass
class _Batch:
    """The live copies of one step (``L`` copies with an attacker in the game):
    positions ``(L, M, 2)`` and ``(L, N, 2)``, ``active`` ``(L, M)``, the step's
    ``states`` and the live copies' ``index`` in them, each copy's ``DefenderCopy``, and
    the copies' ``GameState`` as far as ``made``."""

    attackers: np.ndarray
    defenders: np.ndarray
    active: np.ndarray
    states: BatchState
    index: np.ndarray
    copies: list[DefenderCopy]
    made: dict[int, GameState] = field(default_factory=dict)

    @property
    def speeds(self) -> tuple[float, float]:
        """``(v_A, v_D)``, map units per second."""
        return self.states.attacker_speed, self.states.defender_speed

    def state(self, c: int) -> GameState:
        """Live copy ``c``'s ``GameState`` (made when first asked)."""
        if c not in self.made:
            self.made[c] = self.states.game_state(int(self.index[c]))
        return self.made[c]


class BatchHJDefenders(BatchAssignmentDefenders):
    """The registry's batched ``hj``: ``HJDefenderPolicy(vf11, vf21, margin_cells=...)``
    (``idle="intercept"``) on K copies."""

    def __init__(self, vf11: ValueFunction, vf21: ValueFunction | None,
                 margin_cells: float = CERTIFICATE_CELLS) -> None:
        if vf11.game != "1v1" or (vf21 is not None and vf21.game != "2v1"):
            raise ValueError(f"vf11, vf21: expected a 1v1 and a 2v1 value function, got "
                             f"{vf11.game!r} and {None if vf21 is None else vf21.game!r}")
        super().__init__(vf11, vf21, None, Strategy(Program.MIP, margin_cells,
                                                    Spare.INTERCEPT))

    @classmethod
    def for_scenario(cls, scenario: Scenario, grid1: int = PAPER_GRIDS.grid1,
                     grid2: int = PAPER_GRIDS.grid2, margin_cells: float = CERTIFICATE_CELLS,
                     progress: bool = True) -> BatchHJDefenders:
        """The tubes of ``HJDefenderPolicy.for_scenario`` (loaded, or solved and cached)."""
        if scenario.num_attackers < 2:
            return cls(tube_1v1(scenario, grid1, progress), None, margin_cells)
        return cls(*tube_2v1(scenario, grid1, grid2, progress), margin_cells)

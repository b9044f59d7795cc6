"""The reference defenders acting on K copies of a game in one call.

Each class here is a ``reachavoid_env.BatchPolicy``: ``reset_copies(copies, scenarios)``
and ``act_batch(states) -> (K, N, 2)``, and gives every copy exactly (bit for bit) the
actions its single-game policy gives for that copy's ``GameState``:

- ``BatchHJDefenders``: ``policies.defenders.HJDefenderPolicy`` (``idle="intercept"``, the
  registry's ``hj``). What reads many points runs over every copy's players at once: the
  1 vs 1 lookups and the open-space certificate of the step's open wins (asked, as the
  single policy asks, only where read), the certificate check of the open-space games
  held, the attackers' shortest paths and races (``policies.intercept.race_copies``), the
  intercept plan (``policies.intercept.plan_copies``, one numba call), the certified
  defenders' steering and parallel navigation; the decision tables before the program
  and the controls after it, one numba call each for all copies
  (``policies.lookups.batch_decision_tables`` / ``batch_decision_controls``, each copy
  through the single policy's kernel). What each copy decides alone stays per copy, in
  the single policy's own functions: the kept certified games and the assignment
  program, solved on CP-SAT only where its inputs changed (each copy has its
  ``AssignmentSolver``, whose cache answers an unchanged program). No overlay and no
  ``nominal_captures``: the batch is for training.

Every batched computation applies the single policy's arithmetic to each row alone
(elementwise numpy, per-point lookups, reductions along the same axes), which is what
keeps the copies bit-identical; ``tests/test_batch_defenders.py`` plays both side by side.
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
from policies.lookups import (
    Ragged,
    TubeArrays,
    batch_decision_controls,
    batch_decision_tables,
)
from policies.steering import PlanGames, Tempo, play_plan
from policies.strategy import CERTIFICATE_CELLS, check_margin_cells
from policies.tubes import check_tube, tube_1v1, tube_2v1
from reachavoid_env import BatchState, Scenario
from reachavoid_env.game_state import checked_copies
from reachavoid_env.geodesic import DistanceField, distance_field
from solvers.assignment import AssignmentSolver
from solvers.hj import PAPER_GRIDS, ValueFunction

ACTIVE = 0
"""``AttackerStatus.ACTIVE.code``: the status of an attacker still in the game."""


@dataclass
class _Copy:
    """What one copy's defenders carry from step to step: the program's solver (its
    cache), the certified games of the last decision, the attackers' last positions
    (``None`` before the first decision or after a game without attackers), and the
    step's 1 vs 1 and pair games of the program (``Roles.singles``, ``Roles.doubles``,
    read by the plan)."""

    solver: AssignmentSolver = field(default_factory=lambda: AssignmentSolver("mip"))
    certified: list[Match] = field(default_factory=list)
    previous: np.ndarray | None = None
    singles: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    doubles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.int64))


class BatchHJDefenders:
    """``HJDefenderPolicy(vf11, vf21, idle="intercept", margin_cells=...)`` on K copies of
    one game (module docstring). Every copy plays the tubes' map; the scenarios of
    ``reset_copies`` must share the map, speeds, capture radius, player radius and step.
    """

    def __init__(self, vf11: ValueFunction, vf21: ValueFunction | None,
                 margin_cells: float = CERTIFICATE_CELLS) -> None:
        if vf11.game != "1v1" or (vf21 is not None and vf21.game != "2v1"):
            raise ValueError(f"vf11, vf21: expected a 1v1 and a 2v1 value function, got "
                             f"{vf11.game!r} and {None if vf21 is None else vf21.game!r}")
        self.vf11 = vf11
        self.vf21 = vf21
        self.margin_cells = check_margin_cells(margin_cells)
        self.margins = np.array(Tubes.of(vf11, vf21, None, self.margin_cells).margins,
                                dtype=np.float64)
        self._tubes = (TubeArrays.of(vf11), None if vf21 is None else TubeArrays.of(vf21))
        self._copies: list[_Copy | None] = []
        self._game: tuple | None = None
        self._open: OpenSpace | None = None
        self._field: DistanceField | None = None
        self._dt = 0.0

    @classmethod
    def for_scenario(cls, scenario: Scenario, grid1: int = PAPER_GRIDS.grid1,
                     grid2: int = PAPER_GRIDS.grid2, margin_cells: float = CERTIFICATE_CELLS,
                     progress: bool = True) -> BatchHJDefenders:
        """The tubes of ``HJDefenderPolicy.for_scenario`` (loaded, or solved and cached)."""
        if scenario.num_attackers < 2:
            return cls(tube_1v1(scenario, grid1, progress), None, margin_cells)
        return cls(*tube_2v1(scenario, grid1, grid2, progress), margin_cells)

    @property
    def _certifies(self) -> bool:
        return self.margin_cells > 0.0

    def reset_copies(self, copies: np.ndarray, scenarios: Sequence[Scenario]) -> None:
        copies = checked_copies(copies, scenarios)
        for k, scenario in zip(copies.tolist(), scenarios, strict=True):
            self._prepare(scenario)
            self._copies += [None] * (k + 1 - len(self._copies))
            self._copies[k] = _Copy()

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
        elif scenario.num_attackers > 1:
            raise ValueError(f"vf21: {scenario.name!r} has {scenario.num_attackers} "
                             f"attackers; these defenders were built without the 2 vs 1 tube")
        self._game = game
        self._dt = scenario.dt
        self._open = OpenSpace.of(scenario) if self._certifies else None
        self._field = distance_field(scenario.map, scenario.player_radius)

    def act_batch(self, states: BatchState) -> np.ndarray:
        attackers = np.asarray(states.attacker_positions, dtype=np.float64)
        defenders = np.asarray(states.defender_positions, dtype=np.float64)
        active = np.asarray(states.attacker_status) == ACTIVE
        count, n = attackers.shape[0], defenders.shape[1]
        if len(self._copies) < count or any(c is None for c in self._copies[:count]):
            raise RuntimeError("act_batch: call reset_copies for every copy first")
        actions = np.zeros((count, n, 2), dtype=np.float32)
        live = np.flatnonzero(active.any(axis=1))
        for k in np.flatnonzero(~active.any(axis=1)).tolist():
            self._copies[k].certified, self._copies[k].previous = [], None
        if not len(live):
            return actions
        game = _Batch(attackers[live], defenders[live], active[live], states.attacker_speed,
                      states.defender_speed, states.capture_radius,
                      [self._copies[k] for k in live.tolist()])
        wins = self._open_wins(game)
        held = self._held(game, wins)
        out = actions[live]
        self._decide_and_play(game, wins, held, out)
        self._play_plan(game, out)
        self._play_open(game, out)
        for c, copy in enumerate(game.copies):
            copy.previous = game.attackers[c].copy()
        actions[live] = out
        return actions

    def _open_wins(self, game: _Batch) -> _OpenWins:
        """``HJDefenderPolicy``'s open-space wins of every live copy, asked at once for
        every copy's pairs that the program's tables read (1 vs 1 value <= 0); its other
        pairs (value up to the margin) are asked when a game needs them (``_ask``)."""
        shape = game.active.shape + (game.defenders.shape[1],)
        wins = _OpenWins(np.zeros(shape, dtype=bool), np.zeros(shape, dtype=bool))
        if self._open is None:
            return wins
        states = np.empty(shape + (4,))
        states[..., :2] = game.attackers[:, :, None, :]
        states[..., 2:] = game.defenders[:, None, :, :]
        values = self.vf11.value(states)
        wins.unasked[...] = (values <= self.margins[0]) & game.active[:, :, None]
        self._ask(game, wins, values <= 0.0)
        return wins

    def _ask(self, game: _Batch, wins: _OpenWins, needed: np.ndarray) -> None:
        """Ask the open-space certificate for the pairs of ``needed`` ``(L, M, N)`` that
        ``HJDefenderPolicy`` asks and that are not asked yet, all copies at once."""
        asked = needed & wins.unasked
        if asked.any():
            wins.table[asked] = self._open.wins(game.attackers, game.defenders, asked)[asked]
            wins.unasked[asked] = False

    def _ask_games(self, game: _Batch, wins: _OpenWins, rows: list[tuple[int, ...]]) -> None:
        """``_ask`` for the pairs ``rows``, each ``(copy, attacker, defender)``."""
        if rows and self._open is not None:
            needed = np.zeros_like(wins.unasked)
            needed[tuple(np.array(rows).T)] = True
            self._ask(game, wins, needed)

    def _held(self, game: _Batch, wins: _OpenWins) -> list[np.ndarray]:
        """Each copy's ``OpenSpace.held`` of its certified games, asked once for all
        copies. A tube game's entry (``wins`` at its pair) is read only where its 1 vs 1
        value is <= 0 (``decision_tables`` keeps it while the value is > 0;
        ``kept_games`` reads it at value <= 0), where it is asked."""
        if self._open is None:
            return [np.zeros(len(copy.certified) if self._certifies else 0, dtype=bool)
                    for copy in game.copies]
        return self._open.held([copy.certified for copy in game.copies], game.attackers,
                               game.defenders, game.active, wins.table)

    def _decide_and_play(self, game: _Batch, wins: _OpenWins, held: list[np.ndarray],
                         actions: np.ndarray) -> None:
        """As ``AssignmentDefender._decide`` and ``_play_games`` in every copy: the
        tables of all copies in one call, then per copy the kept games and the program
        (its solver's cache first), then every copy's optimal controls into ``actions``
        (``(L, N, 2)``) and new games' slacks in one call, and each copy's new certified
        games."""
        n = game.defenders.shape[1]
        certified = [copy.certified if self._certifies else [] for copy in game.copies]
        before = [match_arrays(tuple(games)) for games in certified]
        tables = batch_decision_tables(
            game.attackers, game.defenders, game.active,
            (Ragged.of([g.defenders for g in before]), Ragged.of([g.attackers for g in before])),
            np.full(sum(len(g) for g in certified), np.nan), np.concatenate(held), wins.table,
            *self._tubes)
        offsets = np.cumsum([0] + [len(games) for games in certified]).tolist()
        fresh, singles, doubles = [], [], []
        for c, copy in enumerate(game.copies):
            lo, hi = offsets[c], offsets[c + 1]
            kept = kept_games(certified[c], tables.kept[lo:hi], tables.left[lo:hi], held[c],
                              tables.values11[c])
            assignment = copy.solver.solve(tables.beats[c], tables.beats_2v1[c],
                                           tables.active[c])
            if kept:
                assignment = joined_once(assignment, tuple(kept), n)
            roles = roles_of(assignment)
            fresh.append([match for match in roles.games if match not in kept])
            singles.append(roles.singles)
            doubles.append(roles.doubles)
            copy.certified, copy.singles, copy.doubles = kept, roles.singles, roles.doubles
        self._ask_games(game, wins, [(c, m.attackers[0], m.defenders[0])
                                     for c, games in enumerate(fresh) for m in games
                                     if len(m.defenders) == len(m.attackers) == 1])
        new = [match_arrays(tuple(games) if self._certifies else ()) for games in fresh]
        slack = batch_decision_controls(
            game.attackers, game.defenders, Ragged.of(singles), Ragged.of(doubles),
            (Ragged.of([g.defenders for g in new]), Ragged.of([g.attackers for g in new])),
            np.full(sum(len(g.defenders) for g in new), np.nan), self.margins,
            tables.values11, tables.values21, *self._tubes, actions)
        lo = 0
        for c, copy in enumerate(game.copies):
            games = fresh[c]
            if self._certifies:
                on = (slack[lo:lo + len(games)] > 0.0).tolist()
                lo += len(games)
                games = [match if certain else Match(match.defenders, match.attackers,
                                                      Basis.OPEN)
                         for match, certain, open_ in zip(games, on,
                                                          open_games(games, wins.table[c]),
                                                          strict=True)
                         if certain or open_]
            copy.certified = copy.certified + games

    def _play_plan(self, game: _Batch, actions: np.ndarray) -> None:
        """``AssignmentDefender._play_plan`` of every live copy at once
        (``policies.steering.play_plan``)."""
        play_plan(self._field, game.attackers, game.defenders, game.active,
                  [PlanGames(copy.certified, copy.singles, copy.doubles)
                   for copy in game.copies], self.vf11, self.margins[0],
                  Tempo((game.attacker_speed, game.defender_speed), game.capture_radius,
                        self._dt), actions)

    def _play_open(self, game: _Batch, actions: np.ndarray) -> None:
        """``AssignmentDefender._play_open`` of every copy's open-space games at once."""
        if self._open is not None:
            self._open.play([copy.certified for copy in game.copies], game.attackers,
                            game.defenders, [copy.previous for copy in game.copies], actions)


@dataclass(frozen=True)
class _OpenWins:
    """A step's open-space wins ``table`` ``(L, M, N)`` as far as asked, and the pairs
    ``HJDefenderPolicy`` asks (active attacker, 1 vs 1 value up to the margin) that are
    ``unasked`` yet. The certificate is row by row, so a pair asked only where it is
    read gets the single policy's answer; it is read at value <= 0 (the program's
    table, the held tube games) and for the step's new 1 vs 1 games (``_ask_games``),
    and an unasked pair (false) is read nowhere else."""

    table: np.ndarray
    unasked: np.ndarray


@dataclass(frozen=True)
class _Batch:
    """The live copies of one step (``L`` copies with an attacker in the game):
    positions ``(L, M, 2)`` and ``(L, N, 2)``, ``active`` ``(L, M)``, the speeds and
    capture radius, and each copy's ``_Copy``."""

    attackers: np.ndarray
    defenders: np.ndarray
    active: np.ndarray
    attacker_speed: float
    defender_speed: float
    capture_radius: float
    copies: list[_Copy]

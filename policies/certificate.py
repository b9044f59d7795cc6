"""The certificate of the assignment defenders: which assigned games are guaranteed wins.

A tube's value is a numerical solution: near the decision boundary its sign can be wrong
(tube error), and along a played trajectory it drifts. A game of the assignment becomes
*certified* when its value clears the tube's margin (``margin`` per tube, above the
measured error), and stays certified while its value is > 0 (hysteresis: a game taken
with a clear margin is not given up for drifting into the band). The defenders keep
every certified game (their players are taken out of the next program and ``joined``
puts the game back), so the certified count falls only when a game's value reaches 0.
The check and the restriction run inside the batched lookups
(``policies.lookups.batch_decision_tables``; their step-by-step numpy twins are in
``tests/lookups_reference.py``); ``match_arrays`` and ``kept_games`` carry the games there
and back.

A game's value is what the program reads (``policies.lookups.match_value``, the rule's one
home): ``V11`` for one defender against one attacker; the smallest of ``V21`` and both
``V11`` for one defender against a pair (constraints c4 and c5); ``V12`` for a team of two
defenders against one attacker.

**Open space** (``OpenSpace``, where ``vD > vA``). Beside the tube, a 1 vs 1 game is won
where the grid-free condition of ``solvers.open_space.defender_certifies`` holds (the
Apollonius disc misses the target, the parallel-navigation region misses obstacles and
walls); such a game is played by ``solvers.open_space.parallel_navigation``, the
strategy that proves it, so the promise and the play agree. Each game records what
certifies it (``Match.basis``): a game the tube certifies stays a tube game; one only the
open-space condition certifies is an open-space game. The program sees these wins too:
where the condition says defender ``j`` wins attacker ``i`` alone, the 1 vs 1 table counts
a defender win whatever the tube says (``policies.lookups.batch_decision_tables`` ``wins``), so
the program may assign that single game and the certificate takes it. A team needs no
rule of its own: the program forms a team only against an attacker that beats both
defenders alone, so where either member wins alone the program plays that member's single
game instead.
"""

from __future__ import annotations

import enum
import functools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from policies.lookups import Matches
from reachavoid_env import GameMap, Scenario
from solvers import open_space
from solvers.assignment import Assignment
from solvers.hj import ValueFunction


class Basis(enum.Enum):
    """What certifies a game, and so what plays it."""

    TUBE = "tube"
    """Its tube value (played by the tube's controls)."""
    OPEN = "open"
    """The open-space condition (``OpenSpace``; played by parallel navigation)."""


@dataclass(frozen=True)
class Match:
    """One assigned game (a match, named apart from ``solvers.hj``'s HJ games):
    ``defenders`` (one, or a team ``j < k``) against ``attackers``
    (one, or a pair ``i < k`` taken by one defender), as indices; ``basis``, what
    certifies it (of a certified game), is no part of which game it is (equality and hash
    ignore it)."""

    defenders: tuple[int, ...]
    attackers: tuple[int, ...]
    basis: Basis = field(default=Basis.TUBE, compare=False)


def games_of(assignment: Assignment) -> list[Match]:
    """The games of ``assignment``: every defender's own attackers, then every team."""
    alone = [Match((j,), mine) for j, mine in enumerate(assignment.by_defender) if mine]
    return alone + [Match((j, k), (i,)) for i, j, k in assignment.shared]


class Margins(NamedTuple):
    """The margin each tube's value must clear to certify a game (map units)."""

    m11: float
    m21: float
    m12: float


@dataclass(frozen=True)
class Tubes:
    """The tubes a game's value is read from (``vf21`` / ``vf12`` ``None`` where the policy
    plays no such game) and the margin each must clear (map units)."""

    vf11: ValueFunction
    vf21: ValueFunction | None
    vf12: ValueFunction | None
    margins: Margins

    @classmethod
    def of(cls, vf11: ValueFunction, vf21: ValueFunction | None, vf12: ValueFunction | None,
           margin_cells: float) -> Tubes:
        """The tubes with their margins: ``margin_cells`` of each tube's largest grid
        spacing (0 for a missing tube)."""
        return cls(vf11, vf21, vf12, Margins(*(
            0.0 if vf is None else margin_cells * float(max(vf.grid.spacing))
            for vf in (vf11, vf21, vf12))))


class Roles(NamedTuple):
    """What each defender of an assignment plays: int64 rows ``singles (S, 2)``
    ``(attacker, defender)`` alone against one, ``doubles (D, 3)`` ``(first, second,
    defender)`` against two; the ``idle`` defenders (in no game); and its ``games``
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
            doubles.append((*mine, j))
        elif len(mine) == 1:
            singles.append((mine[0], j))
        else:
            idle.append(j)
    return Roles(np.array(singles, dtype=np.int64).reshape(-1, 2),
                 np.array(doubles, dtype=np.int64).reshape(-1, 3), tuple(idle),
                 tuple(games_of(assignment)))


@functools.cache
def no_team_values(games: int) -> np.ndarray:
    """The team values (``policies.lookups.batch_decision_tables``) of ``games`` certified
    games none of which is a team: read for none (read-only)."""
    values = np.full(games, np.nan)
    values.setflags(write=False)
    return values


@functools.lru_cache(maxsize=1024)
def match_arrays(games: tuple[Match, ...]) -> Matches:
    """``games`` as the batched lookups take them (``policies.lookups.Matches``: each game's
    first and last player per side; made once per distinct list, read-only)."""
    defenders = np.array([(game.defenders[0], game.defenders[-1]) for game in games],
                         dtype=np.int64).reshape(-1, 2)
    attackers = np.array([(game.attackers[0], game.attackers[-1]) for game in games],
                         dtype=np.int64).reshape(-1, 2)
    defenders.setflags(write=False)
    attackers.setflags(write=False)
    return Matches(defenders, attackers)


def kept_games(certified: list[Match], kept: np.ndarray, left: np.ndarray,
               held: np.ndarray, values11: np.ndarray) -> list[Match]:
    """The ``certified`` games still on (``kept`` and ``left`` from
    ``policies.lookups.batch_decision_tables``), without the attackers that left, each with
    what keeps it: an open-space game stays one while ``held`` (``OpenSpace.held``),
    else its tube value kept it; a tube game stays one while its value ``values11``
    ``(M, N)`` is > 0, else ``held`` kept it (games of more than two players are held by
    their tube alone)."""
    games = []
    for game, on, present, open_ in zip(certified, kept.tolist(), left.tolist(),
                                        held.tolist(), strict=True):
        if not on:
            continue
        attackers = tuple(i for i, stays in zip(game.attackers, present, strict=False)
                          if stays)
        if game.basis is Basis.OPEN:
            basis = Basis.OPEN if open_ else Basis.TUBE
        else:
            basis = Basis.OPEN if open_ and values11[attackers[0], game.defenders[0]] <= 0.0 \
                else Basis.TUBE
        games.append(game if attackers == game.attackers and basis is game.basis
                     else Match(game.defenders, attackers, basis))
    return games


OPEN_CERTIFY_STEPS = 3.0
"""The open-space margin (``solvers.open_space.defender_certifies``' ``margin``) a game is
certified with, in attacker steps ``vA dt`` (map units: 0.015 on the paper scenarios).

Why a margin, and why this one. In continuous time parallel navigation keeps both
players in the first Apollonius disc and the disc only shrinks. The env plays in steps
of ``dt`` and the defender reads the attacker's velocity from its last step (pure
pursuit on the first), so where the attacker turns the line of sight turns by up to
``2 vA dt`` over the players' distance, and the disc of the new positions may stick out
of the first one. Measured (``tests/test_open_space.py``
``test_the_disc_drifts_less_than_half_a_step``: discrete parallel navigation at
``vA = 1``, ``vD = 1.5``, ``dt = 0.005`` against random, zigzag and a greedy attacker
choosing each step the heading that pushes the next disc farthest out): the disc never
stuck out of the first by more than 0.41 ``vA dt``. The keep margin (``OPEN_KEEP_STEPS``) must stay
at least one step ``vA dt`` (the attacker starts each step inside the disc of that
step's positions; a disc farther than one attacker step from the target leaves no
arrival within the step) and the certify margin above it by more than the drift: 3 and
1.5 steps leave 1.5 steps (3.6 times the measured drift) between them."""

OPEN_KEEP_STEPS = 1.5
"""The open-space margin (attacker steps ``vA dt``) a certified open-space game is kept
with (``OPEN_CERTIFY_STEPS`` says why)."""


@dataclass(frozen=True)
class OpenSpace:
    """The open-space 1 vs 1 certificate of one scenario (module docstring): its map,
    speeds ``(vA, vD)``, the clearance the players keep from obstacles and walls (the
    players' radius: the physics world stops a player's centre that far from them), the
    margins a game is certified and kept with (map units) and the step ``dt``."""

    game_map: GameMap
    speeds: tuple[float, float]
    clearance: float
    certify: float
    keep: float
    dt: float

    @classmethod
    def of(cls, scenario: Scenario) -> OpenSpace | None:
        """The certificate of ``scenario`` (``None`` where defenders are not faster: no
        Apollonius disc)."""
        va, vd = scenario.attacker_speed, scenario.defender_speed
        if not vd > va:
            return None
        step = va * scenario.dt
        return cls(scenario.map, (va, vd), scenario.player_radius, OPEN_CERTIFY_STEPS * step,
                   OPEN_KEEP_STEPS * step, scenario.dt)

    def wins(self, attackers: np.ndarray, defenders: np.ndarray,
             asked: np.ndarray) -> np.ndarray:
        """Whether defender ``j`` wins alone against attacker ``i`` by the open-space
        condition at the certify margin, in each of L copies.

        Args:
            attackers: ``(L, M, 2)`` positions (map units), copies first.
            defenders: ``(L, N, 2)`` positions (map units).
            asked: ``(L, M, N)`` bool, the pairs to check (the caller leaves out the
                attackers out of the game).

        Returns:
            ``(L, M, N)`` bool, false where not asked.
        """
        wins = np.zeros(asked.shape, dtype=bool)
        c, i, j = np.nonzero(asked)
        if c.size:
            wins[c, i, j] = open_space.defender_certifies(
                self.game_map, attackers[c, i], defenders[c, j], self.speeds, self.certify,
                self.clearance)
        return wins

    def held(self, certified: Sequence[Sequence[Match]], attackers: np.ndarray,
             defenders: np.ndarray, active: np.ndarray, wins: np.ndarray) -> list[np.ndarray]:
        """Which of each copy's ``certified`` games of one defender against one active
        attacker the open-space condition holds: an open-space game at the keep margin
        (checked for all copies at once), a tube game at the certify margin (``wins``
        ``(L, M, N)``, this step's table). Positions as ``wins``, ``active`` ``(L, M)``;
        one bool array ``(G_c,)`` per copy."""
        held = [np.zeros(len(games), dtype=bool) for games in certified]
        opened = []
        for c, games in enumerate(certified):
            for g, game in enumerate(games):
                left = [i for i in game.attackers if active[c, i]]
                if len(game.defenders) != 1 or len(left) != 1:
                    continue
                if game.basis is Basis.OPEN:
                    opened.append((c, g, left[0], game.defenders[0]))
                else:
                    held[c][g] = wins[c, left[0], game.defenders[0]]
        if opened:
            c, g, i, j = np.array(opened).T
            keep = open_space.defender_certifies(
                self.game_map, attackers[c, i], defenders[c, j], self.speeds, self.keep,
                self.clearance)
            for row, (copy, game) in enumerate(zip(c.tolist(), g.tolist(), strict=True)):
                held[copy][game] = keep[row]
        return held

    def play(self, certified: Sequence[Sequence[Match]], attackers: np.ndarray,
             defenders: np.ndarray, previous: Sequence[np.ndarray | None],
             actions: np.ndarray) -> None:
        """Every defender of each copy's open-space games (``Basis.OPEN`` among its
        ``certified``) plays parallel navigation into ``actions`` ``(L, N, 2)`` (over
        whatever it holds), each attacker's velocity that of its last step (from the
        copy's ``previous`` positions ``(M, 2)``; none: zero, pure pursuit). Positions
        as ``wins``."""
        rows = [(c, game.attackers[0], game.defenders[0])
                for c, games in enumerate(certified) for game in games
                if game.basis is Basis.OPEN]
        if not rows:
            return
        c, i, j = (np.array(column) for column in zip(*rows, strict=True))
        moving = attackers[c, i]
        velocities = np.zeros_like(moving)
        for row, copy in enumerate(c.tolist()):
            if previous[copy] is not None:
                velocities[row] = (moving[row] - previous[copy][i[row]]) / self.dt
        actions[c, j] = open_space.parallel_navigation(moving, defenders[c, j], velocities,
                                                       self.speeds[1])


def joined(rest: Assignment, fixed: list[Match], num_defenders: int) -> Assignment:
    """``rest`` (an answer of the restricted program) with the ``fixed`` games put back."""
    pairs = list(rest.pairs) + [(i, game.defenders[0]) for game in fixed
                                if len(game.defenders) == 1 for i in game.attackers]
    teams = list(rest.shared) + [(game.attackers[0], *game.defenders) for game in fixed
                                 if len(game.defenders) == 2]
    return Assignment.from_pairs(pairs, num_defenders, teams)


@functools.lru_cache(maxsize=1024)
def joined_once(rest: Assignment, kept: tuple[Match, ...], num_defenders: int) -> Assignment:
    """``joined``, made once per distinct answer and kept games."""
    return joined(rest, list(kept), num_defenders)


def open_games(games: list[Match], wins: np.ndarray) -> list[bool]:
    """Whether each of ``games`` is one defender against one attacker that ``wins``
    ``(M, N)`` (``OpenSpace.wins``) says the defender wins."""
    return [len(game.defenders) == len(game.attackers) == 1
            and bool(wins[game.attackers[0], game.defenders[0]]) for game in games]

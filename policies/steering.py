"""Where the intercept plan's headings reach into the games (the plan proposes, the
games filter): how far a certified 1 vs 1 game's defender may take the heading the plan
proposes (``steer``), which defenders of the program's uncertified games keep the
game's optimal control instead (``game_keepers``), and the plan played by the defenders
of K copies with both rules (``play_plan``); and how the defender of an uncertified pair
game keeps one of its two captures (``hedge_pairs``).

Each is the one rule, over the games of K copies at once in
``policies.batch_defenders`` (one game being one copy).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from policies.certificate import Basis, Match
from policies.intercept import Plan, headings, plan_copies, race_copies
from policies.lookups import HEADING_FLOOR
from policies.tube_states import control_headings
from reachavoid_env.geodesic import DistanceField
from reachavoid_env.rules import unit_vectors
from solvers.hj import ValueFunction

if TYPE_CHECKING:
    from policies.defender_copy import DefenderCopy

CONE_SLACK = 0.05
"""Added to the cosine a certified defender's heading keeps with its optimal control
(``steer``), beyond what holds the value to first order."""

HEDGE_STEPS = 2.0
"""The 1 vs 1 value (in steps of both players' motion, ``(v_A + v_D) dt`` map units) below
which an uncertified pair game's defender plays its better single game instead of the
pair (``hedge_pairs``)."""

_ANGLES = np.linspace(0.0, 2.0 * np.pi, 32, endpoint=False)
ATTACKER_MOVES = np.concatenate([np.stack([np.cos(_ANGLES), np.sin(_ANGLES)], axis=1),
                                 np.zeros((1, 2))])
"""The attacker's moves the one-step check of a certified game tries (``held_one_step``):
32 headings at full speed, and standing still."""


def steer(vf11: ValueFunction, attackers: np.ndarray, defenders: np.ndarray,
          wanted: np.ndarray, margin: float, speeds: tuple[float, float],
          dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Within each certified 1 vs 1 tube game, the heading ``wanted`` as far as the value
    allows.

    Where the value clears the game's margin by more than one step of both players can
    change it (``(v_A + v_D) dt`` map units, taking the value 1-Lipschitz in each
    position), or where the tube's value one step on stays above the margin whatever the
    attacker does (``held_one_step``: 32 headings and standing still; every other move
    lies within ``v_A dt / 2`` of a sampled one, and the game stays certified down to a
    value of 0, a whole margin below), the wanted heading. Where the value sits in a thin
    band above the margin (coarse tubes: a cell is nearly the capture radius) its
    gradient is small and noisy and the cone below flips from step to step, so certified
    games stalled there; the one-step check closes them. Else, among the headings ``u``
    that keep the value from falling whatever the attacker does to first order,
    ``v_D grad_D V . u >= v_A |grad_A V|`` (a cone around the optimal control, narrowed by
    ``CONE_SLACK``), the one nearest the wanted heading; the optimal control (left as it
    is) where the cone is empty.

    Args:
        vf11: the 1 vs 1 tube.
        attackers: ``(G, 2)`` each game's attacker (map units).
        defenders: ``(G, 2)`` each game's defender.
        wanted: ``(G, 2)`` unit headings the plan proposes; a zero row: straight at the
            attacker.
        margin: the 1 vs 1 certificate margin (map units).
        speeds: ``(v_A, v_D)``, map units per second.
        dt: the step (seconds).

    Returns:
        ``(steered, headings)``: which games take a new heading ``(G,)`` and the headings
        ``(G, 2)`` (read where ``steered``).
    """
    attacker_speed, defender_speed = speeds
    value, gradient = vf11.value_and_gradient(np.concatenate([attackers, defenders], axis=1))
    axes = [2 * vf11.players.index(p) + np.arange(2)
            for p in (vf11.attackers[0], vf11.defenders[0])]
    grad_a, grad_d = gradient[:, axes[0]], gradient[:, axes[1]]
    size_d = np.hypot(grad_d[:, 0], grad_d[:, 1])
    floor = size_d > HEADING_FLOOR
    cone = np.where(floor, attacker_speed * np.hypot(grad_a[:, 0], grad_a[:, 1])
                    / (defender_speed * np.maximum(size_d, HEADING_FLOOR)), np.inf)
    cone = cone + CONE_SLACK
    best = grad_d / np.maximum(size_d, HEADING_FLOOR)[:, None]
    aim = np.where(wanted.any(axis=1)[:, None], wanted, unit_vectors(attackers - defenders))
    along = np.einsum("kd,kd->k", aim, best)
    across = aim - along[:, None] * best
    width = np.hypot(across[:, 0], across[:, 1])
    across = across / np.maximum(width, 1e-12)[:, None]
    rim = np.minimum(cone, 1.0)  # the cone's edge; used only where cone < 1
    edge = rim[:, None] * best + np.sqrt(1.0 - rim**2)[:, None] * across
    step = (attacker_speed + defender_speed) * dt
    clear = value - margin > step
    close = ~clear
    if close.any():
        clear[close] = held_one_step(vf11, attackers[close], defenders[close], aim[close],
                                     margin, speeds, dt)
    heading = np.where((clear | (along >= cone))[:, None], aim, edge)
    return clear | (cone < 1.0) & (width > 1e-9) | (along >= cone), heading


def held_one_step(vf11: ValueFunction, attackers: np.ndarray, defenders: np.ndarray,
                  headings: np.ndarray, margin: float, speeds: tuple[float, float],
                  dt: float) -> np.ndarray:
    """Whether the 1 vs 1 value of each game (``attackers``, ``defenders`` ``(G, 2)``)
    stays above ``margin`` one step on, with the defender on ``headings`` (unit vectors
    ``(G, 2)``) and the attacker on each of ``ATTACKER_MOVES`` (the worst counts)."""
    attacker_speed, defender_speed = speeds
    moves = ATTACKER_MOVES * (attacker_speed * dt)
    a = attackers[:, None, :] + moves[None]
    d = defenders + headings * (defender_speed * dt)
    states = np.concatenate([a, np.broadcast_to(d[:, None, :], a.shape)], axis=-1)
    after = vf11.value(states.reshape(-1, 4)).reshape(len(attackers), -1)
    return after.min(axis=1) > margin


def game_keepers(singles: np.ndarray, doubles: np.ndarray, targets: np.ndarray,
                 busy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The defenders of the program's games that play the game's optimal control (1 vs 1
    or 2 vs 1) rather than the plan's heading, in L copies at once.

    A game the program plays (every value of it > 0) but the tube does not certify has a
    value within the tube's error of 0. The plan races its attacker as if it kept to its
    shortest path; an attacker that does not (a pair that splits, a lone attacker that
    feints) beats the race: the game's value falls below 0 within a second or two and
    the game is lost (``docs/defenders.md``, "Why hj lost to attackers that split"). So
    the defender of such a game keeps the game's optimal control while the plan sends it
    after the game's attacker (or one of its pair): the plan and the game then agree on
    whom to chase, and the game knows how. Where the plan sends it after another
    attacker, the team's plan rules (in 6 vs 2 that is what captures more).

    Args:
        singles: ``(S, 3)`` int rows ``(copy, attacker, defender)`` of the program's 1 vs
            1 games (``policies.certificate.Roles.singles`` of each copy).
        doubles: ``(D, 4)`` int rows ``(copy, first, second, defender)`` of its pair
            games (``Roles.doubles``).
        targets: ``(L, N)`` the attacker the plan sends each defender after (-1 for none).
        busy: ``(L, N)`` bool, the defenders of certified games (they play those).

    Returns:
        ``(copies, defenders)``: int arrays, one entry per defender that keeps its game's
        optimal control (singles' first, then pairs').
    """
    copy, single = singles[:, 0], singles[:, 2]
    keeps_single = (targets[copy, single] == singles[:, 1]) & ~busy[copy, single]
    pair_copy, pair = doubles[:, 0], doubles[:, 3]
    chased = targets[pair_copy, pair]
    keeps_pair = (((chased == doubles[:, 1]) | (chased == doubles[:, 2]))
                  & ~busy[pair_copy, pair])
    return (np.concatenate([copy[keeps_single], pair_copy[keeps_pair]]),
            np.concatenate([single[keeps_single], pair[keeps_pair]]))


def hedge_pairs(vf11: ValueFunction, doubles: np.ndarray, values11: np.ndarray,
                hedges: Sequence[dict[int, int]], attackers: np.ndarray,
                defenders: np.ndarray, step: float, actions: np.ndarray) -> None:
    """The defender of each uncertified pair game keeps its better single game won: it
    plays the pair's 2 vs 1 control while that single's 1 vs 1 value stays above
    ``HEDGE_STEPS`` steps, else the single's 1 vs 1 optimal control.

    A pair game that the 2 vs 1 tube does not certify has a value within the tube's
    error of 0, and the 2 vs 1 game counts only both captures: where it is really lost,
    its control is indifferent to catching one. A pair that waits on two sides of the
    target and then runs in together meets a defender whose 2 vs 1 control flips between
    them from step to step, and both arrive (``docs/defenders.md``, "Why hj lost both of a
    pair"). So the defender keeps the better of its two 1 vs 1 games above a floor of
    two steps of value (a value of 0 is the 1 vs 1 game's boundary). Which single is
    the better one is sticky (``hedges``): the one of the last step stays while its value
    is within one step of the other's, so two close values do not make the defender
    flip between the singles instead.

    Args:
        vf11: the 1 vs 1 tube.
        doubles: ``(D, 4)`` int rows ``(copy, first, second, defender)`` of the pair
            games no certificate holds.
        values11: ``(L, M, N)`` the step's 1 vs 1 values, copies first.
        hedges: each copy's single of the last step, defender -> attacker (updated).
        attackers: ``(L, M, 2)`` positions (map units).
        defenders: ``(L, N, 2)`` positions (map units).
        step: ``(v_A + v_D) dt``, map units.
        actions: ``(L, N, 2)`` float32 headings holding the pairs' 2 vs 1 controls,
            written in place.
    """
    if not len(doubles):
        return
    c, first, second, j = doubles.T
    v_first, v_second = values11[c, first, j], values11[c, second, j]
    before = np.array([hedges[copy].get(d, -1) for copy, d in zip(c.tolist(), j.tolist(),
                                                                     strict=True)])
    stays = (((before == first) & (v_first >= v_second - step))
             | ((before == second) & (v_second >= v_first - step)))
    single = np.where(stays, before, np.where(v_first >= v_second, first, second))
    for copy, d, i in zip(c.tolist(), j.tolist(), single.tolist(), strict=True):
        hedges[copy][d] = i
    low = values11[c, single, j] <= HEDGE_STEPS * step
    if low.any():
        c, i, j = c[low], single[low], j[low]
        gaps = attackers[c, i] - defenders[c, j]
        states = np.concatenate([attackers[c, i], defenders[c, j]], axis=1)
        actions[c, j] = control_headings(vf11.control(states, "D"), gaps)


class PlanGames(NamedTuple):
    """One copy's games as the plan meets them: the ``certified`` games of the step and
    the program's 1 vs 1 and pair games (``Roles.singles`` ``(S, 2)``, ``Roles.doubles``
    ``(D, 3)``)."""

    certified: Sequence[Match]
    singles: np.ndarray
    doubles: np.ndarray


class Tempo(NamedTuple):
    """The game's pace: ``speeds`` ``(v_A, v_D)`` map units per second, the
    ``capture_radius`` (map units) and the step ``dt`` (seconds)."""

    speeds: tuple[float, float]
    capture_radius: float
    dt: float


def play_plan(field: DistanceField, attackers: np.ndarray, defenders: np.ndarray,
              active: np.ndarray, games: Sequence[PlanGames], vf11: ValueFunction,
              margin: float, tempo: Tempo,
              actions: np.ndarray) -> tuple[Plan, np.ndarray, np.ndarray]:
    """The team's intercept plan in each of L copies, played: every defender outside a
    certified game takes the plan's heading, but for the ``game_keepers``; a certified
    1 vs 1 tube game's defender takes it as far as ``steer`` allows; the other certified
    games keep the controls ``actions`` holds.

    Args:
        field: the map's geodesic distance field.
        attackers: ``(L, M, 2)`` positions (map units), copies first.
        defenders: ``(L, N, 2)`` positions (map units).
        active: ``(L, M)`` bool, the attackers in the game (the plan's open attackers).
        games: each copy's ``PlanGames``.
        vf11: the 1 vs 1 tube.
        margin: its certificate margin (map units).
        tempo: speeds, capture radius and step.
        actions: ``(L, N, 2)`` float32 headings, written in place.

    Returns:
        The ``Plan`` (``targets (L, N)``, ``aims (L, N, 2)``) and the keepers as
        ``game_keepers`` gives them: ``(copies, defenders)``.
    """
    plan = plan_copies(race_copies(field, attackers, defenders, active, *tempo.speeds,
                                   tempo.capture_radius),
                       np.ones(defenders.shape[:2], dtype=bool), active)
    desired = headings(plan, defenders, attackers)
    free = np.ones(actions.shape[:2], dtype=bool)
    held = [(c, j) for c, copy in enumerate(games) for match in copy.certified
            for j in match.defenders]
    if held:
        free[tuple(np.array(held).T)] = False
    copies, keepers = game_keepers(copy_rows(games, "singles"), copy_rows(games, "doubles"),
                                   plan.targets, ~free)
    free[copies, keepers] = False
    actions[free] = desired[free]
    rows = [(c, match.attackers[0], match.defenders[0])
            for c, copy in enumerate(games) for match in copy.certified
            if match.basis is Basis.TUBE and len(match.defenders) == 1
            and len(match.attackers) == 1]
    if rows:
        c, i, j = (np.array(column) for column in zip(*rows, strict=True))
        steered, heading = steer(vf11, attackers[c, i], defenders[c, j], desired[c, j],
                                 margin, tempo.speeds, tempo.dt)
        actions[c[steered], j[steered]] = heading[steered]
    return plan, copies, keepers


def copy_rows(games: Sequence[PlanGames | DefenderCopy], name: str) -> np.ndarray:
    """Every copy's ``singles`` or ``doubles`` rows (``Roles``' arrays, as ``PlanGames``
    and ``DefenderCopy`` hold them), each led by its copy's index."""
    rows = [getattr(copy, name) for copy in games]
    if len(rows) == 1:   # a game played alone: no stacking
        return np.concatenate([np.zeros((len(rows[0]), 1), dtype=np.int64), rows[0]], axis=1)
    counts = np.fromiter(map(len, rows), dtype=np.int64, count=len(rows))
    stacked = np.empty((int(counts.sum()), 3 if name == "singles" else 4), dtype=np.int64)
    stacked[:, 0] = np.repeat(np.arange(len(rows)), counts)
    if len(stacked):
        stacked[:, 1:] = np.concatenate(rows)
    return stacked

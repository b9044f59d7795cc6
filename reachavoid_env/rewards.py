"""The one home of the game's rewards: every env, the vector env and the training views
compute their rewards with these functions (design.md section 1).

- ``outcomes``: +1 an attacker arrived, -1 it was captured, 0 otherwise (the sparse
  reward, the default of every version);
- ``zero_sum``: the attackers' rewards and, for every defender, minus their sum (the team
  game is zero-sum);
- ``progress``: v0 / v1's ``shaping`` term, ``weight * (d_before - d_after)`` of the signed
  distance to the target, per physics step (undiscounted);
- ``GeodesicPotential`` and ``potential_shaping``: v2's ``reward="shaped"``, potential-based
  shaping ``F = gamma Phi(s') - Phi(s)`` (Ng, Harada and Russell 1999) with ``Phi`` minus
  the geodesic time to the target around the obstacles;
- ``timeout``: the training views' ``timeout_reward`` for a learner still in play at the
  time limit;
- ``team_bonus``: the training views' ``team_reward``, a share of the teammates' outcomes.

Functions work on arrays of any leading shape (one game ``(M,)``, ``K`` copies ``(K, M)``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from reachavoid_env.game_map import GameMap

REWARDS = ("sparse", "shaped")
"""v2's ``reward`` options: the outcome alone, or the outcome plus potential shaping."""


def outcomes(arrived: np.ndarray, captured: np.ndarray) -> np.ndarray:
    """The attackers' outcome rewards of one step.

    Args:
        arrived: ``(..., M)`` bool, the attacker arrived within the step.
        captured: ``(..., M)`` bool, the attacker was captured within the step.

    Returns:
        ``(..., M)`` float64: +1 arrived, -1 captured, 0 otherwise.
    """
    return arrived.astype(np.float64) - captured


def zero_sum(attackers: np.ndarray, defenders: int) -> np.ndarray:
    """Every player's reward from the attackers' (the defenders get minus their sum).

    Args:
        attackers: ``(..., M)`` the attackers' rewards of one step.
        defenders: ``N``, the number of defenders.

    Returns:
        ``(..., M + N)``: the attackers' rewards, then ``N`` times minus their sum.
    """
    team = -attackers.sum(axis=-1, keepdims=True)
    return np.concatenate([attackers, np.broadcast_to(team, (*team.shape[:-1], defenders))],
                          axis=-1)


def progress(before: np.ndarray, after: np.ndarray, started: np.ndarray,
             weight: float) -> np.ndarray:
    """v0 / v1's ``shaping`` term of one physics step.

    Args:
        before: ``(..., M)`` each attacker's signed distance to the target (map units)
            before the step.
        after: ``(..., M)`` the same after the step.
        started: ``(..., M)`` bool, the attacker was in play at the start of the step.
        weight: the env's ``shaping``.

    Returns:
        ``(..., M)``: ``weight * (before - after)`` for the attackers that started the step
        in play, 0 for the others (it sums to ``weight * (d_start - d_end)`` over an
        episode).
    """
    return weight * np.where(started, before - after, 0.0)


def timeout(truncated: np.ndarray | bool, reward: float) -> np.ndarray | float:
    """The ``timeout_reward`` of the training views.

    Args:
        truncated: the learner(s) still in play when the episode was truncated.
        reward: the views' ``timeout_reward``.

    Returns:
        ``reward`` where ``truncated``, 0 elsewhere (same shape as ``truncated``).
    """
    return reward * truncated


def team_bonus(outcomes: np.ndarray, live: np.ndarray, weight: float) -> np.ndarray:
    """The ``team_reward`` term of the attacker training views.

    Args:
        outcomes: ``(..., L)`` each learning attacker's outcome in one env step: +1 it
            arrived, -1 it was captured, 0 otherwise.
        live: ``(..., L)`` bool, the learner was in play at the start of the step.
        weight: the views' ``team_reward``.

    Returns:
        ``(..., L)``: ``weight`` times the sum of the *other* learners' outcomes, for the
        learners in play (0 for the others): a share of its teammates' arrivals and
        captures, so that a learner gains by helping a teammate through.
    """
    others = outcomes.sum(axis=-1, keepdims=True) - outcomes
    return np.where(live, weight * others, 0.0)


class GeodesicPotential:
    """``Phi``, the potential of v2's shaped reward, on one map.

    ``Phi = -T / v`` for an attacker in play, ``T`` the geodesic (around-obstacle)
    distance from it to the target (``geodesic.distance_field`` with the player radius
    as clearance, map units; negative inside the target) and ``v`` the attackers' speed:
    minus the time the attacker needs to reach the target. An attacker out of the game
    (captured or arrived) is in an absorbing state whose potential is **0**, as Ng, Harada
    and Russell require of terminal states, so the shaping never changes which policies are
    optimal (the shaping of an episode telescopes, ``potential_shaping``).

    Args:
        game_map: the map.
        clearance: how far paths keep from obstacles and walls (the player radius).
        speed: the attackers' speed (map units per second).
    """

    def __init__(self, game_map: GameMap, clearance: float, speed: float) -> None:
        from reachavoid_env.geodesic import distance_field  # scikit-fmm: only when shaped

        self.field = distance_field(game_map, clearance)
        self.speed = speed

    def __call__(self, positions: np.ndarray, active: np.ndarray) -> np.ndarray:
        """``Phi`` of every attacker.

        Args:
            positions: ``(..., M, 2)`` the attackers' positions (map units).
            active: ``(..., M)`` bool, the attacker is in play.

        Returns:
            ``(..., M)`` float64: ``-T / v`` in play, 0 out of the game.
        """
        return np.where(active, -self.field.distance(positions) / self.speed, 0.0)


def potential_shaping(before: np.ndarray, after: np.ndarray, gamma: float) -> np.ndarray:
    """The potential-based shaping of one decision, ``F = gamma Phi(s') - Phi(s)``.

    Over an episode of ``n`` decisions the discounted shaping telescopes:
    ``sum_t gamma^t F_t = gamma^n Phi(s_n) - Phi(s_0)`` (``Phi(s_n) = 0`` for an attacker
    that left), a term no policy can change, so the optimal policies of the shaped game are
    those of the sparse one.

    Args:
        before: ``(..., M)`` ``Phi`` at the start of the decision.
        after: ``(..., M)`` ``Phi`` at its end.
        gamma: the learner's discount factor per decision.

    Returns:
        ``(..., M)`` the attackers' shaping terms.
    """
    return gamma * after - before

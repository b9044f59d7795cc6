"""The HJ games' target and avoid sets say what the rulebook (reachavoid_env/rules.py) says.

The kernels evaluate the games' expressions in their own fast form; ``test_hj_kernels``
checks them against ``Problem.sets`` (the numpy evaluation), and this file checks
``Problem.sets`` against the rules, node by node, on the paper map. A capture radius that
no node distance equals keeps the inclusive/exclusive boundary out of the comparison, and
nodes on the domain's edge are left out: the solver's free-space distance measures the
domain grown by half a cell (``solvers/hj/geometry.py``), so that a player sliding along
a wall is not read as being in an obstacle.
"""

from __future__ import annotations

import numpy as np

from reachavoid_env import builtin_map
from reachavoid_env.rules import within_capture
from solvers.hj.games import game_1v1
from solvers.hj.grid import Grid
from solvers.hj.marcher import map_problem

RADIUS = 0.1234
GAME_MAP = builtin_map("paper")


def nodes_1v1(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Attacker and defender positions ``(K, 2)`` of every interior node of an ``n^4`` grid,
    and the flat indices of those nodes."""
    grid = Grid.for_players(GAME_MAP.domain, 2, n)
    mesh = grid.mesh().reshape(-1, 4)
    inside = np.all(np.abs(mesh) < 1.0 - 1e-9, axis=1)
    return mesh[inside, :2], mesh[inside, 2:], np.flatnonzero(inside)


def test_1v1_sets_follow_the_rules():
    n = 17
    attackers, defenders, index = nodes_1v1(n)
    grid = Grid.for_players(GAME_MAP.domain, 2, n)
    target, avoid = (s.reshape(-1)[index] for s in map_problem(game_1v1((1.0, 1.5), RADIUS),
                                                                GAME_MAP, grid).sets())
    captured = np.array([within_capture(a[None], d[None], RADIUS)[0, 0]
                         for a, d in zip(attackers, defenders, strict=True)])
    attacker_blocked = GAME_MAP.in_obstacle(attackers)
    defender_blocked = GAME_MAP.in_obstacle(defenders)
    arrived = GAME_MAP.in_target(attackers) & ~captured
    # avoid (g > 0): the attacker is captured or in an obstacle
    np.testing.assert_array_equal(avoid > 0, captured | attacker_blocked)
    # target (l <= 0): the attacker arrives uncaptured, or the defender is in an obstacle
    np.testing.assert_array_equal(target <= 0, arrived | defender_blocked)
    assert captured.any() and arrived.any() and attacker_blocked.any()

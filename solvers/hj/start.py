"""A tighter start for the solve: the cold start clipped where the attackers can reach the target.

The solve marches the monotone update ``T(V) = max(min(V + dt H(V), l), g)`` from a start
above the largest fixed point ``V*`` (``reach_avoid``). In the defender-win region the
cold start ``max(l, g)`` (up to the map's size) has to settle down to about the capture
radius; this module bounds ``V*`` from above by a constant ``C`` on a set ``S`` of nodes
and starts from ``min(start, C)`` there. It saves the iterations that settling takes where it
decides when the solve stops (the stopping rule looks at the nodes next to the zero level
set only; BENCHMARKS.md, "Clipped start").

**The sets.** For every attacker ``k`` on its planar grid: ``F_k``, the free nodes
(``free >= 0``); ``T_k``, the nodes of ``F_k`` in the target (``target <= 0``); ``K_k``,
the nodes of ``F_k`` joined to ``T_k`` by a path of 4-neighbours inside ``F_k`` (a flood
fill from ``T_k``). ``S`` is the set of grid nodes at which every attacker is at a node of
its ``K_k`` (whatever the defenders' nodes), ``E`` the nodes of ``S`` at which some
attacker is at a node of its ``T_k``. The level is ``C = max(max_S g, max_E max(l, g))``;
in the paper's games ``C`` is the capture radius ``R`` (``g <= R`` while the attackers are
free, ``l <= R`` once one is in the target).

**Claim.** With the Godunov scheme (``schemes.GODUNOV``) every fixed point ``V`` of ``T``
satisfies ``V <= C`` on ``S``. *Proof* (exact arithmetic). Let ``M`` be the largest value
of ``V`` on ``S``, taken at a node ``x``, and suppose ``M > C``. As ``M > C >= g(x)``, the
fixed-point equation gives ``M = min(M + dt H(x), l(x))``, so ``H(x) >= 0``. The
Hamiltonian is a sum of player terms: a defender's term is
``v sqrt(sum max(u[i+1] - u[i], u[i-1] - u[i], 0)^2) / h`` over its axes, and every node a
defender's step reaches has the same attackers' nodes, so it lies in ``S`` and holds a
value ``<= M``: the term is 0. An attacker's term is ``-v sqrt(sum max(u[i] - u[i+1],
u[i] - u[i-1], 0)^2) / h <= 0``, and < 0 as soon as one of its neighbours holds less
than ``M``. Hence ``H(x) >= 0`` forces every attacker's neighbours to hold at least ``M``;
those in ``S`` hold exactly ``M``. Take attacker 1's path inside ``K_1`` from its node at
``x`` to ``T_1`` and move it along the path, the other players fixed: every node on the
way lies in ``S`` and, by the same argument node after node, holds ``M``. The last one
lies in ``E``, where ``V <= max(l, g) <= C < M`` (every fixed point lies below
``max(l, g)``): a contradiction. The boundary's ghost neighbours (zero gradient) are the
node itself and change nothing; exchange symmetry stores one ordering of a symmetric
fixed point, and ``S``, ``E`` are symmetric.

**Consequence.** The start ``V0 = min(start, C)`` on ``S`` (unchanged elsewhere) lies
above the largest fixed point wherever ``start`` does (the cold start ``max(l, g)``
always), and below the cold start; the update is monotone under the CFL bound, so the
iterates from ``V0`` are squeezed between ``V*`` and the cold iterates and reach the
cold solve's fixed point. ``V0`` is also a supersolution (``T(V0) <= V0``: at a node of
``S`` holding ``C`` the defenders' terms vanish as above), so the iterates only fall.
The solve checks that after its first iteration (``StartBound.holds``: no node of ``S``
above ``C``; elsewhere ``T(V) <= max(l, g)`` always) and starts again unclipped if not.
In float32 a difference too small to move ``V + dt H`` does not move it, so the two
solves' values agree to the tolerance at which they stop, not bit for bit.

The Lax-Friedrichs and ENO2 pieces do not have the one-sided structure the proof uses
(a neighbour outside ``S`` can make a central difference or a second difference push a
maximum up), so the bound is applied with the Godunov scheme only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numba import njit, prange

from reachavoid_env.game_map import flood_fill
from reachavoid_env.jit_cache import check_numba_config
from solvers.hj.schemes import GODUNOV

if TYPE_CHECKING:
    from solvers.hj.layout import Layout
    from solvers.hj.marcher import Marcher, Problem

check_numba_config()   # numba loads pickled code: only from a folder of ours

_HUGE = np.float32(1e30)


def reachable_nodes(free: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Free nodes (``free >= 0``) joined to a free target node (``target <= 0``) by a
    path of 4-neighbours through free nodes: a flood fill on a planar grid.

    Args:
        free: ``(nx, ny)`` signed distance to obstacles and the domain's exterior (map units).
        target: ``(nx, ny)`` signed distance to the target (map units, negative inside).

    Returns:
        ``(nx, ny)`` bool.
    """
    return flood_fill(np.asarray(free) >= 0, np.asarray(target) <= 0)


@dataclass(frozen=True)
class NodeSets:
    """``S`` and ``E`` (module docstring) over the stored rows: a node ``(row, element)``
    is in ``S`` when ``row_inside[row] and element_inside[element]``, in ``E`` when it is
    in ``S`` and ``row_arrived[row] or element_arrived[element]``; all bool."""

    row_inside: np.ndarray
    element_inside: np.ndarray
    row_arrived: np.ndarray
    element_arrived: np.ndarray


def node_sets(problem: Problem, layout: Layout) -> NodeSets | None:
    """``S`` and ``E`` of ``problem`` on ``layout``, or ``None`` when ``E`` is empty."""
    game = problem.game
    last = len(game.players) - 1
    rows = layout.stored_rows
    m = layout.row_length
    row_inside, row_arrived = np.ones(rows, dtype=bool), np.zeros(rows, dtype=bool)
    element_inside, element_arrived = np.ones(m, dtype=bool), np.zeros(m, dtype=bool)
    for k, player in enumerate(game.players):
        if player.role != "attacker":
            continue
        target = problem.planar["target"][player.name]
        reachable = reachable_nodes(problem.planar["free"][player.name], target)
        arrived = (reachable & (target <= 0)).reshape(-1)
        reachable = reachable.reshape(-1)
        if k == last:
            element_inside &= reachable
            element_arrived |= arrived
        else:
            nodes = layout.row_nodes[:, k]
            row_inside &= reachable[nodes]
            row_arrived |= arrived[nodes]
    sets = NodeSets(row_inside, element_inside, row_arrived, element_arrived)
    empty = not (row_inside.any() and element_inside.any()
                 and (row_arrived[row_inside].any() or element_arrived[element_inside].any()))
    return None if empty else sets


@njit(cache=True, parallel=True)
def largest_where(values, row_inside, element_inside, row_arrived, element_arrived):
    """The largest of ``values`` ``(rows, m)`` over the nodes ``(i, r)`` with
    ``row_inside[i] and element_inside[r] and (row_arrived[i] or element_arrived[r])``;
    ``-inf`` if there are none (float64)."""
    rows, m = values.shape
    best = np.full(rows, -np.inf)
    for i in prange(rows):
        if row_inside[i]:
            row = values[i]
            top = -np.inf
            for r in range(m):
                if element_inside[r] and (row_arrived[i] or element_arrived[r]):
                    top = max(top, np.float64(row[r]))
            best[i] = top
    return best.max()


@njit(cache=True, parallel=True)
def clip_where(values, row_inside, element_inside, level):
    """``values[i, r] = min(values[i, r], level)`` where ``row_inside[i] and
    element_inside[r]``, in place."""
    rows, m = values.shape
    for i in prange(rows):
        if row_inside[i]:
            row = values[i]
            for r in range(m):
                if element_inside[r]:
                    row[r] = min(row[r], level)


@dataclass(frozen=True)
class StartBound:
    """``V* <= level`` on the nodes of ``sets`` (module docstring); ``level`` in map units."""

    sets: NodeSets
    level: np.float32

    @classmethod
    def of(cls, marcher: Marcher, scratch: np.ndarray) -> StartBound | None:
        """The bound of ``marcher``'s problem, or ``None`` where the module's claim does not
        apply (another scheme than Godunov, no attacker node in the target). ``scratch``
        (the stored value shape, float32) is overwritten: two projections compute ``g``
        and ``max(l, g)`` in it."""
        if marcher.settings.scheme != GODUNOV:
            return None
        sets = node_sets(marcher.problem, marcher.layout)
        if sets is None:
            return None
        everywhere = np.ones_like(sets.row_inside)
        scratch.fill(-_HUGE)
        marcher.project(scratch)  # max(min(-inf, l), g) = g
        avoid = largest_where(scratch, sets.row_inside, sets.element_inside, everywhere,
                              everywhere)
        scratch.fill(_HUGE)
        marcher.project(scratch)  # max(l, g)
        arrived = largest_where(scratch, sets.row_inside, sets.element_inside,
                                sets.row_arrived, sets.element_arrived)
        return cls(sets, np.float32(max(avoid, arrived)))

    def clip(self, values: np.ndarray) -> None:
        """``values = min(values, level)`` on ``S``, in place (``max(l, g)`` stays a
        projection's fixed point: ``g <= level`` on ``S``)."""
        clip_where(values, self.sets.row_inside, self.sets.element_inside, self.level)

    def holds(self, values: np.ndarray) -> bool:
        """Whether no node of ``S`` holds more than ``level`` (after the first iteration: the
        start was a supersolution)."""
        everywhere = np.ones_like(self.sets.row_inside)
        top = largest_where(values, self.sets.row_inside, self.sets.element_inside,
                            everywhere, everywhere)
        return bool(top <= self.level)

"""Assigning attackers to defenders: the paper's MIP on CP-SAT and the matching baseline.

Both work on plain boolean tables built from the solved HJ games (section III-C/D of the
paper); indices are attacker ``i`` in ``0..M-1`` and defender ``j`` in ``0..N-1``:

- ``beats_1v1[i, j]``: attacker ``i`` beats defender ``j`` in the 1 vs 1 game, i.e.
  ``i`` is in the paper's set ``I_j``;
- ``beats_2v1[k, l, j]``: attackers ``k`` and ``l`` together beat defender ``j`` in the
  2 vs 1 game, i.e. ``(k, l)`` is in ``P_j``. A pair counts as winning when either order
  says so; the diagonal is ignored.

``solve_assignment`` is the paper's program (c1)-(c5): each defender takes at most two
attackers, each attacker at most one defender, never an attacker that beats it alone nor
a pair that beats it together; maximise the number of assignments, which is the number
of captures the defenders can guarantee. ``max_matching`` is the baseline of Chen, Zhou
and Tomlin (2014): each defender takes at most one attacker that it beats alone.

Ties between optimal answers are broken by an optional integer ``preference`` table,
strictly below the number of assignments (lexicographic), and otherwise by the
deterministic single-worker solver.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from ortools.graph.python import min_cost_flow
from ortools.sat.python import cp_model


@dataclass(frozen=True)
class Assignment:
    """Which defender chases which attackers.

    ``pairs``: ``(attacker, defender)`` index pairs, sorted. ``by_defender[j]``: the
    attackers assigned to defender ``j``, sorted (at most two for the MIP, one for the
    matching). ``captures``: the optimal objective, the number of assigned attackers.
    ``status``: the solver's status name (always ``"OPTIMAL"``).
    """

    pairs: tuple[tuple[int, int], ...]
    by_defender: tuple[tuple[int, ...], ...]
    captures: int
    status: str

    @classmethod
    def from_pairs(cls, pairs: list[tuple[int, int]], num_defenders: int,
                   status: str = "OPTIMAL") -> Assignment:
        ordered = tuple(sorted(pairs))
        by_defender = tuple(tuple(i for i, d in ordered if d == j) for j in range(num_defenders))
        return cls(ordered, by_defender, len(ordered), status)

    def defender_of(self, attacker: int) -> int | None:
        """The defender assigned to ``attacker``, or ``None``."""
        for i, j in self.pairs:
            if i == attacker:
                return j
        return None


class _Model(cp_model.CpModel):
    """A ``CpModel`` without the camelCase aliases OR-Tools attaches to every new model.

    Attaching them walks ``dir(model)`` and costs about 0.4 ms per model, more than
    solving a typical instance here; this module uses the snake_case names only.
    """

    def _add_pre_pep8_methods(self) -> None:
        pass


def _check_inputs(beats_1v1: np.ndarray, beats_2v1: np.ndarray | None,
                  active: np.ndarray | None,
                  preference: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None,
                                                          np.ndarray, np.ndarray | None]:
    one = np.asarray(beats_1v1)
    if one.ndim != 2 or one.dtype != np.bool_:
        raise ValueError(f"beats_1v1: expected a bool array (M, N), got {one.dtype} {one.shape}")
    m, n = one.shape
    two = None
    if beats_2v1 is not None:
        two = np.asarray(beats_2v1)
        if two.shape != (m, m, n) or two.dtype != np.bool_:
            raise ValueError(f"beats_2v1: expected a bool array {(m, m, n)}, got "
                             f"{two.dtype} {two.shape}")
        two = two | two.transpose(1, 0, 2)
    mask = np.ones(m, dtype=bool) if active is None else np.asarray(active)
    if mask.shape != (m,) or mask.dtype != np.bool_:
        raise ValueError(f"active: expected a bool array ({m},), got {mask.dtype} {mask.shape}")
    pref = None
    if preference is not None:
        pref = np.asarray(preference)
        if pref.shape != (m, n) or not np.issubdtype(pref.dtype, np.integer):
            raise ValueError(f"preference: expected an integer array {(m, n)}, got "
                             f"{pref.dtype} {pref.shape}")
        if np.any(pref < 0):
            raise ValueError("preference: entries must be >= 0")
    return one, two, mask, pref


def _objective_weight(candidates: np.ndarray, pref: np.ndarray | None) -> int:
    """Weight of one assignment so that no preference total can outweigh it.

    Each attacker is assigned at most once, so any preference total is at most the sum
    over attackers of their largest candidate preference; one more than that makes the
    number of assignments the strictly dominant term.
    """
    if pref is None:
        return 1
    best = np.where(candidates, pref, 0).max(axis=1, initial=0)
    return int(best.sum()) + 1


def solve_assignment(beats_1v1: np.ndarray, beats_2v1: np.ndarray,
                     active: np.ndarray | None = None,
                     preference: np.ndarray | None = None) -> Assignment:
    """The paper's MIP (c1)-(c5), solved to optimality with CP-SAT.

    ``beats_1v1``: bool ``(M, N)``; ``beats_2v1``: bool ``(M, M, N)``; ``active``: bool
    ``(M,)``, attackers still in the game (default all). ``preference``: optional
    non-negative integer ``(M, N)``; among assignments with the most captures, one with
    the largest total preference is returned (it never lowers the number of captures).
    """
    one, two, mask, pref = _check_inputs(beats_1v1, beats_2v1, active, preference)
    assert two is not None
    m, n = one.shape
    candidates = ~one & mask[:, None]  # (c4) and inactive attackers: no variable at all
    if not candidates.any():
        return Assignment.from_pairs([], n)

    model = _Model()
    e = {(int(i), int(j)): model.new_bool_var(f"e_{i}_{j}") for i, j in np.argwhere(candidates)}
    for j in range(n):
        takers = np.nonzero(candidates[:, j])[0]
        if len(takers) > 2:
            model.add(cp_model.LinearExpr.sum([e[i, j] for i in takers]) <= 2)  # (c2)
        forbidden = np.triu(two[np.ix_(takers, takers, [j])][:, :, 0], k=1)
        for a, b in np.argwhere(forbidden):
            model.add_at_most_one(e[takers[a], j], e[takers[b], j])  # (c5)
    for i in np.nonzero(candidates.sum(axis=1) > 1)[0]:
        model.add_at_most_one([e[i, j] for j in np.nonzero(candidates[i])[0]])  # (c3)

    weight = _objective_weight(candidates, pref)
    terms = list(e.values())
    coefficients = [weight + (0 if pref is None else int(pref[i, j])) for i, j in e]
    model.maximize(cp_model.LinearExpr.weighted_sum(terms, coefficients))

    solver = cp_model.CpSolver()
    solver.parameters.num_workers = 1
    solver.parameters.random_seed = 0
    solver.parameters.cp_model_presolve = False  # faster on these tiny models, still exact
    status = solver.solve(model)
    if status != cp_model.OPTIMAL:
        raise RuntimeError(f"assignment MIP: CP-SAT ended with {solver.status_name(status)}")
    pairs = [(int(i), int(j)) for (i, j), var in e.items() if solver.boolean_value(var)]
    return Assignment.from_pairs(pairs, n, solver.status_name(status))


def max_matching(beats_1v1: np.ndarray, active: np.ndarray | None = None,
                 preference: np.ndarray | None = None) -> Assignment:
    """Maximum bipartite matching of defenders to attackers they beat 1 vs 1 (baseline).

    Edge ``(i, j)`` when ``not beats_1v1[i, j]`` and attacker ``i`` is active. Solved as
    a max flow with min cost (OR-Tools ``SimpleMinCostFlow``); ``preference`` as in
    ``solve_assignment`` breaks ties between maximum matchings.
    """
    one, _, mask, pref = _check_inputs(beats_1v1, None, active, preference)
    m, n = one.shape
    candidates = ~one & mask[:, None]
    if not candidates.any():
        return Assignment.from_pairs([], n)
    source, sink = m + n, m + n + 1  # attackers are nodes 0..m-1, defenders m..m+n-1
    top = 0 if pref is None else int(np.where(candidates, pref, 0).max())
    flow = min_cost_flow.SimpleMinCostFlow()
    edges = [(int(i), int(j)) for i, j in np.argwhere(candidates)]
    arcs = [flow.add_arc_with_capacity_and_unit_cost(
        i, m + j, 1, 0 if pref is None else top - int(pref[i, j])) for i, j in edges]
    for i in np.nonzero(candidates.any(axis=1))[0]:
        flow.add_arc_with_capacity_and_unit_cost(source, int(i), 1, 0)
    for j in np.nonzero(candidates.any(axis=0))[0]:
        flow.add_arc_with_capacity_and_unit_cost(m + int(j), sink, 1, 0)
    flow.set_node_supply(source, min(m, n))
    flow.set_node_supply(sink, -min(m, n))
    status = flow.solve_max_flow_with_min_cost()
    if status != flow.OPTIMAL:
        raise RuntimeError(f"matching: min cost flow ended with status {status}")
    pairs = [edge for edge, arc in zip(edges, arcs, strict=True) if flow.flow(arc) > 0]
    return Assignment.from_pairs(pairs, n)


class AssignmentSolver:
    """Solves the MIP (or the matching) step after step, reusing unchanged answers.

    The sets ``I_j`` and ``P_j`` change rarely between time steps, so ``solve`` returns
    the previous ``Assignment`` object when its inputs are equal to the last ones. With
    ``keep_previous`` (default) ties between optimal answers are broken towards the pairs
    of the previous answer, so the assignment does not flip between equally good ones.
    ``solves`` and ``reuses`` count what happened.
    """

    def __init__(self, method: str = "mip", keep_previous: bool = True) -> None:
        if method not in ("mip", "matching"):
            raise ValueError(f"method: expected 'mip' or 'matching', got {method!r}")
        self.method = method
        self.keep_previous = keep_previous
        self.solves = 0
        self.reuses = 0
        self._key: tuple[bytes, ...] | None = None
        self._last: Assignment | None = None

    def reset(self) -> None:
        """Forget the previous answer (start of an episode)."""
        self._key = None
        self._last = None

    def solve(self, beats_1v1: np.ndarray, beats_2v1: np.ndarray | None = None,
              active: np.ndarray | None = None) -> Assignment:
        """The optimal assignment for these tables (``beats_2v1`` unused by ``matching``)."""
        if self.method == "mip" and beats_2v1 is None:
            raise ValueError("beats_2v1: required by the 'mip' method")
        one, two, mask, _ = _check_inputs(beats_1v1, beats_2v1 if self.method == "mip" else None,
                                          active, None)
        # The answer depends only on what the program reads: which (attacker, defender)
        # pairs are candidates, and, for the MIP, which pairs of one defender's candidates
        # beat it together. Keying on those alone skips re-solves when only irrelevant
        # entries flip (an attacker that already beats a defender, an inactive one).
        candidates = ~one & mask[:, None]
        parts = [candidates]
        if two is not None:
            parts.append(two & candidates[:, None, :] & candidates[None, :, :])
        key = tuple(p.tobytes() + repr(p.shape).encode() for p in parts)
        if self._last is not None and key == self._key:
            self.reuses += 1
            return self._last
        preference = None
        if self.keep_previous and self._last is not None \
                and len(self._last.by_defender) == one.shape[1]:
            preference = np.zeros(one.shape, dtype=np.int64)
            for i, j in self._last.pairs:
                if i < one.shape[0]:
                    preference[i, j] = 1
        if beats_2v1 is not None and self.method == "mip":
            result = solve_assignment(one, beats_2v1, mask, preference)
        else:
            result = max_matching(one, mask, preference)
        self.solves += 1
        self._key, self._last = key, result
        return result

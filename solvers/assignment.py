"""Assigning attackers to defenders: the paper's MIP on CP-SAT, its extension to defender
pairs, and the matching baseline.

All work on plain boolean tables built from the solved HJ games (section III-C/D of the
paper); indices are attacker ``i`` in ``0..M-1`` and defenders ``j``, ``k`` in
``0..N-1``.

**One index order, project-wide**: attackers first. An index pair is ``(attacker,
defender)``, as the tables' axes ``(M, N)`` are; a team is ``(attacker, j, k)`` and one
defender's pair of attackers ``(first, second, defender)`` (``policies.certificate.Roles``).
Player *names* keep the env's form: an overlay edge is ``(defender name, attacker
name)``. Every table says where the *attacker side* wins (value <= 0), as the tubes do:

- ``beats_1v1[i, j]``: attacker ``i`` beats defender ``j`` in the 1 vs 1 game, i.e.
  ``i`` is in the paper's set ``I_j``;
- ``beats_2v1[k, l, j]``: attackers ``k`` and ``l`` together beat defender ``j`` in the
  2 vs 1 game, i.e. ``(k, l)`` is in ``P_j``. A pair counts as winning when either order
  says so; the diagonal is ignored.
- ``beats_1v2[i, j, k]``: attacker ``i`` beats defenders ``j`` and ``k`` together in the
  1 vs 2 game, i.e. ``i`` is in the set ``Q_jk`` (beyond the paper). Either order of the
  defenders counts, as for ``beats_2v1``; the diagonal ``j == k`` is ignored, and so are
  attackers that ``j`` or ``k`` stops alone (a team is never needed for them).

``solve_assignment`` is the paper's program (c1)-(c5): each defender takes at most two
attackers, each attacker at most one defender, never an attacker that beats it alone nor
a pair that beats it together; maximise the number of assignments, which is the number
of captures the defenders can guarantee. Given ``beats_1v2`` it also lets two defenders
share one attacker that they beat together, (c6)-(c9) in its docstring. ``max_matching``
is the baseline of Chen, Zhou and Tomlin (2014): each defender takes at most one attacker
that it beats alone.

Ties between optimal answers are broken by optional integer preference tables, strictly
below the number of covered attackers (lexicographic), and otherwise by the deterministic
single-worker solver.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from functools import cached_property

import numpy as np


@dataclass(frozen=True)
class Assignment:
    """Which defenders chase which attackers.

    ``pairs``: ``(attacker, defender)`` index pairs of attackers taken by one defender
    alone (variables ``e``), sorted. ``by_defender[j]``: the attackers defender ``j`` takes
    alone, sorted (at most two for the MIP, one for the matching). ``shared``:
    ``(attacker, j, k)`` with ``j < k``, attackers taken by two defenders together
    (variables ``f``; only with ``beats_1v2``), sorted; a defender in ``shared`` takes
    nothing else. ``captures``: the optimal objective, the number of covered attackers
    (always optimal: a solve that does not prove optimality is an error).
    """

    pairs: tuple[tuple[int, int], ...]
    by_defender: tuple[tuple[int, ...], ...]
    captures: int
    shared: tuple[tuple[int, int, int], ...] = ()

    @classmethod
    def from_pairs(cls, pairs: list[tuple[int, int]], num_defenders: int,
                   shared: list[tuple[int, int, int]] | None = None) -> Assignment:
        ordered = tuple(sorted(pairs))
        teams = tuple(sorted((i, min(j, k), max(j, k)) for i, j, k in shared or ()))
        by_defender = tuple(tuple(i for i, d in ordered if d == j) for j in range(num_defenders))
        return cls(ordered, by_defender, len(ordered) + len(teams), teams)

    def defender_of(self, attacker: int) -> int | None:
        """The defender that takes ``attacker`` alone, or ``None`` (also when shared)."""
        for i, j in self.pairs:
            if i == attacker:
                return j
        return None

    def defenders_of(self, attacker: int) -> tuple[int, ...]:
        """Every defender assigned to ``attacker``: none, one, or a pair ``(j, k)``, j < k."""
        alone = self.defender_of(attacker)
        if alone is not None:
            return (alone,)
        return next(((j, k) for i, j, k in self.shared if i == attacker), ())

    def partner_of(self, defender: int) -> tuple[int, int] | None:
        """``(attacker, other defender)`` when ``defender`` shares an attacker, else ``None``."""
        for i, j, k in self.shared:
            if defender in (j, k):
                return i, k if defender == j else j
        return None


@functools.cache
def _model_class() -> type:
    """``CpModel`` without the camelCase aliases OR-Tools attaches to every new model
    (OR-Tools is imported here, on the first program solved, not with this module).

    Attaching them walks ``dir(model)`` and costs about 0.4 ms per model, more than
    solving a typical instance here; this module uses the snake_case names only.
    """
    from ortools.sat.python import cp_model

    class _Model(cp_model.CpModel):
        def _add_pre_pep8_methods(self) -> None:
            pass

    return _Model


@dataclass(frozen=True)
class _Tables:
    """Checked inputs: ``beats_2v1`` / ``beats_1v2`` symmetrised, ``active`` filled in."""

    beats_1v1: np.ndarray
    beats_2v1: np.ndarray | None
    beats_1v2: np.ndarray | None
    active: np.ndarray
    preference: np.ndarray | None
    shared_preference: np.ndarray | None

    @property
    def candidates(self) -> np.ndarray:
        """``(M, N)``: the variables ``e_ij`` that exist, (c4) and active attackers only."""
        return ~self.beats_1v1 & self.active[:, None]

    @property
    def team_candidates(self) -> np.ndarray:
        """``(M, N, N)``: the variables ``f_ijk`` that exist (j < k, (c7), active)."""
        one = self.beats_1v1
        m, n = one.shape
        if self.beats_1v2 is None:
            return np.zeros((m, n, n), dtype=bool)
        upper = np.triu(np.ones((n, n), dtype=bool), k=1)
        return (~self.beats_1v2 & one[:, :, None] & one[:, None, :] & upper[None]
                & self.active[:, None, None])


def _integer_table(name: str, table: np.ndarray | None,
                   shape: tuple[int, ...]) -> np.ndarray | None:
    if table is None:
        return None
    table = np.asarray(table)
    if table.shape != shape or not np.issubdtype(table.dtype, np.integer):
        raise ValueError(f"{name}: expected an integer array {shape}, got "
                         f"{table.dtype} {table.shape}")
    if np.any(table < 0):
        raise ValueError(f"{name}: entries must be >= 0")
    return table


def _bool_table(name: str, table: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    table = np.asarray(table)
    if table.shape != shape or table.dtype != np.bool_:
        raise ValueError(f"{name}: expected a bool array {shape}, got {table.dtype} "
                         f"{table.shape}")
    return table


def _check_inputs(beats_1v1: np.ndarray, beats_2v1: np.ndarray | None = None,
                  active: np.ndarray | None = None, preference: np.ndarray | None = None,
                  beats_1v2: np.ndarray | None = None,
                  shared_preference: np.ndarray | None = None) -> _Tables:
    one = np.asarray(beats_1v1)
    if one.ndim != 2 or one.dtype != np.bool_:
        raise ValueError(f"beats_1v1: expected a bool array (M, N), got {one.dtype} {one.shape}")
    m, n = one.shape
    two = None if beats_2v1 is None else _bool_table("beats_2v1", beats_2v1, (m, m, n))
    three = None if beats_1v2 is None else _bool_table("beats_1v2", beats_1v2, (m, n, n))
    mask = np.ones(m, dtype=bool) if active is None else _bool_table("active", active, (m,))
    return _Tables(
        beats_1v1=one,
        beats_2v1=None if two is None else two | two.transpose(1, 0, 2),
        beats_1v2=None if three is None else three | three.transpose(0, 2, 1),
        active=mask,
        preference=_integer_table("preference", preference, (m, n)),
        shared_preference=_integer_table("shared_preference", shared_preference, (m, n, n)),
    )


def _objective_weight(tables: _Tables) -> int:
    """Weight of one covered attacker so that no preference total can outweigh it.

    Each attacker is covered at most once, so any preference total is at most the sum
    over attackers of their largest candidate preference; one more than that makes the
    number of covered attackers the strictly dominant term.
    """
    m = tables.beats_1v1.shape[0]
    best = np.zeros(m, dtype=np.int64)
    if tables.preference is not None:
        best = np.where(tables.candidates, tables.preference, 0).max(axis=1, initial=0)
    if tables.shared_preference is not None:
        shared = np.where(tables.team_candidates, tables.shared_preference, 0)
        best = np.maximum(best, shared.reshape(m, -1).max(axis=1, initial=0))
    return int(best.sum()) + 1


def solve_assignment(beats_1v1: np.ndarray, beats_2v1: np.ndarray,
                     active: np.ndarray | None = None,
                     preference: np.ndarray | None = None,
                     beats_1v2: np.ndarray | None = None,
                     shared_preference: np.ndarray | None = None) -> Assignment:
    """The paper's MIP (c1)-(c5), with defender pairs (c6)-(c9) when given ``beats_1v2``.

    ``beats_1v1``: bool ``(M, N)``; ``beats_2v1``: bool ``(M, M, N)``; ``active``: bool
    ``(M,)``, attackers still in the game (default all); ``beats_1v2``: bool ``(M, N, N)``
    or ``None`` (the paper's program). ``preference`` (``(M, N)``, for ``e``) and
    ``shared_preference`` (``(M, N, N)``, for ``f``, read at ``j < k``): optional
    non-negative integers; among assignments covering the most attackers, one with the
    largest total preference is returned (it never lowers the number covered).

    The program. ``e_ij = 1``: defender ``j`` takes attacker ``i`` alone (1 vs 1 or, with
    a second attacker, 2 vs 1). ``f_ijk = 1`` (``j < k``): defenders ``j`` and ``k`` take
    attacker ``i`` together (1 vs 2). ``I_j``, ``P_j``, ``Q_jk`` as in the module
    docstring::

        maximise   sum_ij e_ij + sum_{i, j<k} f_ijk
        (c1)  e_ij in {0, 1}                                  for all i, j
        (c2)  sum_i e_ij <= 2                                 for all j
        (c3)  sum_j e_ij <= 1                                 for all i
        (c4)  e_sj = 0                                        for all j, s in I_j
        (c5)  e_kj + e_lj <= 1                                for all j, (k, l) in P_j
        (c6)  f_ijk in {0, 1}                                 for all i, j < k
        (c7)  f_sjk = 0                 for all j < k, s in Q_jk or s not in I_j & I_k
        (c8)  sum_j e_ij + sum_{j<k} f_ijk <= 1               for all i
        (c9)  sum_i e_ij + 2 sum_i sum_{k != j} f_i{jk} <= 2  for all j

    (c7) forms a team only for an attacker that it stops and neither of its defenders
    stops alone: where ``j`` stops ``s`` alone, ``f_sjk`` is dominated (``e_sj`` in its
    place keeps every constraint and the objective), so leaving it out never lowers the
    optimum and keeps the model small. (c8) covers each attacker at most once and
    contains (c3); (c9) puts a defender in at most one team and then gives it nothing
    else, and contains (c2). Without ``f``
    variables (no ``beats_1v2``, or every entry true) the program is exactly (c1)-(c5).
    (c4) and (c7) are applied by not creating the variables, as are inactive attackers.
    """
    tables = _check_inputs(beats_1v1, beats_2v1, active, preference, beats_1v2,
                           shared_preference)
    if tables.beats_2v1 is None:
        raise ValueError("beats_2v1: required by the MIP")
    m, n = tables.beats_1v1.shape
    candidates, team_candidates = tables.candidates, tables.team_candidates
    if not candidates.any() and not team_candidates.any():
        return Assignment.from_pairs([], n)

    from ortools.sat.python import cp_model

    model = _model_class()()
    e = {(int(i), int(j)): model.new_bool_var(f"e_{i}_{j}")  # (c1), (c4)
         for i, j in np.argwhere(candidates)}
    f = {(int(i), int(j), int(k)): model.new_bool_var(f"f_{i}_{j}_{k}")  # (c6), (c7)
         for i, j, k in np.argwhere(team_candidates)}
    for j in range(n):
        takers = np.nonzero(candidates[:, j])[0]
        teams = [var for (_, a, b), var in f.items() if j in (a, b)]
        if len(takers) + 2 * len(teams) > 2:
            model.add(cp_model.LinearExpr.sum([e[i, j] for i in takers])
                      + 2 * cp_model.LinearExpr.sum(teams) <= 2)  # (c2), (c9)
        forbidden = np.triu(tables.beats_2v1[np.ix_(takers, takers, [j])][:, :, 0], k=1)
        for a, b in np.argwhere(forbidden):
            model.add_at_most_one(e[takers[a], j], e[takers[b], j])  # (c5)
    for i in range(m):
        cover = [e[i, j] for j in np.nonzero(candidates[i])[0]] \
            + [var for (s, _, _), var in f.items() if s == i]
        if len(cover) > 1:
            model.add_at_most_one(cover)  # (c3), (c8)

    weight = _objective_weight(tables)
    pref, shared_pref = tables.preference, tables.shared_preference
    terms = list(e.values()) + list(f.values())
    coefficients = [weight + (0 if pref is None else int(pref[i, j])) for i, j in e] \
        + [weight + (0 if shared_pref is None else int(shared_pref[i, j, k])) for i, j, k in f]
    model.maximize(cp_model.LinearExpr.weighted_sum(terms, coefficients))

    solver = cp_model.CpSolver()
    solver.parameters.num_workers = 1
    solver.parameters.random_seed = 0
    solver.parameters.cp_model_presolve = False  # faster on these tiny models, still exact
    status = solver.solve(model)
    if status != cp_model.OPTIMAL:
        raise RuntimeError(f"assignment MIP: CP-SAT ended with {solver.status_name(status)}")
    pairs = [key for key, var in e.items() if solver.boolean_value(var)]
    shared = [key for key, var in f.items() if solver.boolean_value(var)]
    return Assignment.from_pairs(pairs, n, shared)


def max_matching(beats_1v1: np.ndarray, active: np.ndarray | None = None,
                 preference: np.ndarray | None = None) -> Assignment:
    """Maximum bipartite matching of defenders to attackers they beat 1 vs 1 (baseline).

    Edge ``(i, j)`` when ``not beats_1v1[i, j]`` and attacker ``i`` is active. Solved as
    a max flow with min cost (OR-Tools ``SimpleMinCostFlow``); ``preference`` as in
    ``solve_assignment`` breaks ties between maximum matchings.
    """
    tables = _check_inputs(beats_1v1, active=active, preference=preference)
    m, n = tables.beats_1v1.shape
    candidates, pref = tables.candidates, tables.preference
    if not candidates.any():
        return Assignment.from_pairs([], n)
    source, sink = m + n, m + n + 1  # attackers are nodes 0..m-1, defenders m..m+n-1
    top = 0 if pref is None else int(np.where(candidates, pref, 0).max())
    from ortools.graph.python import min_cost_flow

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
    """Solves the MIP (or the matching) step after step, reusing answers still optimal.

    The sets ``I_j``, ``P_j`` (and ``Q_jk``) change rarely between time steps, so
    ``solve`` returns the previous ``Assignment`` object when what the program reads
    (``_Program``) is equal to the last time. With ``keep_previous`` (default) ties
    between optimal answers are broken towards the assignments of the previous answer
    (alone and shared), so the assignment does not flip between equally good ones; and
    the previous answer is also returned without a solve when it is still feasible and
    provably still optimal: the new program's feasible assignments are all feasible in the
    program it was solved for, or it reaches a cheap upper bound on the optimum
    (``_Program.upper_bound``). A full solve would return the same object's assignment
    then: it covers the most attackers and, among those, is the only one with the largest
    preference (every one of its own variables). ``solves``, ``reuses`` (unchanged
    program) and ``kept`` (proven still optimal) count what happened. Tables equal to the
    last call's, byte for byte, are answered before any checking (the common case from
    one time step to the next).
    """

    def __init__(self, method: str = "mip", keep_previous: bool = True) -> None:
        if method not in ("mip", "matching"):
            raise ValueError(f"method: expected 'mip' or 'matching', got {method!r}")
        self.method = method
        self.keep_previous = keep_previous
        self.solves = 0
        self.reuses = 0
        self.kept = 0
        self._program: _Program | None = None
        self._solved: _Program | None = None
        self._last: Assignment | None = None
        self._inputs: tuple | None = None

    def reset(self) -> None:
        """Forget the previous answer (start of an episode)."""
        self._program = self._solved = None
        self._last = None
        self._inputs = None

    def solve(self, beats_1v1: np.ndarray, beats_2v1: np.ndarray | None = None,
              active: np.ndarray | None = None,
              beats_1v2: np.ndarray | None = None) -> Assignment:
        """The optimal assignment for these tables (``beats_2v1`` and ``beats_1v2`` unused
        by ``matching``; ``beats_1v2=None`` is the paper's program)."""
        inputs = _raw_inputs(beats_1v1, beats_2v1, active, beats_1v2)
        if self._last is not None and inputs == self._inputs:
            self.reuses += 1
            return self._last
        self._inputs = None
        result = self._answer(beats_1v1, beats_2v1, active, beats_1v2)
        self._inputs = inputs
        return result

    def _answer(self, beats_1v1: np.ndarray, beats_2v1: np.ndarray | None,
                active: np.ndarray | None, beats_1v2: np.ndarray | None) -> Assignment:
        """``solve`` for tables other than the last call's."""
        mip = self.method == "mip"
        if mip and beats_2v1 is None:
            raise ValueError("beats_2v1: required by the 'mip' method")
        tables = _check_inputs(beats_1v1, beats_2v1 if mip else None, active,
                               beats_1v2=beats_1v2 if mip else None)
        program = _Program.of(tables)
        last = self._last
        if last is not None and self._program is not None and program.key == self._program.key:
            self.reuses += 1
            return last
        if last is not None and self.keep_previous and self._solved is not None \
                and program.shape == self._solved.shape:
            kept = self._still_optimal(program, last, 2 if mip else 1)
            if kept is not None:
                self.kept += 1
                self._program = program
                if kept is not last:
                    self._solved, self._last = program, kept
                return kept
        preference, shared_preference = self._previous_preferences(tables.beats_1v1.shape)
        if mip:
            result = solve_assignment(tables.beats_1v1, tables.beats_2v1, tables.active,
                                      preference, tables.beats_1v2, shared_preference)
        else:
            result = max_matching(tables.beats_1v1, tables.active, preference)
        self.solves += 1
        self._program = self._solved = program
        self._last = result
        return result

    def _still_optimal(self, program: _Program, last: Assignment,
                       per_defender: int) -> Assignment | None:
        """The answer a full solve would give, when a cheap argument proves it, else
        ``None``: ``last`` where it is still feasible and either nothing new became
        feasible since its solve or it reaches ``program.upper_bound``; ``last`` less its
        vanished variables where that is feasible and reaches the bound (where the
        optimum is that size, the full solve keeps every previous variable it can)."""
        if program.admits(last):
            if program.within(self._solved) or last.captures >= program.upper_bound(
                    per_defender):
                return last
            return None
        survivors = program.surviving(last)
        if program.admits(survivors) and survivors.captures >= program.upper_bound(
                per_defender):
            return survivors
        return None

    def _previous_preferences(self, shape: tuple[int, int]) -> tuple[np.ndarray | None,
                                                                      np.ndarray | None]:
        """Preference 1 on every variable the previous answer set (same defenders)."""
        last = self._last
        m, n = shape
        if not self.keep_previous or last is None or len(last.by_defender) != n:
            return None, None
        preference = np.zeros((m, n), dtype=np.int64)
        for i, j in last.pairs:
            if i < m:
                preference[i, j] = 1
        shared_preference = np.zeros((m, n, n), dtype=np.int64)
        for i, j, k in last.shared:
            if i < m:
                shared_preference[i, j, k] = 1
        return preference, shared_preference


def _raw_inputs(*tables: np.ndarray | None) -> tuple:
    """The tables as given, for an exact comparison with the last call's: each one's
    dtype, shape and bytes (``None`` as is)."""
    arrays = [None if t is None else np.asarray(t) for t in tables]
    return tuple(None if a is None else (a.dtype.str, a.shape, a.tobytes()) for a in arrays)


@dataclass(frozen=True, eq=False)
class _Program:
    """What the program reads of the tables, and nothing else.

    ``candidates`` ``(M, N)``: the variables ``e`` that exist; ``forbidden`` ``(M, M, N)``
    (``None`` for the matching): which pairs of a defender's candidates beat it together
    (c5), symmetric; ``team_candidates`` ``(M, N, N)`` (``None`` for the paper's program
    and the matching): the variables ``f``. Entries outside these (an attacker that
    already beats a defender, an inactive one, a 2 vs 1 pair of which one attacker is out
    of reach) never change the answer.
    """

    candidates: np.ndarray
    forbidden: np.ndarray | None
    team_candidates: np.ndarray | None

    @classmethod
    def of(cls, tables: _Tables) -> _Program:
        candidates = tables.candidates
        forbidden = None
        if tables.beats_2v1 is not None:
            forbidden = tables.beats_2v1 & candidates[:, None, :] & candidates[None, :, :]
        teams = None if tables.beats_1v2 is None else tables.team_candidates
        return cls(candidates, forbidden, teams)

    @property
    def shape(self) -> tuple[int, int, bool, bool]:
        """``(M, N)`` and which tables the program reads."""
        return (*self.candidates.shape, self.forbidden is not None,
                self.team_candidates is not None)

    @cached_property
    def key(self) -> tuple[tuple[int, int, bool, bool], bytes]:
        """Equal for two programs exactly when they read the same (then they have the
        same answer)."""
        parts = (self.candidates, self.forbidden, self.team_candidates)
        return self.shape, b"".join(p.tobytes() for p in parts if p is not None)

    def within(self, other: _Program) -> bool:
        """Whether every assignment feasible here is feasible in ``other`` (same
        ``shape``): no new variable, and no pair forbidden there that is allowed here."""
        if (self.candidates & ~other.candidates).any():
            return False
        if self.team_candidates is not None and (
                self.team_candidates & ~other.team_candidates).any():
            return False
        if self.forbidden is None:
            return True
        both = self.candidates[:, None, :] & self.candidates[None, :, :]
        return not (other.forbidden & both & ~self.forbidden).any()

    def admits(self, assignment: Assignment) -> bool:
        """Whether ``assignment`` (of the same attackers and defenders) is feasible here:
        its variables exist and no defender's two attackers beat it together (c5)."""
        if any(not self.candidates[i, j] for i, j in assignment.pairs):
            return False
        if self.forbidden is not None and any(
                self.forbidden[mine[0], mine[1], j]
                for j, mine in enumerate(assignment.by_defender) if len(mine) == 2):
            return False
        return all(self.team_candidates is not None and self.team_candidates[i, j, k]
                   for i, j, k in assignment.shared)

    def surviving(self, assignment: Assignment) -> Assignment:
        """``assignment`` without its variables that no longer exist here."""
        pairs = [(i, j) for i, j in assignment.pairs if self.candidates[i, j]]
        shared = [(i, j, k) for i, j, k in assignment.shared
                  if self.team_candidates is not None and self.team_candidates[i, j, k]]
        return Assignment.from_pairs(pairs, self.candidates.shape[1], shared)

    def upper_bound(self, per_defender: int) -> int:
        """An upper bound on the number of covered attackers, cheap to compute: the
        attackers that have a variable, and the defenders' capacity, ``per_defender``
        attackers each (2 for the MIP, 1 for the matching), no more than its candidates,
        one where every pair of its candidates beats it (c5), and one half for a defender
        with team variables only (a team covers one attacker with two defenders)."""
        candidates = self.candidates
        coverable = candidates.any(axis=1)
        takers = candidates.sum(axis=0)
        capacity = np.minimum(takers, per_defender)
        if self.forbidden is not None:
            pairs = takers * (takers - 1) // 2
            forbidden_pairs = (self.forbidden.sum(axis=(0, 1))
                               - np.einsum("iij->j", self.forbidden)) // 2
            capacity = np.where(forbidden_pairs >= pairs, np.minimum(capacity, 1), capacity)
        halves = 2 * capacity
        if self.team_candidates is not None:
            teams = self.team_candidates
            coverable = coverable | teams.any(axis=(1, 2))
            in_team = teams.any(axis=(0, 2)) | teams.any(axis=(0, 1))
            halves = np.where((takers == 0) & in_team, 1, halves)
        return int(min(coverable.sum(), halves.sum() // 2))

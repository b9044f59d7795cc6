"""The assignment MIP and the matching baseline against brute-force enumeration."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from solvers.assignment import Assignment, AssignmentSolver, max_matching, solve_assignment


def random_instance(rng: np.random.Generator, m: int, n: int):
    p1, p2 = rng.uniform(0.0, 0.8, size=2)
    one = rng.random((m, n)) < p1
    two = rng.random((m, m, n)) < p2  # deliberately not symmetric: either order forbids
    active = rng.random(m) < 0.85
    return one, two, active


def feasible_mip(pairs, one, two, active) -> bool:
    defenders = [j for _, j in pairs]
    attackers = [i for i, _ in pairs]
    if len(set(attackers)) != len(attackers):
        return False  # (c3)
    if any(defenders.count(j) > 2 for j in set(defenders)):
        return False  # (c2)
    if any(one[i, j] or not active[i] for i, j in pairs):
        return False  # (c4), inactive attackers
    for (a, j), (b, j2) in itertools.combinations(pairs, 2):
        if j == j2 and (two[a, b, j] or two[b, a, j]):
            return False  # (c5)
    return True


def feasible_matching(pairs, one, active) -> bool:
    attackers = [i for i, _ in pairs]
    defenders = [j for _, j in pairs]
    return (len(set(attackers)) == len(attackers) and len(set(defenders)) == len(defenders)
            and all(not one[i, j] and active[i] for i, j in pairs))


def all_assignments(m: int, n: int):
    """Every way to give each attacker a defender or nothing (-1), as pair lists."""
    for choice in itertools.product(range(-1, n), repeat=m):
        yield [(i, j) for i, j in enumerate(choice) if j >= 0]


def brute_force(m, n, feasible, preference=None) -> tuple[int, int]:
    """(most assignments, largest preference among those) over all feasible assignments."""
    best = (0, 0)
    for pairs in all_assignments(m, n):
        if feasible(pairs):
            bonus = 0 if preference is None else sum(int(preference[i, j]) for i, j in pairs)
            best = max(best, (len(pairs), bonus))
    return best


def check_consistent(result: Assignment, n: int) -> None:
    assert result.status == "OPTIMAL"
    assert result.captures == len(result.pairs)
    assert len(result.by_defender) == n
    assert sorted((i, j) for j, group in enumerate(result.by_defender) for i in group) \
        == list(result.pairs)
    for i, j in result.pairs:
        assert result.defender_of(i) == j


def test_mip_equals_brute_force_on_random_instances():
    rng = np.random.default_rng(1)
    for _ in range(300):
        m, n = int(rng.integers(1, 6)), int(rng.integers(1, 4))
        one, two, active = random_instance(rng, m, n)
        result = solve_assignment(one, two, active)
        check_consistent(result, n)
        assert feasible_mip(result.pairs, one, two, active)
        best, _ = brute_force(m, n, lambda p: feasible_mip(p, one, two, active))  # noqa: B023
        assert result.captures == best


def test_matching_equals_brute_force_on_random_instances():
    rng = np.random.default_rng(2)
    for _ in range(300):
        m, n = int(rng.integers(1, 6)), int(rng.integers(1, 4))
        one, _, active = random_instance(rng, m, n)
        result = max_matching(one, active)
        check_consistent(result, n)
        assert feasible_matching(result.pairs, one, active)
        best, _ = brute_force(m, n, lambda p: feasible_matching(p, one, active))  # noqa: B023
        assert result.captures == best


def test_preference_breaks_ties_without_lowering_captures():
    rng = np.random.default_rng(3)
    for _ in range(150):
        m, n = int(rng.integers(1, 6)), int(rng.integers(1, 4))
        one, two, active = random_instance(rng, m, n)
        preference = rng.integers(0, 50, size=(m, n))
        result = solve_assignment(one, two, active, preference)
        assert feasible_mip(result.pairs, one, two, active)
        got = (result.captures, sum(int(preference[i, j]) for i, j in result.pairs))
        assert got == brute_force(m, n, lambda p: feasible_mip(p, one, two, active),  # noqa: B023
                                  preference)
        matched = max_matching(one, active, preference)
        got = (matched.captures, sum(int(preference[i, j]) for i, j in matched.pairs))
        assert got == brute_force(m, n, lambda p: feasible_matching(p, one, active),  # noqa: B023
                                  preference)


def test_paper_2v1_example_mip_takes_both_matching_one():
    # The paper's 2 vs 1 start: the defender beats each attacker alone and both together.
    one = np.zeros((2, 1), dtype=bool)
    two = np.zeros((2, 2, 1), dtype=bool)
    assert solve_assignment(one, two).by_defender == ((0, 1),)
    assert max_matching(one).captures == 1
    two[0, 1, 0] = True  # now the pair beats it: only one can be assigned
    assert solve_assignment(one, two).captures == 1


def test_no_defender_can_take_anyone():
    one = np.ones((4, 2), dtype=bool)
    two = np.zeros((4, 4, 2), dtype=bool)
    for result in (solve_assignment(one, two), max_matching(one)):
        assert result.pairs == () and result.by_defender == ((), ()) and result.captures == 0


def test_all_attackers_inactive():
    one = np.zeros((3, 2), dtype=bool)
    two = np.zeros((3, 3, 2), dtype=bool)
    inactive = np.zeros(3, dtype=bool)
    assert solve_assignment(one, two, inactive).captures == 0
    assert max_matching(one, inactive).captures == 0


def test_fewer_attackers_than_defenders():
    one = np.array([[True, False, False]])
    two = np.zeros((1, 1, 3), dtype=bool)
    result = solve_assignment(one, two)
    assert result.captures == 1 and result.defender_of(0) in (1, 2)
    assert max_matching(one).captures == 1


def test_pairs_only_constraints():
    m, n = 5, 2
    one = np.zeros((m, n), dtype=bool)
    assert solve_assignment(one, np.ones((m, m, n), dtype=bool)).captures == n
    assert solve_assignment(one, np.zeros((m, m, n), dtype=bool)).captures == 4
    # The diagonal of beats_2v1 is ignored.
    diagonal = np.zeros((m, m, n), dtype=bool)
    diagonal[np.arange(m), np.arange(m)] = True
    assert solve_assignment(one, diagonal).captures == 4


def test_either_order_of_a_pair_forbids_it():
    one = np.zeros((2, 1), dtype=bool)
    two = np.zeros((2, 2, 1), dtype=bool)
    two[1, 0, 0] = True
    assert solve_assignment(one, two).captures == 1


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"beats_1v1": np.zeros((2, 1), dtype=int)}, "beats_1v1"),
    ({"beats_2v1": np.zeros((2, 2), dtype=bool)}, "beats_2v1"),
    ({"active": np.ones(3, dtype=bool)}, "active"),
    ({"preference": np.ones((2, 1))}, "preference"),
    ({"preference": -np.ones((2, 1), dtype=int)}, "preference"),
])
def test_bad_input_names_the_field(kwargs, field):
    args = {"beats_1v1": np.zeros((2, 1), dtype=bool), "beats_2v1": np.zeros((2, 2, 1), bool)}
    args.update(kwargs)
    with pytest.raises(ValueError, match=field):
        solve_assignment(**args)


def test_solver_reuses_unchanged_answers():
    rng = np.random.default_rng(4)
    one, two, active = random_instance(rng, 6, 2)
    solver = AssignmentSolver()
    first = solver.solve(one, two, active)
    assert solver.solve(one.copy(), two.copy(), active.copy()) is first
    assert (solver.solves, solver.reuses) == (1, 1)
    active[np.nonzero(active)[0][:1]] = False
    assert solver.solve(one, two, active) is not first
    assert solver.solves == 2
    solver.reset()
    solver.solve(one, two, active)
    assert solver.solves == 3


def test_solver_keeps_previous_answer_when_still_optimal():
    rng = np.random.default_rng(5)
    for method in ("mip", "matching"):
        solver = AssignmentSolver(method)
        one, two, active = random_instance(rng, 5, 2)
        previous = solver.solve(one, two, active)
        kept = 0
        for _ in range(200):
            one, two, active = one.copy(), two.copy(), active.copy()
            flip = rng.integers(0, 3)
            if flip == 0:
                one[tuple(rng.integers(0, s) for s in one.shape)] ^= True
            elif flip == 1:
                two[tuple(rng.integers(0, s) for s in two.shape)] ^= True
            else:
                active[rng.integers(0, 5)] ^= True
            result = solver.solve(one, two, active)
            fresh = (solve_assignment(one, two, active) if method == "mip"
                     else max_matching(one, active))
            assert result.captures == fresh.captures
            still_ok = (feasible_mip(previous.pairs, one, two, active) if method == "mip"
                        else feasible_matching(previous.pairs, one, active))
            if still_ok and previous.captures == fresh.captures:
                assert result.pairs == previous.pairs
                kept += 1
            previous = result
        assert kept > 20


def test_solver_rejects_unknown_method_and_missing_pairs():
    with pytest.raises(ValueError, match="method"):
        AssignmentSolver("greedy")
    with pytest.raises(ValueError, match="beats_2v1"):
        AssignmentSolver().solve(np.zeros((2, 1), dtype=bool))


def test_same_input_same_answer():
    rng = np.random.default_rng(6)
    for _ in range(20):
        one, two, active = random_instance(rng, 8, 4)
        assert solve_assignment(one, two, active) == solve_assignment(one, two, active)
        assert max_matching(one, active) == max_matching(one, active)


def test_solver_reuses_when_only_unread_entries_change():
    beats_1v1 = np.array([[True, False], [False, False], [False, False]])
    beats_2v1 = np.zeros((3, 3, 2), dtype=bool)
    active = np.array([True, True, True])
    solver = AssignmentSolver("mip")
    first = solver.solve(beats_1v1, beats_2v1, active)
    # Attacker 0 beats defender 0 alone, so no pair with it is ever read for defender 0.
    flipped = beats_2v1.copy()
    flipped[0, 1, 0] = flipped[1, 0, 0] = True
    assert solver.solve(beats_1v1, flipped, active) is first
    # Attacker 2 leaves the game: what it would beat no longer matters either.
    gone = np.array([True, True, False])
    second = solver.solve(beats_1v1, beats_2v1, gone)
    changed = beats_1v1.copy()
    changed[2] = [True, True]
    assert solver.solve(changed, beats_2v1, gone) is second
    assert (solver.solves, solver.reuses) == (2, 2)
    # A pair both of whose attackers defender 1 could take does matter.
    relevant = beats_2v1.copy()
    relevant[1, 2, 1] = relevant[2, 1, 1] = True
    solver.solve(beats_1v1, relevant, active)
    assert solver.solves == 3

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


def random_team_instance(rng: np.random.Generator, m: int, n: int):
    """``(beats_1v1, beats_2v1, beats_1v2, active)``; the 1 vs 2 table is not symmetric in
    the defenders, and attackers beat defenders alone more often than in
    ``random_instance`` (slow defenders: where teams matter)."""
    one, two, active = random_instance(rng, m, n)
    one |= rng.random((m, n)) < 0.5
    three = rng.random((m, n, n)) < rng.uniform(0.1, 0.9)
    return one, two, three, active


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


def feasible_with_teams(pairs, shared, one, two, three, active) -> bool:
    """(c1)-(c9) checked on whole pair lists, independently of the model."""
    if not feasible_mip(pairs, one, two, active):
        return False  # (c1)-(c5)
    if any(three[i, j, k] or three[i, k, j] or not (one[i, j] and one[i, k])
           or not active[i] or not j < k for i, j, k in shared):
        return False  # (c6), (c7), inactive attackers
    covered = [i for i, _ in pairs] + [i for i, _, _ in shared]
    if len(set(covered)) != len(covered):
        return False  # (c8)
    in_teams = [d for _, j, k in shared for d in (j, k)]
    alone = {j for _, j in pairs}
    return len(set(in_teams)) == len(in_teams) and not alone & set(in_teams)  # (c9)


def brute_force_with_teams(one, two, three, active, preference=None,
                           shared_preference=None) -> tuple[int, int]:
    """(most covered, largest preference among those): every attacker gets nothing, one
    defender or a pair of defenders; partial assignments that break a constraint are cut
    (every constraint is an upper bound, so no extension of them can be feasible)."""
    m, n = one.shape
    options = [None] + [(j,) for j in range(n)] + list(itertools.combinations(range(n), 2))
    best = (0, 0)

    def visit(i, pairs, shared):
        nonlocal best
        if not feasible_with_teams(pairs, shared, one, two, three, active):
            return
        if i == m:
            bonus = sum(int(preference[a, j]) for a, j in pairs) if preference is not None else 0
            if shared_preference is not None:
                bonus += sum(int(shared_preference[a, j, k]) for a, j, k in shared)
            best = max(best, (len(pairs) + len(shared), bonus))
            return
        for option in options:
            if option is None:
                visit(i + 1, pairs, shared)
            elif len(option) == 1:
                visit(i + 1, [*pairs, (i, option[0])], shared)
            else:
                visit(i + 1, pairs, [*shared, (i, *option)])

    visit(0, [], [])
    return best


def brute_force(m, n, feasible, preference=None) -> tuple[int, int]:
    """(most assignments, largest preference among those) over all feasible assignments."""
    best = (0, 0)
    for pairs in all_assignments(m, n):
        if feasible(pairs):
            bonus = 0 if preference is None else sum(int(preference[i, j]) for i, j in pairs)
            best = max(best, (len(pairs), bonus))
    return best


def check_consistent(result: Assignment, n: int) -> None:
    assert result.captures == len(result.pairs) + len(result.shared)
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
    solver = AssignmentSolver(keep_previous=False)  # no proofs: every changed program solved
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
    solver = AssignmentSolver("mip", keep_previous=False)
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


def check_teams(result: Assignment, n: int) -> None:
    check_consistent(result, n)
    assert result.captures == len(result.pairs) + len(result.shared)
    for i, j, k in result.shared:
        assert j < k and result.defenders_of(i) == (j, k) and result.defender_of(i) is None
        assert result.partner_of(j) == (i, k) and result.partner_of(k) == (i, j)
        assert result.by_defender[j] == result.by_defender[k] == ()
    for i, j in result.pairs:
        assert result.defenders_of(i) == (j,) and result.partner_of(j) is None


def test_mip_with_teams_equals_brute_force_on_random_instances():
    rng = np.random.default_rng(7)
    used_teams = 0
    for _ in range(300):
        m, n = int(rng.integers(1, 6)), int(rng.integers(1, 5))
        one, two, three, active = random_team_instance(rng, m, n)
        result = solve_assignment(one, two, active, beats_1v2=three)
        check_teams(result, n)
        assert feasible_with_teams(result.pairs, result.shared, one, two, three, active)
        assert result.captures == brute_force_with_teams(one, two, three, active)[0]
        used_teams += bool(result.shared)
    assert used_teams > 50  # the instances exercise the new variables


def test_shared_preference_breaks_ties_without_lowering_captures():
    rng = np.random.default_rng(8)
    for _ in range(150):
        m, n = int(rng.integers(1, 5)), int(rng.integers(1, 5))
        one, two, three, active = random_team_instance(rng, m, n)
        preference = rng.integers(0, 50, size=(m, n))
        shared_preference = rng.integers(0, 50, size=(m, n, n))
        result = solve_assignment(one, two, active, preference, three, shared_preference)
        assert feasible_with_teams(result.pairs, result.shared, one, two, three, active)
        got = (result.captures, sum(int(preference[i, j]) for i, j in result.pairs)
               + sum(int(shared_preference[i, j, k]) for i, j, k in result.shared))
        assert got == brute_force_with_teams(one, two, three, active, preference,
                                             shared_preference)


def test_without_team_variables_the_program_is_the_papers():
    rng = np.random.default_rng(9)
    for _ in range(200):
        m, n = int(rng.integers(1, 7)), int(rng.integers(1, 5))
        one, two, active = random_instance(rng, m, n)
        preference = rng.integers(0, 5, size=(m, n))
        paper = solve_assignment(one, two, active, preference)
        no_team_wins = np.ones((m, n, n), dtype=bool)
        assert solve_assignment(one, two, active, preference, no_team_wins) == paper
        # Teams only of attackers out of the game: no variable either.
        teams_of_inactive = active[:, None, None] | np.eye(n, dtype=bool)[None]
        assert solve_assignment(one, two, active, preference, teams_of_inactive) == paper
        assert paper.shared == ()


def test_two_defenders_share_an_attacker_neither_stops_alone():
    one = np.ones((1, 2), dtype=bool)  # the attacker beats each defender alone
    two = np.zeros((1, 1, 2), dtype=bool)
    three = np.zeros((1, 2, 2), dtype=bool)
    result = solve_assignment(one, two, beats_1v2=three)
    assert result.shared == ((0, 0, 1),) and result.captures == 1 and result.pairs == ()
    assert solve_assignment(one, two).captures == 0
    # Either order of the defenders saying "attacker wins" forbids the team.
    three[0, 1, 0] = True
    assert solve_assignment(one, two, beats_1v2=three).captures == 0
    # The diagonal is no team.
    diagonal = np.ones((1, 2, 2), dtype=bool)
    diagonal[0, [0, 1], [0, 1]] = False
    assert solve_assignment(one, two, beats_1v2=diagonal).captures == 0


def test_a_defender_in_a_team_takes_nothing_else():
    # Attacker 0 needs defenders 0 and 1 together; attackers 1 and 2 each lose to
    # defender 0 alone and, as a pair, to defender 0 too.
    one = np.array([[True, True], [False, True], [False, True]])
    two = np.zeros((3, 3, 2), dtype=bool)
    three = np.ones((3, 2, 2), dtype=bool)
    three[0, 0, 1] = False
    result = solve_assignment(one, two, beats_1v2=three)
    assert result.captures == 2 and result.shared == () and result.by_defender[0] == (1, 2)
    # Once attacker 2 is gone the team and the lone defender are worth one each: either
    # way one attacker is covered, never defender 0 in a team and alone at once.
    gone = np.array([True, True, False])
    result = solve_assignment(one, two, gone, beats_1v2=three)
    assert result.captures == 1
    assert feasible_with_teams(result.pairs, result.shared, one, two, three, gone)
    # Three defenders, each beaten alone, any two win together: one team, never two
    # teams sharing a defender.
    one = np.ones((2, 3), dtype=bool)
    result = solve_assignment(one, np.zeros((2, 2, 3), bool), beats_1v2=np.zeros((2, 3, 3), bool))
    assert result.captures == 1 and len(result.shared) == 1


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"beats_1v2": np.zeros((2, 1), dtype=bool)}, "beats_1v2"),
    ({"beats_1v2": np.zeros((2, 1, 1), dtype=int)}, "beats_1v2"),
    ({"shared_preference": np.ones((2, 1, 1))}, "shared_preference"),
    ({"shared_preference": -np.ones((2, 1, 1), dtype=int)}, "shared_preference"),
])
def test_bad_team_input_names_the_field(kwargs, field):
    args = {"beats_1v1": np.zeros((2, 1), dtype=bool), "beats_2v1": np.zeros((2, 2, 1), bool)}
    args.update(kwargs)
    with pytest.raises(ValueError, match=field):
        solve_assignment(**args)


def test_solver_with_teams_reuses_only_when_unread_entries_change():
    one = np.ones((3, 3), dtype=bool)
    one[2, 2] = False
    two = np.zeros((3, 3, 3), dtype=bool)
    three = np.ones((3, 3, 3), dtype=bool)
    three[0, 0, 1] = three[0, 1, 0] = False
    active = np.array([True, True, False])
    solver = AssignmentSolver("mip", keep_previous=False)
    first = solver.solve(one, two, active, three)
    assert first.shared == ((0, 0, 1),)
    # Unread: the diagonal, and any team against the inactive attacker 2.
    unread = three.copy()
    unread[1, 2, 2] = False
    unread[2] = False
    assert solver.solve(one, two, active, unread) is first
    assert (solver.solves, solver.reuses) == (1, 1)
    # Read: a new team variable against attacker 1 ...
    read = three.copy()
    read[1, 2, 0] = read[1, 0, 2] = False
    assert solver.solve(one, two, active, read).captures == 1
    assert solver.solves == 2
    # ... and the order j > k of the team in use: either order saying "attacker wins"
    # removes the team.
    read = three.copy()
    read[0, 1, 0] = True
    assert solver.solve(one, two, active, read).captures == 0
    assert solver.solves == 3
    # The paper's program (no table) is a different program: solved again.
    assert solver.solve(one, two, active).captures == 0
    assert solver.solves == 4


def test_solver_keeps_previous_shared_answer_when_still_optimal():
    one = np.ones((2, 3), dtype=bool)
    two = np.zeros((2, 2, 3), dtype=bool)
    solver = AssignmentSolver("mip")
    three = np.ones((2, 3, 3), dtype=bool)
    three[0, 1, 2] = three[0, 2, 1] = False
    assert solver.solve(one, two, beats_1v2=three).shared == ((0, 1, 2),)
    # Now any two defenders stop attacker 0: the previous team (1, 2) is kept.
    assert solver.solve(one, two, beats_1v2=three & (np.arange(2) != 0)[:, None, None]
                        ).shared == ((0, 1, 2),)
    # ... without a solve: attacker 0 is the only one with a variable, and it is covered.
    assert (solver.solves, solver.kept) == (1, 1)


def previous_preferences(previous: Assignment, m: int, n: int):
    """Preference 1 on every variable of ``previous`` (what ``keep_previous`` solves with)."""
    preference = np.zeros((m, n), dtype=np.int64)
    shared_preference = np.zeros((m, n, n), dtype=np.int64)
    for i, j in previous.pairs:
        preference[i, j] = 1
    for i, j, k in previous.shared:
        shared_preference[i, j, k] = 1
    return preference, shared_preference


@pytest.mark.parametrize("program", ["paper", "teams", "matching"])
def test_answers_kept_without_a_solve_equal_full_solves(program):
    """Random walks of the tables, one entry flipped per step as during a game (attackers
    leaving, coming back, sets I_j, P_j, Q_jk changing): every answer, solved or proven
    still optimal, is the one a full solve tie-broken towards the previous answer gives,
    and covers as many attackers as brute force."""
    rng = np.random.default_rng({"paper": 10, "teams": 11, "matching": 12}[program])
    solver = AssignmentSolver("matching" if program == "matching" else "mip")
    kept = 0
    for _ in range(12):
        m, n = int(rng.integers(2, 6)), int(rng.integers(1, 4))
        one, two, three, active = random_team_instance(rng, m, n)
        solver.reset()
        previous = None
        for _ in range(40):
            tables = [one, two, three, active]
            which = int(rng.integers(0, 4 if program == "teams" else 3))
            which = 3 if which == 2 and program != "teams" else which
            tables[which] = tables[which].copy()
            tables[which][tuple(rng.integers(0, s) for s in tables[which].shape)] ^= True
            one, two, three, active = tables
            before = solver.kept
            result = solver.solve(one, two, active, three if program == "teams" else None)
            kept += solver.kept - before
            preference, shared_preference = (previous_preferences(previous, m, n)
                                             if previous is not None else (None, None))
            if program == "matching":
                fresh = max_matching(one, active, preference)
                best, _ = brute_force(m, n, lambda p: feasible_matching(p, one, active))  # noqa: B023
            elif program == "paper":
                fresh = solve_assignment(one, two, active, preference)
                best, _ = brute_force(m, n, lambda p: feasible_mip(p, one, two, active))  # noqa: B023
            else:
                fresh = solve_assignment(one, two, active, preference, three, shared_preference)
                best = brute_force_with_teams(one, two, three, active)[0]
            assert result == fresh
            assert result.captures == best
            previous = result
    assert kept > 40  # the proofs are exercised
    assert solver.solves > 20  # and so are the solves


def test_models_skip_only_the_camel_case_aliases():
    """``solvers.assignment`` builds its programs on a ``CpModel`` that skips the
    camelCase aliases OR-Tools attaches to each new model (a private hook, about 0.4 ms a
    model): the hook must still exist and be the one ``CpModel.__init__`` calls, and the
    snake_case methods must stay."""
    from ortools.sat.python import cp_model

    from solvers.assignment import _model_class

    assert hasattr(cp_model.CpModel, "_add_pre_pep8_methods")
    plain, ours = cp_model.CpModel(), _model_class()()
    assert hasattr(plain, "NewBoolVar") and not hasattr(ours, "NewBoolVar")
    assert callable(ours.new_bool_var) and callable(ours.add_bool_or)

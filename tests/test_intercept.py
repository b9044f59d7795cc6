"""The time-to-intercept defenders (``policies.intercept``): the path tracer and the plan
against numpy twins, the races and the plan on hand-made cases, and a played game."""

from __future__ import annotations

import numpy as np
from defenders_reference import reference_plan

import reachavoid_env
from policies.intercept import (
    PATH_STEP,
    InterceptDefender,
    Races,
    plan_copies,
    plan_intercepts,
    race_copies,
    trace_paths,
)
from policies.registry import make_policy
from reachavoid.rollout import run_episode
from reachavoid_env.geodesic import distance_field


def reference_paths(field, starts, step=PATH_STEP, max_points=256):
    """``trace_paths`` point by point with ``DistanceField.distance`` / ``gradient``."""
    points = np.empty((len(starts), max_points, 2))
    counts = np.zeros(len(starts), dtype=np.int64)
    lo = np.array([field.xs[0], field.ys[0]])
    hi = np.array([field.xs[-1], field.ys[-1]])
    for a, start in enumerate(starts):
        point = np.array(start, dtype=np.float64)
        for k in range(max_points):
            points[a, k] = point
            counts[a] = k + 1
            clamped = np.clip(point, lo, hi)
            if field.distance(clamped) <= 0.0:
                break
            gradient = field.gradient(clamped)
            norm = np.hypot(*gradient)
            if norm < 1e-12:
                break
            point = point - step * gradient / norm
        points[a, counts[a]:] = points[a, counts[a] - 1]
    return points, counts


def test_traced_paths_match_the_numpy_twin_and_end_in_the_target():
    scenario = reachavoid_env.builtin_scenario("paper_2v1")
    field = distance_field(scenario.map, scenario.player_radius)
    starts = np.array([[-0.5, 0.0], [0.0, 0.8], [-0.8, -0.8], [0.7, 0.2]])
    paths = trace_paths(field, starts)
    points, counts = reference_paths(field, starts)
    np.testing.assert_array_equal(paths.counts, counts)
    np.testing.assert_allclose(paths.points, points, rtol=0, atol=1e-12)
    ends = paths.points[np.arange(len(starts)), paths.counts - 1]
    assert np.all(scenario.map.target_signed_distance(ends) <= 0.02)
    assert paths.counts[3] == 1   # a start inside the target is its own path


def test_races_and_the_plan_take_the_most_threatening_attacker_first():
    scenario = reachavoid_env.builtin_scenario("paper_2v1")
    field = distance_field(scenario.map, scenario.player_radius)
    attackers = np.array([[0.3, 0.2], [-0.8, 0.8]])    # near the target, far from it
    defenders = np.array([[0.5, 0.5], [-0.7, 0.7]])
    race = Races(*(array[0] for array in race_copies(
        field, attackers[None], defenders[None], np.ones((1, 2), dtype=bool), 1.0, 1.5, 0.1)))
    assert race.threat[0] < race.threat[1]
    assert race.wins[0, 0] and race.wins[1, 1] and not race.wins[0, 1]
    plan = plan_intercepts(race, np.ones(2, dtype=bool), np.ones(2, dtype=bool))
    assert plan.targets.tolist() == [0, 1]
    one = plan_intercepts(race, np.array([True, False]), np.ones(2, dtype=bool))
    assert one.targets.tolist() == [0, -1]
    lost = Races(np.zeros((2, 1), bool), np.zeros((2, 1, 2)), np.ones((2, 1)),
                 np.array([2.0, 1.0]))
    spare = plan_intercepts(lost, np.ones(1, dtype=bool), np.ones(2, dtype=bool))
    assert spare.targets.tolist() == [1]   # no race won: guard the most threatening


def test_intercept_defenders_play_the_paper_games():
    for name, captured in (("paper_2v1", 2), ("paper_6v2", 6)):
        scenario = reachavoid_env.builtin_scenario(name)
        defenders = make_policy("defenders", "intercept", scenario)
        assert isinstance(defenders, InterceptDefender)
        env = reachavoid_env.parallel_env(scenario=scenario)
        result = run_episode(env, make_policy("attackers", "shortest-path", scenario),
                             defenders, seed=0)
        assert result.captured_count == captured, name


def test_the_plan_of_many_copies_is_the_numpy_twins_of_each():
    """``plan_copies`` (one numba kernel) against the numpy plan of before, copy by copy,
    on random races full of ties (threats, times), free defenders and open attackers."""
    rng = np.random.default_rng(0)
    copies, m, n = 400, 5, 4
    race = Races(rng.random((copies, m, n)) < 0.5, rng.random((copies, m, n, 2)),
                 rng.integers(0, 3, (copies, m, n)).astype(float),
                 rng.integers(0, 3, (copies, m)).astype(float))
    free = rng.random((copies, n)) < 0.8
    open_ = rng.random((copies, m)) < 0.7
    plan = plan_copies(race, free, open_)
    for c in range(copies):
        one = Races(*(array[c] for array in race))
        expected = reference_plan(one, free[c], open_[c])
        single = plan_intercepts(one, free[c], open_[c])
        for got in (single, plan_copies(Races(*(a[c:c + 1] for a in race)), free[c:c + 1],
                                        open_[c:c + 1])):
            got = type(got)(*(array.reshape(expected_array.shape) for array, expected_array
                              in zip(got, expected, strict=True)))
            assert np.array_equal(got.targets, expected.targets), c
            assert np.array_equal(got.aims.view(np.uint64), expected.aims.view(np.uint64)), c
        assert np.array_equal(plan.targets[c], expected.targets)
        assert np.array_equal(plan.aims[c].view(np.uint64), expected.aims.view(np.uint64))

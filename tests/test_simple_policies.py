"""Straight and random attackers, idle and greedy defenders."""

from __future__ import annotations

import numpy as np
import pytest

from policies import GreedyDefender, IdleDefender, RandomAttacker, StraightAttacker
from policies.attackers import target_centres
from reachavoid_env import (
    AttackerStatus,
    Box,
    GameMap,
    GameState,
    Policy,
    Polygon,
    builtin_scenario,
)

ACTIVE, CAPTURED, ARRIVED = AttackerStatus.ACTIVE, AttackerStatus.CAPTURED, AttackerStatus.ARRIVED


def state_of(attackers, defenders, status=None, step=0) -> GameState:
    attackers = np.asarray(attackers, dtype=float)
    return GameState(time=step * 0.005, step=step, attacker_positions=attackers,
                     defender_positions=np.asarray(defenders, dtype=float),
                     attacker_status=tuple(status or [ACTIVE] * len(attackers)),
                     attacker_speed=1.0, defender_speed=1.5, capture_radius=0.1)


def check_actions(actions: dict[str, np.ndarray], names: list[str]) -> None:
    assert sorted(actions) == sorted(names)
    for action in actions.values():
        assert action.dtype == np.float32 and action.shape == (2,)
        assert np.all(np.abs(action) <= 1.0)


@pytest.fixture
def scenario():
    return builtin_scenario("paper_6v2")


@pytest.mark.parametrize("policy", [StraightAttacker(), RandomAttacker(0), IdleDefender(),
                                    GreedyDefender()])
def test_follow_the_policy_protocol(policy):
    assert isinstance(policy, Policy)


def test_target_centres():
    paper = builtin_scenario("paper_2v1").map
    np.testing.assert_allclose(target_centres(paper), [[0.7, 0.2]])
    # a U whose centroid lies in its notch: the aim point must lie inside the U
    u_shape = Polygon(((0.0, 0.0), (0.6, 0.0), (0.6, 0.6), (0.4, 0.6), (0.4, 0.2), (0.2, 0.2),
                       (0.2, 0.6), (0.0, 0.6)))
    game_map = GameMap(domain=(-1.0, 1.0, -1.0, 1.0), target=(u_shape, Box((-0.9, -0.9),
                                                                           (-0.7, -0.7))))
    centres = target_centres(game_map)
    assert u_shape.signed_distance(centres[0]) < -0.05
    np.testing.assert_allclose(centres[1], [-0.8, -0.8])


def test_straight_attacker_heads_for_the_nearest_target_centre(scenario):
    policy = StraightAttacker()
    policy.reset(scenario)
    state = state_of(scenario.attackers, scenario.defenders,
                     [ACTIVE, CAPTURED, ACTIVE, ARRIVED, ACTIVE, ACTIVE])
    actions = policy.act(state)
    check_actions(actions, ["attacker_0", "attacker_2", "attacker_4", "attacker_5"])
    for name, action in actions.items():
        start = state.attacker_positions[int(name.split("_")[1])]
        expected = (np.array([0.7, 0.2]) - start) / np.linalg.norm([0.7, 0.2] - start)
        np.testing.assert_allclose(action, expected, rtol=1e-6)


def test_straight_attacker_needs_reset(scenario):
    with pytest.raises(RuntimeError, match="reset"):
        StraightAttacker().act(state_of(scenario.attackers, scenario.defenders))


def test_random_attacker_is_seeded_and_holds_its_heading(scenario):
    def run(seed):
        policy = RandomAttacker(seed, hold=0.25)  # 50 steps at dt = 0.005
        policy.reset(scenario)
        return [policy.act(state_of(scenario.attackers, scenario.defenders, step=k))
                for k in range(101)]

    first, again, other = run(3), run(3), run(4)
    for k in range(101):
        check_actions(first[k], scenario.attacker_names)
        for name in scenario.attacker_names:
            np.testing.assert_array_equal(first[k][name], again[k][name])
            assert np.linalg.norm(first[k][name]) == pytest.approx(1.0, abs=1e-6)
    assert any(not np.allclose(first[0][n], other[0][n]) for n in scenario.attacker_names)
    np.testing.assert_array_equal(first[0]["attacker_0"], first[49]["attacker_0"])
    assert not np.allclose(first[49]["attacker_0"], first[50]["attacker_0"])
    np.testing.assert_array_equal(first[50]["attacker_0"], first[99]["attacker_0"])


def test_random_attacker_acts_for_active_attackers_only(scenario):
    policy = RandomAttacker(0)
    policy.reset(scenario)
    state = state_of(scenario.attackers, scenario.defenders, [CAPTURED] + [ACTIVE] * 5)
    check_actions(policy.act(state), scenario.attacker_names[1:])
    with pytest.raises(ValueError, match="hold"):
        RandomAttacker(0, hold=0.0)


def test_idle_defender_stands_still(scenario):
    policy = IdleDefender()
    policy.reset(scenario)
    actions = policy.act(state_of(scenario.attackers, scenario.defenders))
    check_actions(actions, scenario.defender_names)
    assert all(not a.any() for a in actions.values())


def test_greedy_defender_chases_the_nearest_active_attacker():
    policy = GreedyDefender()
    policy.reset(builtin_scenario("paper_2v1"))
    attackers = [[0.0, 0.5], [0.5, -0.5], [-0.5, -0.5]]
    defenders = [[0.0, 0.0], [-0.4, -0.8]]
    actions = policy.act(state_of(attackers, defenders, [CAPTURED, ACTIVE, ACTIVE]))
    check_actions(actions, ["defender_0", "defender_1"])
    # attacker_0 is nearest to defender_0 but captured: it goes for attacker_1 instead
    np.testing.assert_allclose(actions["defender_0"], np.array([1, -1]) / np.sqrt(2), rtol=1e-6)
    np.testing.assert_allclose(actions["defender_1"], np.array([-0.1, 0.3]) / np.hypot(0.1, 0.3),
                               rtol=1e-6)
    assert policy.overlay().edges == (("defender_0", "attacker_1"), ("defender_1", "attacker_2"))


def test_greedy_defender_stops_when_no_attacker_is_left():
    policy = GreedyDefender()
    policy.reset(builtin_scenario("paper_2v1"))
    actions = policy.act(state_of([[0.0, 0.5]], [[0.0, 0.0]], [ARRIVED]))
    check_actions(actions, ["defender_0"])
    assert not actions["defender_0"].any()
    assert policy.overlay().edges == ()

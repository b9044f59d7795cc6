"""Game rules: capture and arrival along the step's segments, ties, rewards, removal, ends."""

from __future__ import annotations

import numpy as np
import pytest

from reachavoid_env import AttackerStatus, Box, GameMap, ReachAvoidEnv, Scenario
from reachavoid_env.observations import GLOBAL
from reachavoid_env.rules import capture_times, resolve_events

# Powers of two throughout, so positions after a step are exact in binary.
OPEN_MAP = GameMap((-1.0, 1.0, -1.0, 1.0), (Box((0.5, 0.0), (0.75, 0.25)),))
STILL = np.zeros(2, dtype=np.float32)
EAST = np.array([1.0, 0.0], dtype=np.float32)


def exact_scenario(**changes) -> Scenario:
    """Open map, dt = 1/8 s, speeds 1 and 2, capture radius 1/8: every move is exact."""
    settings = dict(map=OPEN_MAP, num_attackers=1, num_defenders=1, attacker_speed=1.0,
                    defender_speed=2.0, capture_radius=0.125, dt=0.125, player_radius=0.125,
                    max_steps=50)
    settings.update(changes)
    return Scenario(**settings)


def start(scenario: Scenario, attackers, defenders, **kwargs) -> ReachAvoidEnv:
    env = ReachAvoidEnv(scenario, **kwargs)
    env.reset(seed=0, options={"attackers": attackers, "defenders": defenders})
    return env


def test_tie_goes_to_capture():
    # The attacker reaches the target's edge x = 0.5 exactly when the defender's disc
    # reaches it: both events at t = 1.
    env = start(exact_scenario(), [[0.375, 0.125]], [[0.5, 0.25]])
    obs, rewards, terminations, truncations, infos = env.step(
        {"attacker_0": EAST, "defender_0": STILL})
    assert env.game_state().attacker_positions.tolist() == [[0.5, 0.125]]
    assert infos["attacker_0"] == {"captured": 1, "arrived": 0,
                                   "status": AttackerStatus.CAPTURED.code, "captured_by": 0}
    assert rewards == {"attacker_0": -1.0, "defender_0": 1.0}
    assert terminations == {"attacker_0": True, "defender_0": True}
    assert truncations == {"attacker_0": False, "defender_0": False}
    assert env.agents == []


def test_readable_infos_name_the_status_and_the_captor():
    env = ReachAvoidEnv(exact_scenario(), info_format="readable")
    _, infos = env.reset(seed=0, options={"attackers": [[0.375, 0.125]],
                                          "defenders": [[0.5, 0.25]]})
    assert infos["attacker_0"] == {"captured": 0, "arrived": 0,
                                   "status": AttackerStatus.ACTIVE}
    _, _, _, _, infos = env.step({"attacker_0": EAST, "defender_0": STILL})
    assert infos["attacker_0"]["status"] is AttackerStatus.CAPTURED
    assert infos["attacker_0"]["captured_by"] == "defender_0"


def test_arrival_on_the_boundary_counts():
    # The same move with the defender a little farther: the attacker ends exactly on
    # the target's edge (inclusive bounds) and arrives.
    env = start(exact_scenario(), [[0.375, 0.125]], [[0.5, 0.25 + 2.0**-10]])
    _, rewards, terminations, _, infos = env.step({"attacker_0": EAST, "defender_0": STILL})
    assert infos["attacker_0"]["status"] == AttackerStatus.ARRIVED.code
    assert infos["attacker_0"]["captured_by"] == -1
    assert rewards == {"attacker_0": 1.0, "defender_0": -1.0}
    assert terminations == {"attacker_0": True, "defender_0": True}
    assert infos["defender_0"] == {"captured": 0, "arrived": 1}


def test_fast_pass_by_is_captured():
    # The defender crosses the capture disc within one step; both of its end points are
    # outside the disc, so only the segment test sees the capture.
    scenario = exact_scenario(defender_speed=4.0, dt=0.0625)
    env = start(scenario, [[0.0, 0.0]], [[-0.125, 0.0625]])
    defender_end = np.array([0.125, 0.0625])
    assert np.hypot(*defender_end) > scenario.capture_radius
    _, rewards, _, _, infos = env.step({"attacker_0": STILL, "defender_0": EAST})
    assert env.game_state().defender_positions.tolist() == [defender_end.tolist()]
    assert infos["attacker_0"]["status"] == AttackerStatus.CAPTURED.code
    assert rewards["defender_0"] == 1.0


def test_earliest_event_wins():
    active = np.array([True, True])
    a_old = np.array([[0.25, 0.125], [0.25, 0.1875]])
    a_new = np.array([[0.75, 0.125], [0.5, 0.1875]])
    # A defender closing in from the east reaches attacker 0 at t = 1, after it entered
    # the target at t = 0.5; attacker 1 enters at t = 1 and nobody catches it.
    d_old, d_new = np.array([[1.125, 0.125]]), np.array([[0.875, 0.125]])
    events = resolve_events(OPEN_MAP, 0.125, active, a_old, a_new, d_old, d_new)
    assert events.arrived.tolist() == [True, True] and events.captured.tolist() == [False, False]
    assert events.times.tolist() == [0.5, 1.0] and events.captor.tolist() == [-1, -1]
    # A still defender whose disc touches attacker 1's path at t = 0.5: captured first.
    d_old = d_new = np.array([[0.375, 0.3125]])
    events = resolve_events(OPEN_MAP, 0.125, active, a_old, a_new, d_old, d_new)
    assert events.captured.tolist() == [False, True] and events.arrived.tolist() == [True, False]
    assert events.times.tolist() == [0.5, 0.5] and events.captor.tolist() == [-1, 0]
    # Attackers no longer active are ignored.
    events = resolve_events(OPEN_MAP, 0.125, np.array([False, False]), a_old, a_new, d_old,
                            d_new)
    assert not events.left.any()


def test_capture_times_match_dense_sampling():
    rng = np.random.default_rng(5)
    a_old, d_old = rng.uniform(-1, 1, (8, 2)), rng.uniform(-1, 1, (4, 2))
    a_new = a_old + rng.normal(scale=0.8, size=(8, 2))
    d_new = d_old + rng.normal(scale=0.8, size=(4, 2))
    radius = 0.3
    times = capture_times(a_old, a_new, d_old, d_new, radius)
    s = np.linspace(0, 1, 20001)[:, None]
    for i in range(8):
        for j in range(4):
            gap = np.linalg.norm((a_old[i] + s * (a_new[i] - a_old[i]))
                                 - (d_old[j] + s * (d_new[j] - d_old[j])), axis=-1)
            inside = np.flatnonzero(gap <= radius)
            if inside.size:
                assert abs(times[i, j] - s[inside[0], 0]) <= 1e-4
            else:
                assert times[i, j] == np.inf
    assert ((times > 0) & (times < 1)).sum() >= 3


def test_captured_attacker_leaves_and_keeps_its_last_position():
    scenario = exact_scenario(num_attackers=2, num_defenders=1)
    env = start(scenario, [[-0.5, 0.0], [0.0, -0.75]], [[-0.5, 0.25 + 0.125]],
                observation=GLOBAL)
    south = np.array([0.0, -1.0], dtype=np.float32)
    _, rewards, terminations, _, infos = env.step(
        {"attacker_0": STILL, "attacker_1": STILL, "defender_0": south})
    # The defender moves 0.25 down; its disc reaches attacker 0 at the end.
    assert terminations == {"attacker_0": True, "attacker_1": False, "defender_0": False}
    assert rewards == {"attacker_0": -1.0, "attacker_1": 0.0, "defender_0": 1.0}
    assert env.agents == ["attacker_1", "defender_0"]
    assert infos["attacker_1"] == {"captured": 1, "arrived": 0,
                                   "status": AttackerStatus.ACTIVE.code, "captured_by": -1}
    obs, _, _, _, _ = env.step({"attacker_0": EAST, "attacker_1": STILL,
                                "defender_0": STILL})    # removed agents' actions ignored
    assert set(obs) == {"attacker_1", "defender_0"}
    state = env.game_state()
    assert state.attacker_positions[0].tolist() == [-0.5, 0.0]
    assert state.attacker_status == (AttackerStatus.CAPTURED, AttackerStatus.ACTIVE)
    # v0's layout: own (x, y), then (x, y, active) per attacker, per defender.
    expected = np.array([0.0, -0.75, -0.5, 0.0, 0.0, 0.0, -0.75, 1.0, -0.5, 0.125, 1.0],
                        dtype=np.float32)
    assert np.array_equal(obs["attacker_1"], expected)
    assert np.array_equal(obs["defender_0"][:2], [-0.5, 0.125])
    assert np.array_equal(env.state(), expected[2:])


def test_two_captures_in_one_step_pay_the_defenders_both():
    scenario = exact_scenario(num_attackers=3, num_defenders=2)
    env = start(scenario, [[-0.5, 0.0], [0.5, -0.5], [-0.5, -0.75]],
                [[-0.5, 0.25], [0.5, -0.25]])
    south = np.array([0.0, -1.0], dtype=np.float32)
    _, rewards, terminations, _, infos = env.step(
        {"attacker_0": STILL, "attacker_1": STILL, "attacker_2": STILL,
         "defender_0": south, "defender_1": south})
    assert rewards == {"attacker_0": -1.0, "attacker_1": -1.0, "attacker_2": 0.0,
                       "defender_0": 2.0, "defender_1": 2.0}
    assert [name for name, done in terminations.items() if done] == ["attacker_0",
                                                                     "attacker_1"]
    assert infos["defender_1"] == {"captured": 2, "arrived": 0}


def test_truncation_after_max_cycles_then_empty_steps():
    env = start(exact_scenario(), [[-0.75, -0.75]], [[0.75, 0.75]], max_cycles=3)
    for _ in range(2):
        _, _, terminations, truncations, _ = env.step({"attacker_0": STILL,
                                                       "defender_0": STILL})
        assert not any(terminations.values()) and not any(truncations.values())
    _, rewards, terminations, truncations, _ = env.step({"attacker_0": STILL,
                                                         "defender_0": STILL})
    assert truncations == {"attacker_0": True, "defender_0": True}
    assert terminations == {"attacker_0": False, "defender_0": False}
    assert rewards == {"attacker_0": 0.0, "defender_0": 0.0}
    assert env.agents == []
    assert env.step({}) == ({}, {}, {}, {}, {})
    assert env.step({"attacker_0": STILL}) == ({}, {}, {}, {}, {})


def test_max_cycles_defaults_to_the_scenario():
    assert ReachAvoidEnv(exact_scenario(max_steps=7)).max_cycles == 7
    assert ReachAvoidEnv(exact_scenario(max_steps=7), max_cycles=2).max_cycles == 2


def test_long_actions_are_scaled_to_unit_length():
    env = start(exact_scenario(), [[-0.75, -0.75]], [[0.75, 0.75]])
    env.step({"attacker_0": np.array([3.0, 4.0]), "defender_0": np.array([0.25, 0.0])})
    state = env.game_state()
    assert np.allclose(state.attacker_positions[0], [-0.75 + 0.6 * 0.125, -0.75 + 0.8 * 0.125])
    assert np.allclose(state.defender_positions[0], [0.75 + 0.25 * 2.0 * 0.125, 0.75])
    assert state.time == 0.125 and state.step == 1


def test_shaping_rewards_progress_and_stays_zero_sum():
    plain = start(exact_scenario(), [[-0.75, 0.125]], [[0.75, 0.75]])
    _, rewards, _, _, _ = plain.step({"attacker_0": EAST, "defender_0": STILL})
    assert rewards == {"attacker_0": 0.0, "defender_0": 0.0}
    shaped = start(exact_scenario(), [[-0.75, 0.125]], [[0.75, 0.75]], shaping=2.0)
    _, rewards, _, _, _ = shaped.step({"attacker_0": EAST, "defender_0": STILL})
    assert rewards["attacker_0"] == pytest.approx(2.0 * 0.125)
    assert rewards["defender_0"] == -rewards["attacker_0"]
    with pytest.raises(ValueError, match="shaping"):
        ReachAvoidEnv(exact_scenario(), shaping=float("nan"))


def test_flags_are_python_bools_and_rewards_floats_and_dicts_fresh():
    env = start(exact_scenario(), [[-0.75, -0.75]], [[0.75, 0.75]])
    actions = {"attacker_0": STILL, "defender_0": STILL}
    first = env.step(actions)
    second = env.step(actions)
    for one, two in zip(first, second, strict=True):
        assert one is not two
    _, rewards, terminations, truncations, _ = first
    assert all(type(v) is float for v in rewards.values())
    assert all(type(v) is bool for v in [*terminations.values(), *truncations.values()])
    first[2]["__all__"] = True                  # RLlib writes into the dicts
    assert "__all__" not in env.step(actions)[2]


def test_a_slid_attacker_is_judged_on_the_path_it_took():
    """At 1000 map units per second an attacker runs into the right wall and slides up it,
    through the target, to a defender: the chord from start to end misses the target and
    passes the defender, but the path entered the target first."""
    from reachavoid_env.world import World

    data = {"name": "slide", "map": {"domain": [0.0, 10.0, 0.0, 10.0], "obstacles": [],
                                     "target": {"type": "box", "min": [9.5, 5.6],
                                                "max": [10.0, 6.1]}},
            "players": {"attacker_speed": 1000.0, "defender_speed": 1.0,
                        "capture_radius": 0.1, "attackers": [[7.0, 5.0]],
                        "defenders": [[1.0, 1.0]]},
            "sim": {"dt": 0.005, "max_steps": 10, "player_radius": 0.05}}
    aim = np.array([1.0, 0.3]) / np.hypot(1.0, 0.3)
    probe = Scenario.from_dict(data, name="slide")
    end = World(probe.map, probe.player_radius, np.array([[7.0, 5.0]]), 1000.0,
                probe.dt).step(aim[None] * 1000.0)[0]
    assert end[0] > 9.9 and end[1] > 6.3     # slid up the wall past the target
    data["players"]["defenders"] = [[float(end[0]) - 0.05, float(end[1])]]
    env = start(Scenario.from_dict(data, name="slide"), [[7.0, 5.0]], data["players"]["defenders"])
    *_, infos = env.step({"attacker_0": aim.astype(np.float32),
                          "defender_0": np.zeros(2, dtype=np.float32)})
    assert infos["attacker_0"]["arrived"] == 1 and infos["attacker_0"]["captured"] == 0
    stop = env.game_state().attacker_positions
    assert env.scenario.map.in_target(stop)[0]   # where the path entered (the chord never does)

"""Env API details: bad actions and options, spaces, seeding, pickling, registry, rendering."""

from __future__ import annotations

import pickle
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pettingzoo
import pytest

import reachavoid_env
from reachavoid_env import (
    AttackerStatus,
    GameState,
    Overlay,
    ReachAvoidEnv,
    ScenarioError,
    builtin_scenario,
)


def still(env: ReachAvoidEnv) -> dict[str, np.ndarray]:
    return {name: np.zeros(2, dtype=np.float32) for name in env.agents}


def rollout(env: ReachAvoidEnv, seed: int, steps: int) -> list:
    """Reset observations, then (obs, rewards, terms, truncs, infos) of every step.

    Attackers act at random (seeded), defenders chase the nearest active attacker.
    """
    obs, infos = env.reset(seed=seed)
    record = [(obs, infos)]
    rng = np.random.default_rng(seed)
    for _ in range(steps):
        if not env.agents:
            break
        state = env.game_state()
        targets = state.attacker_positions[state.active_attackers]
        actions = {}
        for name in env.agents:
            if name.startswith("attacker"):
                actions[name] = rng.uniform(-1, 1, 2).astype(np.float32)
            else:
                me = state.defender_positions[int(name.split("_")[1])]
                nearest = targets[np.argmin(np.linalg.norm(targets - me, axis=1))]
                actions[name] = (10.0 * (nearest - me)).astype(np.float32)
        record.append(env.step(actions))
    return record


def assert_same(one, two) -> None:
    if isinstance(one, dict):
        assert one.keys() == two.keys()
        for key in one:
            assert_same(one[key], two[key])
    elif isinstance(one, (list, tuple)):
        assert len(one) == len(two)
        for a, b in zip(one, two, strict=True):
            assert_same(a, b)
    elif isinstance(one, np.ndarray):
        assert one.dtype == two.dtype and np.array_equal(one, two)
    else:
        assert one == two


def test_package_exports_and_registry():
    assert reachavoid_env.parallel_env is not None and reachavoid_env.raw_env is not None
    par = pettingzoo.make("parallel", "reachavoid/ReachAvoid-v0", scenario="paper_6v2")
    assert isinstance(par, ReachAvoidEnv) and par.num_agents == 0
    assert par.possible_agents == [f"attacker_{i}" for i in range(6)] + ["defender_0",
                                                                          "defender_1"]
    aec = pettingzoo.make("aec", "reachavoid/ReachAvoid-v0", max_cycles=9)
    assert isinstance(aec.unwrapped, ReachAvoidEnv) and aec.unwrapped.max_cycles == 9
    assert str(par) == "reach_avoid_v0"
    assert ReachAvoidEnv.metadata["is_parallelizable"] is True
    assert ReachAvoidEnv.metadata["render_modes"] == ["human", "rgb_array"]


def test_spaces_are_declared_once():
    env = ReachAvoidEnv("paper_8v4")
    for name in env.possible_agents:
        assert env.observation_space(name) is env.observation_space(name)
        assert env.action_space(name) is env.action_space(name)
        assert env.observation_space(name).shape == (7 + 16 + 5 * 11 + 1,)
        assert env.observation_space(name).dtype == np.float32
    assert env.state_space.shape == (36,)
    obs, _ = env.reset(seed=1)
    for name, value in obs.items():
        assert env.observation_space(name).contains(value)
    assert env.state_space.contains(env.state())


def test_nan_and_inf_actions_name_the_agent():
    env = ReachAvoidEnv("paper_2v1")
    env.reset(seed=0)
    for bad in (np.nan, np.inf, -np.inf):
        actions = still(env)
        actions["attacker_1"] = np.array([0.0, bad], dtype=np.float32)
        with pytest.raises(ValueError, match="attacker_1"):
            env.step(actions)


def test_malformed_actions_name_the_agent():
    env = ReachAvoidEnv("paper_2v1")
    env.reset(seed=0)
    for bad in (np.zeros(3), 0.5, "north", [[0.1, 0.2]]):
        actions = still(env)
        actions["defender_0"] = bad
        with pytest.raises(ValueError, match="defender_0"):
            env.step(actions)


def test_unknown_and_missing_agents_are_key_errors():
    env = ReachAvoidEnv("paper_2v1")
    env.reset(seed=0)
    with pytest.raises(KeyError, match="attacker_7"):
        env.step({**still(env), "attacker_7": np.zeros(2)})
    actions = still(env)
    del actions["defender_0"]
    with pytest.raises(KeyError, match="defender_0"):
        env.step(actions)


def test_reset_options_set_the_starts():
    env = ReachAvoidEnv("paper_2v1")
    starts = {"attackers": [[-0.5, 0.5], [0.5, -0.8]], "defenders": [[0.8, 0.8]]}
    obs, _ = env.reset(seed=0, options=starts)
    assert np.array_equal(obs["attacker_1"][:2], np.float32([0.5, -0.8]))
    assert env.scenario.attackers == ((-0.5, 0.5), (0.5, -0.8))
    assert env.game_state().defender_positions.tolist() == [[0.8, 0.8]]
    # Without options the next reset goes back to the scenario's starts.
    env.reset()
    assert env.scenario.attackers == builtin_scenario("paper_2v1").attackers
    # Only one side given: the other keeps the scenario's starts.
    env.reset(options={"defenders": [[0.8, -0.8]], "options": 1})
    assert env.scenario.defenders == ((0.8, -0.8),)
    assert env.scenario.attackers == builtin_scenario("paper_2v1").attackers


@pytest.mark.parametrize(("options", "message"), [
    ({"attackers": [[0.0, 0.0]]}, r"options\['attackers'\]: expected shape \(2, 2\)"),
    ({"defenders": [[np.nan, 0.0]]}, r"options\['defenders'\]\[0\] \(defender_0\)"),
    ({"attackers": [[-0.5, 0.0], [0.0, -0.5]]}, r"inside obstacle 0 \(attacker_1\)"),
    ({"defenders": [[1.5, 0.0]]}, r"outside the domain .* \(defender_0\)"),
    ({"attackers": [[0.7, 0.2], [0.0, 0.8]]}, r"inside the target \(attacker_0\)"),
    ({"attackers": [[-0.5, 0.0], [0.3, -0.25]]}, r"captured by defenders\[0\].*\(attacker_1\)"),
    ({"scenario": builtin_scenario("paper_6v2")}, "has 6 attackers and 2 defenders"),
    ({"scenario": "paper_2v1"}, "expected a Scenario"),
])
def test_bad_reset_options_name_the_player(options, message):
    env = ReachAvoidEnv("paper_2v1")
    with pytest.raises((ValueError, TypeError), match=message):
        env.reset(seed=0, options=options)


def test_reset_errors_carry_the_players_field():
    with pytest.raises(ScenarioError) as info:
        ReachAvoidEnv("paper_2v1").reset(seed=0, options={"attackers": [[-0.5, 0.0], [0.0, -0.5]]})
    assert info.value.field == "players.attackers[1]"


def test_reset_with_another_scenario():
    env = ReachAvoidEnv("paper_2v1")
    other = replace(builtin_scenario("paper_2v1"), capture_radius=0.2)
    env.reset(seed=0, options={"scenario": other})
    assert env.game_state().capture_radius == 0.2
    env.reset(seed=0)
    assert env.game_state().capture_radius == 0.1


def test_constructor_errors():
    with pytest.raises(ValueError, match="render_mode"):
        ReachAvoidEnv(render_mode="ansi")
    with pytest.raises(ValueError, match="max_cycles"):
        ReachAvoidEnv(max_cycles=0)
    with pytest.raises(ScenarioError, match="unknown built-in|no such file"):
        ReachAvoidEnv("paper_3v3")
    with pytest.raises(TypeError, match="scenario"):
        ReachAvoidEnv(scenario=3)
    with pytest.raises(ValueError, match="info_format"):
        ReachAvoidEnv(info_format="json")


def test_random_starts_follow_the_seed():
    scenario = builtin_scenario("paper_6v2").with_players(3, 2)
    env = ReachAvoidEnv(scenario)
    first, _ = env.reset(seed=11)
    again, _ = env.reset(seed=11)
    other, _ = env.reset(seed=12)
    assert_same(first, again)
    assert not np.array_equal(first["attacker_0"], other["attacker_0"])


@pytest.mark.parametrize("scenario", ["paper_8v4", "random_3v2"])
def test_many_steps_are_deterministic(scenario):
    sc = (builtin_scenario("paper_6v2").with_players(3, 2) if scenario == "random_3v2"
          else builtin_scenario(scenario))
    sc = replace(sc, capture_radius=0.25)      # captures happen within the rollout
    one, two = ReachAvoidEnv(sc), ReachAvoidEnv(sc)
    first = rollout(one, seed=4, steps=400)
    assert_same(first, rollout(two, seed=4, steps=400))
    # A reset env replays the same episode as a fresh one.
    assert_same(first, rollout(one, seed=4, steps=400))
    assert len(first) > 20
    assert max(info["captured"] for info in first[-1][4].values()) > 0


def test_pickle_round_trip():
    env = ReachAvoidEnv("paper_6v2", max_cycles=50, shaping=0.5)
    rollout(env, seed=3, steps=10)
    copy = pickle.loads(pickle.dumps(env))
    assert copy.max_cycles == 50 and copy.shaping == 0.5
    assert_same(rollout(env, seed=3, steps=30), rollout(copy, seed=3, steps=30))
    scenario = builtin_scenario("paper_6v2").with_players(3, 2)
    env = ReachAvoidEnv(scenario)
    copy = pickle.loads(pickle.dumps(env))
    assert copy.base_scenario == scenario
    assert_same(rollout(env, seed=5, steps=30), rollout(copy, seed=5, steps=30))


def test_game_state_and_overlay_rendering():
    env = ReachAvoidEnv("paper_2v1", render_mode="rgb_array", render_width=320)
    with pytest.raises(RuntimeError, match="reset"):
        env.game_state()
    env.reset(seed=0)
    state = env.game_state()
    assert isinstance(state, GameState)
    assert state.attacker_positions.tolist() == [[-0.5, 0.0], [0.0, 0.8]]
    assert state.attacker_status == (AttackerStatus.ACTIVE,) * 2
    assert (state.attacker_speed, state.defender_speed, state.capture_radius) == (1.0, 1.5, 0.1)
    plain = env.render()
    env.set_overlay(Overlay(edges=(("defender_0", "attacker_0"),), lines=("edge",)))
    drawn = env.render()
    assert plain.dtype == np.uint8 and plain.shape[2] == 3 and plain.shape[1] == 320
    assert not np.array_equal(plain, drawn)
    env.close()
    env.close()


def test_render_without_mode_warns():
    env = ReachAvoidEnv("paper_2v1")
    env.reset(seed=0)
    with pytest.warns(UserWarning, match="render mode"):
        assert env.render() is None


def test_numeric_infos_have_fixed_integer_keys_and_match_the_readable_ones():
    """What TorchRL needs: every agent's info keys fixed from reset() on, every value an int;
    the readable format carries the same facts."""
    sc = replace(builtin_scenario("paper_6v2"), capture_radius=0.25)
    numeric = rollout(ReachAvoidEnv(sc), seed=4, steps=400)
    readable = rollout(ReachAvoidEnv(sc, info_format="readable"), seed=4, steps=400)
    keys = {name: set(info) for name, info in numeric[0][1].items()}
    assert keys["attacker_0"] == {"captured", "arrived", "status", "captured_by"}
    assert keys["defender_0"] == {"captured", "arrived"}
    captures = 0
    for step, (ours, theirs) in enumerate(zip(numeric, readable, strict=True)):
        infos, readable_infos = ours[-1], theirs[-1]
        for name, info in infos.items():
            assert set(info) == keys[name] and all(type(v) is int for v in info.values())
            if name.startswith("attacker"):
                shown = readable_infos[name]
                assert AttackerStatus.from_code(info["status"]) is shown["status"]
                captor = f"defender_{info['captured_by']}" if info["captured_by"] >= 0 else None
                assert shown.get("captured_by") == captor
                captures += captor is not None and step > 0
            else:
                assert info == readable_infos[name]
    assert captures > 0


def test_status_codes_round_trip():
    assert [status.code for status in AttackerStatus] == [0, 1, 2]
    for status in AttackerStatus:
        assert AttackerStatus.from_code(status.code) is status
    for bad in (-1, 3, 1.5, True):
        with pytest.raises(ValueError, match="status code"):
            AttackerStatus.from_code(bad)


def test_core_packages_import_no_rl_library():
    """The integrations import their RL library; the env and policies packages do not."""
    code = ("import sys, reachavoid_env, reachavoid_env.integrations, policies; "
            "print(sorted(set(sys.modules) & {'torch', 'torchrl', 'tensordict', 'supersuit', "
            "'stable_baselines3', 'benchmarl', 'ray'}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120)
    assert out.stdout.strip() == "[]"


def test_step_before_reset_is_an_error():
    env = reachavoid_env.parallel_env(scenario="paper_2v1")
    with pytest.raises(RuntimeError, match="call reset"):
        env.step({})


def test_unpickled_env_must_be_reset():
    env = reachavoid_env.parallel_env(scenario="paper_2v1")
    env.reset(seed=0)
    env.step({agent: np.zeros(2, np.float32) for agent in env.agents})
    copy = pickle.loads(pickle.dumps(env))
    with pytest.raises(RuntimeError, match="unpickled env is not reset"):
        copy.step({agent: np.zeros(2, np.float32) for agent in env.agents})


def test_reset_options_are_checked():
    env = reachavoid_env.parallel_env(scenario="paper_2v1")
    with pytest.raises(ValueError, match=r"options\['starts'\] is not an option"):
        env.reset(options={"starts": [[0.0, 0.0]]})
    with pytest.raises(TypeError, match="options must be a dict"):
        env.reset(options=[1])
    env.reset(options={"options": 1})


def test_huge_actions_are_scaled_not_lost():
    scenario = builtin_scenario("paper_1v1")
    env = reachavoid_env.parallel_env(scenario=scenario)
    env.reset(seed=0)
    before = env.unwrapped.game_state().attacker_positions[0].copy()
    env.step({"attacker_0": np.array([1e200, 1e200]), "defender_0": np.zeros(2)})
    moved = env.unwrapped.game_state().attacker_positions[0] - before
    expected = scenario.attacker_speed * scenario.dt
    assert np.linalg.norm(moved) == pytest.approx(expected, rel=1e-6)
    assert moved[0] == pytest.approx(moved[1])


def test_actions_are_refused_clearly():
    env = reachavoid_env.parallel_env(scenario="paper_2v1", render_mode="rgb_array")
    with pytest.raises(RuntimeError, match="render: call reset"):
        env.render()
    env.reset(seed=0)
    for actions in (None, [np.zeros(2)] * 3):
        with pytest.raises(TypeError, match="actions must be a dict"):
            env.step(actions)
    with pytest.raises(ValueError, match="complex"):
        env.step({agent: np.array([1 + 1j, 0.0]) for agent in env.agents})


@pytest.mark.parametrize("action", [["0.5", "0"], [True, False], np.array([True, False]),
                                    np.array(["0.5", "0"]), "05", [1, "0"]])
def test_actions_are_real_two_vectors_only(action):
    env = reachavoid_env.parallel_env(scenario="paper_2v1")
    env.reset(seed=0)
    actions = {agent: np.zeros(2) for agent in env.agents}
    actions["attacker_0"] = action
    with pytest.raises(ValueError, match="action for attacker_0: expected a 2-vector of real"):
        env.step(actions)
    for fine in ([0.5, 0], (1, 0.0), np.array([0.5, 0], dtype=np.float32), [np.float32(1), 0]):
        actions["attacker_0"] = fine
        env.step(actions)

"""The training wrappers: PettingZoo and Gymnasium conformance, scripted play, pickling,
vector envs."""

from __future__ import annotations

import pickle
from dataclasses import replace

import gymnasium
import numpy as np
import pytest
from checks import checked
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import api_test, parallel_api_test
from pettingzoo.utils import parallel_to_aec

from policies import GreedyDefender, HJDefenderPolicy, IdleDefender, StraightAttacker
from reachavoid_env import AttackerStatus, builtin_scenario
from reachavoid_env.environment import ReachAvoidEnv
from reachavoid_env.wrappers import AttackerParallelEnv, SingleAttackerEnv, build_policy

# Large capture discs and long steps: random play captures and arrives within the checks'
# episodes, so agents are removed and some episodes end early.
CROWDED = replace(builtin_scenario("paper_2v1").with_players(4, 3), capture_radius=0.3,
                  dt=0.05)
CROWDED_PARAM = pytest.param(CROWDED, id="crowded_4v3")


@pytest.fixture
def hj(coarse_tubes):
    """A fresh HJ + MIP defender policy on the paper map's coarse tubes (25^4, 13^6)."""
    return HJDefenderPolicy(*coarse_tubes)


def reference_defenders(scenario, coarse_tubes):
    """HJ defenders where the tubes fit the scenario (the paper's map, speeds and capture
    radius), greedy ones otherwise."""
    return GreedyDefender() if scenario is CROWDED else HJDefenderPolicy(*coarse_tubes)


def greedy_factory(scenario):
    return GreedyDefender()


def straight_factory(scenario):
    return StraightAttacker()


class Recorder:
    """A defender policy that stands still and records what it was given."""

    def __init__(self) -> None:
        self.scenarios = []
        self.steps = []

    def reset(self, scenario) -> None:
        self.scenarios.append(scenario)

    def act(self, state):
        self.steps.append(state.step)
        return {name: np.zeros(2, dtype=np.float32) for name in state.defender_names}


# ------------------------------------------------------------------ parallel env
@pytest.mark.parametrize("scenario", ["paper_2v1", "paper_6v2", CROWDED_PARAM])
@pytest.mark.parametrize("repeat", [1, 3])
def test_parallel_api(scenario, repeat, coarse_tubes):
    env = AttackerParallelEnv(reference_defenders(scenario, coarse_tubes), scenario=scenario,
                              action_repeat=repeat)
    checked(parallel_api_test, env, num_cycles=300)


@pytest.mark.parametrize("scenario", ["paper_6v2", CROWDED_PARAM])
def test_aec_api(scenario, coarse_tubes):
    env = parallel_to_aec(AttackerParallelEnv(reference_defenders(scenario, coarse_tubes),
                                              scenario=scenario, max_cycles=120))
    checked(api_test, env, num_cycles=120)


def test_parallel_env_has_attackers_only_and_their_part_of_the_game(coarse_tubes):
    env = AttackerParallelEnv(HJDefenderPolicy(*coarse_tubes), scenario="paper_6v2",
                              shaping=0.5)
    game = ReachAvoidEnv(scenario="paper_6v2", shaping=0.5)
    assert env.possible_agents == [f"attacker_{i}" for i in range(6)]
    obs, infos = env.reset(seed=3)
    game_obs, game_infos = game.reset(seed=3)
    for name in env.possible_agents:
        np.testing.assert_array_equal(obs[name], game_obs[name])
        assert infos[name] == game_infos[name]
        assert env.observation_space(name) is env.observation_space(name)
    defenders = HJDefenderPolicy(*coarse_tubes)
    defenders.reset(game.scenario)
    rng = np.random.default_rng(0)
    while env.agents:
        actions = {name: rng.uniform(-1, 1, 2).astype(np.float32) for name in env.agents}
        expected = game.step({**actions, **defenders.act(game.game_state())})
        got = env.step(actions)
        for mine, theirs in zip(got, expected, strict=True):
            assert set(mine) == set(theirs) - {f"defender_{j}" for j in range(2)}
            for name in mine:
                if isinstance(mine[name], np.ndarray):
                    np.testing.assert_array_equal(mine[name], theirs[name])
                else:
                    assert mine[name] == theirs[name]
        assert env.agents == [name for name in game.agents if name.startswith("attacker")]
    np.testing.assert_array_equal(env.state(), game.state())


def test_action_repeat_holds_actions_and_sums_rewards():
    scenario = builtin_scenario("paper_1v1")
    env = AttackerParallelEnv(IdleDefender(), scenario=scenario, shaping=1.0, action_repeat=4)
    env.reset(seed=0)
    start = env.game_state().attacker_positions[0]
    _, rewards, *_ = env.step({"attacker_0": np.array([1.0, 0.0], dtype=np.float32)})
    state = env.game_state()
    assert state.step == 4
    np.testing.assert_allclose(state.attacker_positions[0] - start,
                               [4 * scenario.dt * scenario.attacker_speed, 0.0])
    distance = scenario.map.target_signed_distance
    progress = distance(start[None])[0] - distance(state.attacker_positions[:1])[0]
    assert rewards["attacker_0"] == pytest.approx(progress)


def test_repeat_stops_when_the_last_attacker_leaves():
    env = AttackerParallelEnv(IdleDefender(), scenario="paper_1v1", action_repeat=50)
    env.reset(seed=0, options={"attackers": [[0.55, 0.2]]})
    obs, rewards, terminations, truncations, infos = env.step(
        {"attacker_0": np.array([1.0, 0.0], dtype=np.float32)})
    assert rewards == {"attacker_0": 1.0}
    assert terminations == {"attacker_0": True} and truncations == {"attacker_0": False}
    assert infos["attacker_0"]["status"] == AttackerStatus.ARRIVED.code
    assert env.agents == [] and env.game_state().step < 50
    assert env.step({}) == ({}, {}, {}, {}, {})


def test_defender_policy_is_reset_with_the_episode_scenario_and_acts_every_env_step():
    recorder = Recorder()
    env = AttackerParallelEnv(recorder, scenario=CROWDED, action_repeat=2)
    env.reset(seed=5)
    assert recorder.scenarios == [env.game.scenario]
    assert recorder.scenarios[0].attackers is not None  # random starts drawn for the episode
    env.step({name: np.zeros(2, dtype=np.float32) for name in env.agents})
    assert recorder.steps == [0, 1]


def test_scripted_every_holds_scripted_actions_and_redecides_when_a_player_leaves():
    recorder = Recorder()
    env = AttackerParallelEnv(recorder, scenario="paper_2v1", scripted_every=20)
    env.reset(seed=0, options={"attackers": [[0.55, 0.2], [-0.5, 0.0]]})
    for _ in range(55):
        env.step({name: np.array([1.0, 0.0], dtype=np.float32) for name in env.agents})
    arrival = recorder.steps[1]
    assert env.agents == ["attacker_1"] and 0 < arrival < 20
    assert recorder.steps == [0, arrival, arrival + 20, arrival + 40]
    with pytest.raises(ValueError, match="scripted_every"):
        SingleAttackerEnv(recorder, scenario="paper_1v1", scripted_every=0)


def test_parallel_step_errors_name_the_agent():
    env = AttackerParallelEnv(GreedyDefender(), scenario="paper_2v1")
    env.reset(seed=0)
    with pytest.raises(KeyError, match="defender_0"):
        env.step({"attacker_0": np.zeros(2), "attacker_1": np.zeros(2),
                  "defender_0": np.zeros(2)})
    with pytest.raises(KeyError, match="attacker_1"):
        env.step({"attacker_0": np.zeros(2)})
    with pytest.raises(ValueError, match="attacker_1"):
        env.step({"attacker_0": np.zeros(2), "attacker_1": np.array([np.nan, 0.0])})


def test_a_policy_that_leaves_out_a_defender_is_named():
    class Lazy(Recorder):
        def act(self, state):
            return {}

    env = AttackerParallelEnv(Lazy(), scenario="paper_2v1")
    env.reset(seed=0)
    with pytest.raises(KeyError, match="defender_0"):
        env.step({"attacker_0": np.zeros(2), "attacker_1": np.zeros(2)})


# ------------------------------------------------------------------ policy sources
def test_build_policy_takes_policies_and_factories_and_refuses_the_rest():
    scenario = builtin_scenario("paper_2v1")
    policy = GreedyDefender()
    assert build_policy(policy, scenario, "defenders") is policy
    assert isinstance(build_policy(greedy_factory, scenario, "defenders"), GreedyDefender)
    with pytest.raises(TypeError, match="defenders: got the class GreedyDefender"):
        build_policy(GreedyDefender, scenario, "defenders")
    with pytest.raises(TypeError, match="teammates: the factory returned int"):
        build_policy(lambda sc: 3, scenario, "teammates")
    with pytest.raises(TypeError, match="defenders: expected a policy"):
        build_policy("greedy", scenario, "defenders")


# ------------------------------------------------------------------ gymnasium env
@pytest.mark.parametrize("scenario,repeat", [("paper_1v1", 1), ("paper_2v1", 4),
                                             pytest.param(CROWDED, 2, id="crowded_4v3-2")])
def test_gymnasium_check_env(scenario, repeat, coarse_tubes):
    defenders = reference_defenders(scenario, coarse_tubes)
    env = SingleAttackerEnv(defenders, scenario=scenario, teammates=StraightAttacker(),
                            action_repeat=repeat)
    env.spec = gymnasium.envs.registration.EnvSpec(
        "Test-v0", entry_point=SingleAttackerEnv,
        kwargs={"defenders": defenders, "scenario": scenario,
                "teammates": StraightAttacker(), "action_repeat": repeat})
    checked(check_env, env)


def test_learner_is_captured_standing_still_against_hj_defenders(hj):
    env = SingleAttackerEnv(hj, scenario="paper_1v1")
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs) and info["status"] == AttackerStatus.ACTIVE.code
    steps, terminated, truncated = 0, False, False
    while not (terminated or truncated):
        obs, reward, terminated, truncated, info = env.step(np.zeros(2, dtype=np.float32))
        steps += 1
    assert terminated and not truncated and reward == -1.0
    assert info["status"] == AttackerStatus.CAPTURED.code and info["is_success"] is False
    assert info["captured_by"] == 0
    assert steps < env.game.max_cycles
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(2, dtype=np.float32))


def test_learner_arrives_running_at_the_target_past_idle_defenders():
    env = SingleAttackerEnv(IdleDefender(), scenario="paper_2v1", attacker=1,
                            teammates=StraightAttacker(), action_repeat=10)
    env.reset(seed=0, options={"attackers": [[-0.5, 0.0], [0.7, 0.6]]})
    total, terminated = 0.0, False
    while not terminated:
        _, reward, terminated, truncated, info = env.step(np.array([0.0, -1.0], np.float32))
        total += reward
        assert not truncated
    assert total == 1.0 and info["is_success"] is True
    assert env.game_state().attacker_status[0] is AttackerStatus.ACTIVE  # teammate plays on


def test_episode_truncates_after_max_cycles_env_steps_with_the_timeout_reward():
    env = SingleAttackerEnv(IdleDefender(), scenario="paper_1v1", max_cycles=25,
                            action_repeat=10, timeout_reward=-1.0)
    env.reset(seed=0)
    steps = [env.step(np.zeros(2, dtype=np.float32))[1:4] for _ in range(3)]
    assert steps == [(0.0, False, False), (0.0, False, False), (-1.0, False, True)]
    assert env.game_state().step == 25


def test_parallel_timeout_reward_goes_to_attackers_still_in_play():
    env = AttackerParallelEnv(IdleDefender(), scenario="paper_2v1", max_cycles=30,
                              timeout_reward=-0.5, action_repeat=20)
    env.reset(seed=0, options={"attackers": [[0.55, 0.2], [-0.5, 0.0]]})
    _, rewards, terminations, _, _ = env.step(
        {"attacker_0": np.array([1.0, 0.0], np.float32), "attacker_1": np.zeros(2)})
    assert rewards == {"attacker_0": 1.0, "attacker_1": 0.0} and terminations["attacker_0"]
    _, rewards, _, truncations, _ = env.step({"attacker_1": np.zeros(2)})
    assert rewards == {"attacker_1": -0.5} and truncations == {"attacker_1": True}
    with pytest.raises(ValueError, match="timeout_reward"):
        AttackerParallelEnv(IdleDefender(), timeout_reward=float("nan"))


def test_teammates_move_the_other_attackers():
    env = SingleAttackerEnv(IdleDefender(), scenario="paper_2v1", teammates=StraightAttacker())
    env.reset(seed=0)
    before = env.game_state().attacker_positions.copy()
    env.step(np.zeros(2, dtype=np.float32))
    after = env.game_state().attacker_positions
    np.testing.assert_array_equal(after[0], before[0])
    assert np.linalg.norm(after[1] - before[1]) > 0


def test_gymnasium_env_argument_errors():
    with pytest.raises(ValueError, match="teammates: scenario 'paper_2v1' has 2 attackers"):
        SingleAttackerEnv(GreedyDefender(), scenario="paper_2v1")
    with pytest.raises(ValueError, match=r"attacker: must be an attacker index in 0\.\.1"):
        SingleAttackerEnv(GreedyDefender(), scenario="paper_2v1", attacker=2,
                          teammates=StraightAttacker())
    with pytest.raises(ValueError, match="action_repeat"):
        SingleAttackerEnv(GreedyDefender(), scenario="paper_1v1", action_repeat=0)
    env = SingleAttackerEnv(GreedyDefender(), scenario="paper_1v1")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="attacker_0"):
        env.step(np.array([np.inf, 0.0]))


def test_rgb_render_draws_the_defenders_overlay(hj):
    env = SingleAttackerEnv(hj, scenario="paper_1v1", render_mode="rgb_array",
                            render_width=160)
    env.reset(seed=0)
    env.step(np.zeros(2, dtype=np.float32))
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[1] == 160
    assert env.game._overlay.edges == (("defender_0", "attacker_0"),)
    env.close()


# ------------------------------------------------------------------ pickling, vectors
def test_pickled_envs_rebuild_from_their_arguments():
    single = SingleAttackerEnv(greedy_factory, scenario="paper_2v1",
                               teammates=straight_factory, action_repeat=3)
    parallel = AttackerParallelEnv(greedy_factory, scenario="paper_6v2", shaping=0.5,
                                   scripted_every=4)
    for env in (single, parallel):
        copy = pickle.loads(pickle.dumps(env))
        first, second = env.reset(seed=2), copy.reset(seed=2)
        assert repr(first) == repr(second)
    assert copy.game.shaping == 0.5 and copy.scripted_every == 4
    assert pickle.loads(pickle.dumps(single)).action_repeat == 3


@pytest.mark.parametrize("vector", [gymnasium.vector.SyncVectorEnv,
                                    gymnasium.vector.AsyncVectorEnv])
def test_vector_envs(vector):
    def make():
        return SingleAttackerEnv(greedy_factory, scenario="paper_1v1", action_repeat=20)

    envs = vector([make, make])
    try:
        obs, _ = envs.reset(seed=[0, 1])
        assert obs.shape == (2, 29) and obs.dtype == np.float32
        for _ in range(60):
            obs, rewards, terminated, truncated, infos = envs.step(
                np.tile(np.array([1.0, 0.2], dtype=np.float32), (2, 1)))
            assert envs.single_observation_space.contains(obs[0])
        assert rewards.shape == (2,) and terminated.dtype == bool
    finally:
        envs.close()

"""Random starts through every registered id, observations of a GameState, learned
policies (functions of observations, SB3 models) as Policy objects in play and bench,
video speed with action_repeat, and SB3's episode statistics on the SuperSuit chain."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings

import gymnasium
import imageio_ffmpeg
import numpy as np
import pettingzoo
import pytest
from checks import ROOT

import reachavoid_env
from policies import GreedyDefender, IdleDefender
from policies.learned import TRAINING_ATTRIBUTE, ObservationPolicy, load_sb3, training_record
from policies.registry import make_policy, resolve
from reachavoid import cli
from reachavoid.rollout import run_episode
from reachavoid.training.views import make_attackers_parallel_env
from reachavoid_env import builtin_names, builtin_scenario
from reachavoid_env.observations import GLOBAL, ObservationConfig, observe
from reachavoid_env.training_ids import gym_id, pettingzoo_id
from reachavoid_env.video import RecordEpisode


# ------------------------------------------------------------------ random starts
def _starts(env, seed):
    env.reset(seed=seed)
    state = env.unwrapped.game_state()
    return np.concatenate([state.attacker_positions, state.defender_positions])


@pytest.mark.parametrize("name", builtin_names())
def test_random_start_ids_draw_from_the_seed(name):
    """Every built-in's random-start ids, and the plain ids with ``starts="random"``: two
    seeds give two starts, one seed the same start, with the scenario's player counts."""
    scenario = builtin_scenario(name)
    envs = [gymnasium.make(gym_id(name, "random"), defenders="idle"),
            gymnasium.make(gym_id(name), defenders="idle", starts="random"),
            gymnasium.make("reachavoid/Attacker-v1", scenario=name, defenders="idle",
                           starts="random"),
            pettingzoo.make("parallel", pettingzoo_id(name, "random"), defenders="idle"),
            pettingzoo.make("parallel", "reachavoid/Attackers-v1", scenario=name,
                            defenders="idle", starts="random"),
            pettingzoo.make("parallel", "reachavoid/ReachAvoid-v0", scenario=name,
                            starts="random")]
    for env in envs:
        one, other, again = _starts(env, 1), _starts(env, 2), _starts(env, 1)
        assert one.shape == (scenario.num_attackers + scenario.num_defenders, 2)
        assert not np.allclose(one, other)
        np.testing.assert_array_equal(one, again)
        env.close()


def test_scenario_starts_stay_the_default_and_bad_starts_are_named():
    fixed = gymnasium.make(gym_id("paper_2v1"), defenders="idle")
    np.testing.assert_array_equal(_starts(fixed, 1), _starts(fixed, 2))
    env = reachavoid_env.parallel_env(scenario="paper_6v2", starts="random")
    assert env.base_scenario.attackers is None and env.base_scenario.num_attackers == 6
    with pytest.raises(ValueError, match="starts: 'everywhere' is not one of"):
        reachavoid_env.parallel_env(scenario="paper_6v2", starts="everywhere")


# ------------------------------------------------------------------ observations
@pytest.mark.parametrize("config", [GLOBAL, ObservationConfig()], ids=["v0", "v1"])
def test_observe_is_the_env_observation_bit_for_bit(config):
    """Along a game with captures and arrivals, ``observe(game_state())`` gives what the
    env returned to every agent it returned something to."""
    env = reachavoid_env.parallel_env(scenario="paper_6v2", starts="random",
                                      observation=config)
    observations, _ = env.reset(seed=3)
    rng = np.random.default_rng(0)
    defenders = GreedyDefender()
    defenders.reset(env.scenario)
    left = 0
    while env.agents:
        seen = observe(env.game_state(), env.scenario.map, config, env.max_cycles)
        for name, value in observations.items():
            np.testing.assert_array_equal(seen[name], value)
        actions = {**defenders.act(env.game_state()),
                   **{f"attacker_{i}": rng.uniform(-1, 1, 2) for i in range(6)}}
        observations, *_ = env.step({name: actions[name] for name in env.agents})
        left = max(left, 8 - len(env.agents))
    assert left >= 2                          # the check ran past players leaving


def test_observation_policy_holds_its_actions_for_action_repeat_steps():
    calls = []

    def predict(batch):
        calls.append(batch.copy())
        return np.tile([1.0, 0.0], (len(batch), 1))

    policy = ObservationPolicy(predict, action_repeat=4)
    env = reachavoid_env.parallel_env(scenario="paper_2v1")
    result = run_episode(env, policy, IdleDefender(), seed=0)
    assert len(calls) == -(-result.steps // 4)
    assert calls[0].shape == (2, 7 + 16 + 5 * 2 + 1) and calls[0].dtype == np.float32
    with pytest.raises(ValueError, match="observes 11 numbers; 'paper_6v2' has 6 attackers"):
        ObservationPolicy(predict, observation_size=11).reset(builtin_scenario("paper_6v2"))


def test_full_speed_actions_are_headings():
    """``full_speed``: every action is scaled to length 1 (a zero action stays zero), where
    the default only clips to ``[-1, 1]``: a network that hesitates between two headings
    (a short mean) still runs at full speed."""
    def predict(batch):
        return np.tile([[0.3, 0.4], [0.0, 0.0]], (len(batch) // 2, 1))

    scenario = builtin_scenario("paper_2v1")
    env = reachavoid_env.parallel_env(scenario=scenario)
    env.reset(seed=0)
    state = env.game_state()
    for full_speed, expected in ((True, [0.6, 0.8]), (False, [0.3, 0.4])):
        policy = ObservationPolicy(predict, full_speed=full_speed)
        policy.reset(scenario)
        actions = policy.act(state)
        np.testing.assert_allclose(actions["attacker_0"], expected, rtol=1e-6)
        np.testing.assert_array_equal(actions["attacker_1"], [0.0, 0.0])
        assert actions["attacker_0"].dtype == np.float32


# ------------------------------------------------------------------ SB3 models
@pytest.fixture(scope="module")
def model_path(tmp_path_factory):
    """A 2,000-step PPO attacker on paper_1v1 random starts, saved as the examples do."""
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    from reachavoid.training.views import make_attacker_env

    env = make_attacker_env("paper_1v1", defenders="greedy", starts="random",
                            action_repeat=10, shaping=1.0, timeout_reward=-1.0)
    model = PPO("MlpPolicy", env, n_steps=500, batch_size=100, seed=0, device="cpu")
    model.learn(2_000)
    setattr(model, TRAINING_ATTRIBUTE, training_record(env.game.observation, action_repeat=10,
                                                          scenario="paper_1v1"))
    path = tmp_path_factory.mktemp("model") / "model.zip"
    model.save(path)
    return path


def test_a_model_plays_as_it_was_trained(model_path):
    """The model as a Policy in ``run_episode`` on the full game plays the same episode as
    the model on the observations of the training env (decisions every 10 steps)."""
    from stable_baselines3 import PPO

    policy = load_sb3(model_path)
    assert policy.action_repeat == 10 and not policy.full_speed
    model = PPO.load(model_path, device="cpu")
    training = make_attackers_parallel_env("paper_1v1", defenders=GreedyDefender(),
                                           starts="random", action_repeat=10)
    game = reachavoid_env.parallel_env(scenario="paper_1v1", starts="random")
    for seed in range(3):
        observations, _ = training.reset(seed=seed)
        while training.agents:
            observations, *_ = training.step(
                {"attacker_0": model.predict(observations["attacker_0"], deterministic=True)[0]})
        result = run_episode(game, policy, GreedyDefender(), seed=seed)
        final = training.game_state()
        assert result.steps == final.step
        np.testing.assert_array_equal(game.game_state().attacker_positions,
                                      final.attacker_positions)


def test_sb3_names_go_through_the_registry(model_path):
    entry = resolve("attackers", f"sb3:{model_path}")
    assert entry.options == {"action_repeat", "algorithm"}
    policy = make_policy("attackers", f"sb3:{model_path}", builtin_scenario("paper_1v1"),
                         action_repeat=2)
    assert isinstance(policy, ObservationPolicy) and policy.action_repeat == 2
    with pytest.raises(ValueError, match="observes 29 numbers"):
        make_policy("attackers", f"sb3:{model_path}", builtin_scenario("paper_2v1"))
    with pytest.raises(ValueError, match="attackers: model 'nowhere.zip' .* is not a file"):
        resolve("attackers", "sb3:nowhere.zip")


def test_play_and_bench_take_a_model(model_path, tmp_path, capsys):
    video = tmp_path / "x.mp4"
    spec = f"sb3:{model_path}"
    assert cli.main(["play", "--scenario", "paper_1v1", "--attackers", spec, "--defenders",
                     "greedy", "--video", str(video), "--json"]) == 0
    played = json.loads(capsys.readouterr().out)
    assert played["attackers"] == spec and played["steps"] > 0
    frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(video))
    assert frames == played["steps"] + 1
    assert cli.main(["bench", "--attackers", spec, "--config", "1v1", "--defenders",
                     "greedy,idle", "--episodes", "3", "--json"]) == 0
    bench = json.loads(capsys.readouterr().out)
    (cell,) = bench["cells"]
    assert cell["attackers"] == spec
    assert [m["label"] for m in cell["methods"]] == ["greedy", "idle"]
    assert cli.main(["play", "--scenario", "paper_2v1", "--attackers", spec]) == 2
    assert "observes 29 numbers" in capsys.readouterr().err
    assert cli.main(["bench", "--attackers", spec, "--config", "2v1", "--defenders",
                     "greedy", "--episodes", "2", "--backend", "process", "--workers", "2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "observes 29 numbers" in err, err   # one line, no traceback
    assert cli.main(["play", "--attackers", "sb3:nowhere.zip"]) == 2
    assert "'nowhere.zip' (in 'sb3:nowhere.zip') is not a file" in capsys.readouterr().err


def test_the_observation_loop_plays_a_model_on_random_starts(model_path, tmp_path):
    from checks import run_example

    lines = run_example("multi_agent_loop", "--scenario", "paper_1v1", "--defenders", "greedy",
                        "--policy", str(model_path), "--episodes", "2", "--video",
                        str(tmp_path / "loop.mp4"))
    episodes = [line.split(": ", 1)[1] for line in lines if line.startswith("episode ")]
    assert len(episodes) == 2 and episodes[0] != episodes[1]   # two seeds, two random starts
    assert (tmp_path / "loop.mp4").stat().st_size > 0


# ------------------------------------------------------------------ conventions
@pytest.mark.parametrize("repeat", [1, 10])
def test_video_of_an_attacker_env_lasts_the_game_time(repeat, tmp_path):
    env = make_attackers_parallel_env("paper_2v1", defenders="greedy", action_repeat=repeat,
                                      render_mode="rgb_array", render_width=160)
    assert env.metadata["render_fps"] == pytest.approx(1 / (0.005 * repeat))
    path = tmp_path / "episode.mp4"
    with RecordEpisode(env, path) as recorded:
        recorded.reset(seed=0)
        while recorded.agents:
            recorded.step({name: np.array([1.0, 0.0]) for name in recorded.agents})
    game_time = env.game_state().time
    frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(path))
    fps = env.metadata["render_fps"]
    # one frame per agent step after the first: the video lasts the game time (+ 1 frame)
    assert frames / fps == pytest.approx(game_time + 1 / fps, abs=repeat * 0.005)


def test_sb3_vec_env_fills_the_episode_buffer_without_warnings():
    pytest.importorskip("supersuit")
    from stable_baselines3 import PPO

    from reachavoid_env.integrations.supersuit import sb3_vec_env

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        envs = sb3_vec_env(make_attackers_parallel_env(
            builtin_scenario("paper_2v1"), defenders="greedy", starts="random",
            max_cycles=20), copies=2)
        model = PPO("MlpPolicy", envs, n_steps=32, batch_size=64, seed=0, device="cpu")
        model.learn(128)
    assert len(model.ep_info_buffer) >= 4
    assert {"r", "l", "t"} <= set(model.ep_info_buffer[0])


@pytest.mark.parametrize("name", sorted(p.stem for p in (ROOT / "examples").glob("*.py")))
def test_every_example_answers_help_with_its_defaults(name):
    result = subprocess.run([sys.executable, f"examples/{name}.py", "--help"], cwd=ROOT,
                            capture_output=True, text=True, timeout=600)
    if "ModuleNotFoundError" in result.stderr:      # rllib / benchmarl live in their own venv
        pytest.skip(result.stderr.strip().splitlines()[-1])
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("usage:") and "Traceback" not in result.stderr
    if name == "train_attacker_sb3":    # what docs/training.md's recipe says
        for default in ("paper_1v1", "150000", "--action-repeat ACTION_REPEAT",
                        "(default: 10)", "(default: 200)"):
            assert default in " ".join(result.stdout.split()), default

def test_one_attacker_needs_no_2v1_tube():
    """A 1 vs 1 scenario's HJ defenders solve the 1 vs 1 tube only."""
    import os
    from pathlib import Path

    from policies import HJDefenderPolicy

    defenders = HJDefenderPolicy.for_scenario(builtin_scenario("paper_1v1"), grid1=11,
                                              grid2=6, progress=False)
    assert defenders.vf21 is None
    cache = Path(os.environ["REACHAVOID_CACHE_DIR"])
    assert not list(cache.glob("2v1-6-*"))
    env = reachavoid_env.parallel_env(scenario="paper_1v1", starts="random")
    result = run_episode(env, ObservationPolicy(lambda b: np.tile([1.0, 0.0], (len(b), 1))),
                         defenders, seed=0)
    assert result.captured_count + result.arrived_count <= 1
    with pytest.raises(ValueError, match="vf21: 'paper_2v1' has 2 attackers"):
        defenders.reset(builtin_scenario("paper_2v1"))

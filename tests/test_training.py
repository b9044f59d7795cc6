"""Named training envs, their registry ids, the examples, and a PPO smoke run."""

from __future__ import annotations

import json
import pickle
import re
import subprocess
import sys
import warnings

import gymnasium
import numpy as np
import pettingzoo
import pytest
from checks import ROOT, run_example
from gymnasium.utils.env_checker import check_env

from policies import (
    GreedyDefender,
    HJDefenderPolicy,
    IdleDefender,
    RandomAttacker,
    StraightAttacker,
)
from policies.registry import ATTACKERS, DEFENDERS, PolicySpec
from reachavoid.training.views import (
    attacker_factory,
    defender_factory,
    make_attacker_env,
    make_attackers_parallel_env,
)
from reachavoid_env import builtin_names, builtin_scenario
from reachavoid_env.training_ids import GYM_ID, PETTINGZOO_ID, gym_id
from reachavoid_env.wrappers import AttackerParallelEnv, SingleAttackerEnv

# Tubes coarse enough to solve in seconds (conftest.py points the cache at a throwaway
# folder, so each grid is solved once per test session).
COARSE = {"grid1": 11, "grid2": 8, "progress": False}


# ------------------------------------------------------------------ named policies
def test_factories_build_the_named_policies_and_pickle():
    scenario = builtin_scenario("paper_2v1")
    assert isinstance(defender_factory("greedy")(scenario), GreedyDefender)
    assert isinstance(defender_factory("idle")(scenario), IdleDefender)
    assert isinstance(attacker_factory("straight")(scenario), StraightAttacker)
    factory = attacker_factory("random", seed=3, hold=0.5)
    assert factory.options == (("hold", 0.5), ("seed", 3))
    copy = pickle.loads(pickle.dumps(factory))
    assert copy == factory
    built = copy(scenario)
    assert isinstance(built, RandomAttacker) and built.hold == 0.5


def test_unknown_names_list_the_choices():
    with pytest.raises(ValueError, match=r"defenders: unknown policy 'hjj' \(choices: hj, "):
        defender_factory("hjj")
    with pytest.raises(ValueError, match="attackers: unknown policy"):
        make_attacker_env("paper_2v1", defenders="greedy", teammates="nobody")
    with pytest.raises(ValueError, match="side"):
        PolicySpec("referees", "greedy")
    assert set(DEFENDERS) >= {"hj", "matching", "greedy", "idle"}
    assert set(ATTACKERS) >= {"shortest-path", "straight", "random", "hj"}


def test_options_go_with_names_only():
    with pytest.raises(ValueError, match="defender_options: only used with a policy name"):
        make_attacker_env("paper_1v1", defenders=GreedyDefender(),
                          defender_options={"grid1": 21})
    env = make_attacker_env("paper_2v1", defenders=GreedyDefender(),
                            teammates=lambda scenario: StraightAttacker())
    assert isinstance(env.teammates, StraightAttacker)


def test_defaults_are_hj_defenders_and_shortest_path_teammates():
    assert defender_factory().source == "hj"
    assert attacker_factory().source == "shortest-path"
    env = make_attacker_env("paper_2v1", defenders="greedy")
    assert type(env.teammates).__name__ == "ShortestPathAttacker"


def test_hj_defenders_by_name():
    env = make_attackers_parallel_env("paper_2v1", defender_options=COARSE)
    assert isinstance(env.defenders, HJDefenderPolicy)
    assert env.defenders.vf11.grid.shape == (11,) * 4
    env.reset(seed=0)
    env.step({name: np.zeros(2, dtype=np.float32) for name in env.agents})
    assert all(d.startswith("defender_") and a.startswith("attacker_")
               for d, a in env.defenders.assignment)
    assert env.game_state().defender_positions[0].tolist() != [0.3, -0.3]


# ------------------------------------------------------------------ registry ids
def test_gymnasium_ids_are_registered_for_every_builtin():
    assert GYM_ID in gymnasium.registry
    for name in builtin_names():
        for starts in ("scenario", "random"):
            spec = gymnasium.spec(gym_id(name, starts))
            assert spec.kwargs == {"scenario": name, "starts": starts}
            assert spec.entry_point == "reachavoid.training.views:make_attacker_env"
    assert gym_id("paper_6v2", "random") == "reachavoid/Attacker-paper_6v2-random-v1"


def test_check_env_through_the_registry():
    env = gymnasium.make(gym_id("paper_2v1"), defender_options=COARSE, action_repeat=5)
    inner = env.unwrapped
    assert isinstance(inner, SingleAttackerEnv) and inner.action_repeat == 5
    assert isinstance(inner.defenders, HJDefenderPolicy)
    assert env.observation_space.shape == (34,)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(inner)  # with a spec, so the other render mode is made and checked too
    assert [str(w.message) for w in caught if w.category is not DeprecationWarning] == []


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_make_vec(mode):
    envs = gymnasium.make_vec(gym_id("paper_1v1"), num_envs=2, vectorization_mode=mode,
                              defender_options=COARSE, action_repeat=25)
    try:
        obs, _ = envs.reset(seed=0)
        assert obs.shape == (2, 29)
        finished = 0
        for _ in range(50):
            obs, rewards, terminated, truncated, infos = envs.step(
                np.zeros((2, 2), dtype=np.float32))
            finished += int((terminated | truncated).sum())
        assert finished >= 2  # standing still, each env's attacker is caught at least once
        assert envs.call("defenders")[0].vf21 is None   # one attacker: no 2 vs 1 tube
    finally:
        envs.close()


def test_module_colon_id_loads_the_ids_in_a_fresh_interpreter():
    code = ("import gymnasium; env = gymnasium.make("
            "'reachavoid_env:reachavoid/Attacker-paper_1v1-v0', defenders='greedy'); "
            "print(env.reset(seed=0)[0].shape)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, timeout=120, check=True)
    assert done.stdout.strip() == "(8,)"


@pytest.mark.parametrize("first", ["reachavoid_env", "gymnasium"])
def test_importing_the_env_registers_the_training_ids(first):
    """No ``import policies`` first: ``reachavoid_env`` registers the ids (by string) when
    Gymnasium is imported, before or after it."""
    second = {"reachavoid_env": "gymnasium", "gymnasium": "reachavoid_env"}[first]
    code = (f"import sys, {first}, {second}; import gymnasium; "
            "assert 'policies' not in sys.modules; env = gymnasium.make("
            "'reachavoid/Attacker-paper_1v1-random-v1', defenders='greedy'); "
            "print(env.reset(seed=0)[0].shape)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, timeout=120, check=True)
    assert done.stdout.strip() == "(29,)"


def test_pettingzoo_id():
    env = pettingzoo.make("parallel", PETTINGZOO_ID, scenario="paper_6v2", defenders="greedy")
    assert isinstance(env, AttackerParallelEnv)
    assert env.possible_agents == [f"attacker_{i}" for i in range(6)]


# ------------------------------------------------------------------ examples
def outcome_counts(line: str) -> dict[str, int]:
    """The counts of ``multi_agent_loop``'s line of an episode."""
    return {name: int(count)
            for name, count in re.findall(r"(arrived|captured|timed out) (\d+)", line)}


def test_multi_agent_loop_example():
    lines = run_example("multi_agent_loop", "--scenario", "paper_6v2", "--defenders", "hj",
                        "--grid1", "11", "--grid2", "8", "--episodes", "1")
    (line,) = [line for line in lines if line.startswith("episode 0:")]
    assert sum(outcome_counts(line).values()) == 6      # every attacker's outcome


def test_toward_target_hook_reads_positions_from_observations():
    lines = run_example("multi_agent_loop", "--scenario", "paper_1v1", "--defenders", "idle",
                        "--starts", "scenario", "--episodes", "1")
    (line,) = [line for line in lines if line.startswith("episode 0:")]
    assert outcome_counts(line) == {"arrived": 1, "captured": 0, "timed out": 0}


def test_train_attacker_example_runs_against_hj_defenders(tmp_path):
    pytest.importorskip("stable_baselines3")
    from reachavoid.training import single as train
    report = train.main(["--grid1", "11", "--grid2", "8", "--timesteps", "256", "--envs", "1",
                         "--episodes", "2", "--no-video", "--out", str(tmp_path)])
    assert report["defenders"] == "hj" and report["grids"] == [11, 8]
    for attacker in ("trained", "random", "shortest-path"):
        rates = [report[attacker][f"{outcome}_rate"] for outcome in train.OUTCOMES]
        assert sum(rates) == pytest.approx(1.0)


def test_train_attacker_example_replaces_a_users_model_only_with_force(tmp_path, capsys):
    """Its outputs follow the command's rule, checked before any work; ``--evaluate-only``
    reads no model others can change (a model file is code)."""
    pytest.importorskip("stable_baselines3")
    from reachavoid.training import single as train
    (tmp_path / "model.zip").write_text("mine")
    shared = tmp_path / "shared"
    shared.mkdir()
    (shared / "model.zip").write_bytes(b"PK")
    shared.chmod(0o777)
    quick = ["--defenders", "idle", "--episodes", "1", "--no-video"]
    for argv in ([*quick, "--out", str(tmp_path)],
                 [*quick, "--out", str(tmp_path / "new"), "--evaluate-only",
                  str(shared / "model.zip")], [*quick, "--out", str(tmp_path), "--seed", "-1"]):
        with pytest.raises(SystemExit) as stopped:
            train.main(argv)
        assert stopped.value.code == 2
    errors = capsys.readouterr().err
    assert "model.zip' exists; pass --force" in errors and "a model file is code" in errors
    assert "--seed: must be an integer in [0, " in errors
    assert (tmp_path / "model.zip").read_text() == "mine"
    assert not (tmp_path / "new").exists()
    assert train.parse_args([*quick, "--out", str(tmp_path), "--force"]).force


def test_train_attacker_example_beats_random(tmp_path):
    """PPO smoke run (a few thousand steps) through the recipe the example runs. The defenders
    stand still, so that so short a run learns something a test can check."""
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    from reachavoid.training import single as train
    report = train.main(["--defenders", "idle", "--timesteps", "8192", "--envs", "2",
                         "--timeout-reward", "0", "--episodes", "10", "--seed", "0",
                         "--out", str(tmp_path)])
    assert report["trained"]["arrived_rate"] > report["random"]["arrived_rate"]
    assert json.loads((tmp_path / "report.json").read_text()) == report
    assert (tmp_path / "trained.mp4").stat().st_size > 0
    model = PPO.load(tmp_path / "model.zip", device="cpu")
    assert model.observation_space.shape == (29,)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["curve.csv", "model.zip",
                                                          "report.json", "trained.mp4"]

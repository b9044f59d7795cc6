"""RLlib (rllib extra, its own virtual environment: ray[rllib] pins gymnasium): PPO on the
attacker-only env, one policy shared by every attacker, HJ defenders on coarse tubes; the
example as a command."""

from __future__ import annotations

import math
import re

import pytest

pytest.importorskip("ray.rllib")

from checks import run_example  # noqa: E402

from reachavoid.training.rllib import POLICY, ppo_config, train  # noqa: E402


def test_ppo_iteration_on_the_attackers_against_hj_defenders():
    config = ppo_config("paper_2v1", "hj", {"grid1": 25, "grid2": 13, "progress": False},
                        train_batch_size=200)
    results = list(train(config, iterations=1))
    assert len(results) == 1
    result = results[0]
    sampled = result["env_runners"]["num_agent_steps_sampled_lifetime"]
    assert set(sampled) <= {"attacker_0", "attacker_1"} and sum(sampled.values()) >= 200
    # One policy for every attacker: the only module trained is "attacker".
    assert POLICY == "attacker"
    assert set(result["learners"]) - {"__all_modules__"} == {"attacker"}
    attacker = result["learners"]["attacker"]
    for key in ("policy_loss", "vf_loss", "total_loss", "entropy"):
        assert math.isfinite(attacker[key])
    assert attacker["num_module_steps_trained"] > 0
    returns = result["env_runners"]["agent_episode_returns_mean"]
    assert set(returns) <= {"attacker_0", "attacker_1"} and returns


def test_the_example_prints_an_iteration():
    lines = run_example("rllib_config", "--scenario", "paper_2v1", "--defenders", "greedy",
                        "--iterations", "1", "--batch", "200")
    printed = [line for line in lines if line.startswith("iteration ")]
    assert len(printed) == 1
    steps = re.fullmatch(r"iteration 0: episode return mean \S+, ([\d.]+) agent steps",
                         printed[0])
    assert steps and float(steps[1]) > 0, lines

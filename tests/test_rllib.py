"""RLlib (rllib extra, its own virtual environment: ray[rllib] pins gymnasium): PPO on the
attacker-only env, one policy shared by every attacker, HJ defenders on coarse tubes."""

from __future__ import annotations

import math

import pytest

pytest.importorskip("ray.rllib")

from checks import example  # noqa: E402


def test_ppo_iteration_on_the_attackers_against_hj_defenders():
    rllib = example("rllib_config")
    results = rllib.main(["--scenario", "paper_2v1", "--defenders", "hj", "--grid1", "25",
                          "--grid2", "13", "--iterations", "1", "--batch", "200"])
    result = results[0]
    sampled = result["env_runners"]["num_agent_steps_sampled_lifetime"]
    assert set(sampled) <= {"attacker_0", "attacker_1"} and sum(sampled.values()) >= 200
    # One policy for every attacker: the only module trained is "attacker".
    assert set(result["learners"]) - {"__all_modules__"} == {"attacker"}
    attacker = result["learners"]["attacker"]
    for key in ("policy_loss", "vf_loss", "total_loss", "entropy"):
        assert math.isfinite(attacker[key])
    assert attacker["num_module_steps_trained"] > 0
    returns = result["env_runners"]["agent_episode_returns_mean"]
    assert set(returns) <= {"attacker_0", "attacker_1"} and returns

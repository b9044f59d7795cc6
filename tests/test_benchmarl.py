"""BenchMARL (benchmarl extra, its own virtual environment: it pins torchrl < 0.12): the task
class and a MAPPO experiment of a few thousand frames."""

from __future__ import annotations

import math

import pytest

pytest.importorskip("benchmarl")

from checks import example  # noqa: E402

from reachavoid_env.integrations.benchmarl import ReachAvoidTask  # noqa: E402


def test_task_makes_the_game_with_role_groups_and_state():
    task = ReachAvoidTask.REACH_AVOID.get_task({"scenario": "paper_2v1", "max_cycles": 50})
    env = task.get_env_fun(num_envs=1, continuous_actions=True, seed=0, device="cpu")()
    assert task.group_map(env) == {"attacker": ["attacker_0", "attacker_1"],
                                   "defender": ["defender_0"]}
    assert task.max_steps(env) == 50
    assert task.state_spec(env)["state"].shape == (9,)
    assert task.observation_spec(env)["attacker", "observation"].shape == (2, 34)
    rollout = env.rollout(60, break_when_any_done=False)
    assert rollout["next", "done"].squeeze(-1).nonzero().flatten().tolist() == [49]


def test_mappo_experiment_runs_a_few_thousand_frames(tmp_path):
    mappo = example("benchmarl_mappo")
    experiment, rows = mappo.main(["--frames", "2000", "--batch", "1000", "--out",
                                   str(tmp_path)])
    assert experiment.total_frames == 2000 and experiment.n_iters_performed == 2
    assert sorted(row["group"] for row in rows) == ["attacker", "attacker", "defender",
                                                    "defender"]
    for row in rows:
        for key in ("loss_objective", "loss_critic"):
            assert math.isfinite(row[key])
    assert any(tmp_path.iterdir())        # BenchMARL's logs

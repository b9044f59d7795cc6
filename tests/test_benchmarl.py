"""BenchMARL (benchmarl extra, its own virtual environment: it pins torchrl < 0.12): the task
classes, MAPPO experiments of a few thousand frames and the example as a command."""

from __future__ import annotations

import math
import re
import subprocess
import sys

import pytest

pytest.importorskip("benchmarl")

from checks import ENV, ROOT, run_example  # noqa: E402

from reachavoid.training.benchmarl_experiment import MappoSettings, run  # noqa: E402
from reachavoid_env.checks import FieldError  # noqa: E402
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
    experiment, rows = run(MappoSettings(frames=2000, batch=1000, out=tmp_path))
    assert experiment.total_frames == 2000 and experiment.n_iters_performed == 2
    assert sorted(row["group"] for row in rows) == ["attacker", "attacker", "defender",
                                                    "defender"]
    for row in rows:
        for key in ("loss_objective", "loss_critic"):
            assert math.isfinite(row[key])
    assert any(tmp_path.iterdir())        # BenchMARL's logs


def test_attackers_task_is_the_batched_attacker_view_against_scripted_defenders():
    from torchrl.envs.utils import check_env_specs

    from reachavoid.training.benchmarl_task import ScriptedDefendersTask

    task = ScriptedDefendersTask.ATTACKERS.get_task(
        {"scenario": "paper_6v2", "defenders": "greedy", "max_cycles": 50, "action_repeat": 2})
    env = task.get_env_fun(num_envs=3, continuous_actions=True, seed=0, device="cpu")()
    check_env_specs(env)
    assert env.batch_size == (3,)                       # num_envs: the vector env's copies
    assert task.group_map(env) == {"attacker": [f"attacker_{i}" for i in range(6)]}
    assert task.max_steps(env) == 25
    observed = task.observation_spec(env)["attacker"]
    assert list(observed.keys()) == ["observation"] and observed["observation"].shape == (6, 59)
    assert task.state_spec(env) is None and task.action_mask_spec(env) is None
    assert env.view.vec.num_envs == 3 and env.view.learners == task.group_map(env)["attacker"]


def test_attackers_task_refuses_an_unknown_key_when_made():
    from reachavoid.training.benchmarl_task import ScriptedDefendersTask

    with pytest.raises(ValueError, match=r"^config\.defender: not a key of the ATTACKERS "
                                         r"task \(keys: scenario, defenders, "):
        ScriptedDefendersTask.ATTACKERS.get_task({"scenario": "paper_6v2", "defender": "hj"})


@pytest.mark.parametrize("defenders, options", [
    ("greedy", None), ("hj", {"grid1": 11, "grid2": 8, "progress": False})])
def test_mappo_trains_the_attackers_against_scripted_defenders(tmp_path, defenders, options):
    experiment, rows = run(MappoSettings(
        task="attackers", scenario="paper_6v2", defenders=defenders, defender_options=options,
        envs=8, max_cycles=100, frames=320, batch=160, out=tmp_path))
    assert experiment.total_frames == 320 and experiment.n_iters_performed == 2
    assert list(experiment.group_map) == ["attacker"]          # the defenders do not learn
    assert list(experiment.losses) == ["attacker"]
    assert [row["group"] for row in rows] == ["attacker", "attacker"]
    for row in rows:
        for key in ("loss_objective", "loss_critic"):
            assert math.isfinite(row[key])
    scripted = experiment.test_env.view._scripted[0][0]
    assert type(scripted).__name__ == {"greedy": "BatchGreedyDefenders",
                                       "hj": "BatchHJDefenders"}[defenders]


def test_the_example_trains_the_attackers_and_prints_their_losses(tmp_path):
    lines = run_example("benchmarl_mappo", "--task", "attackers", "--scenario", "paper_6v2",
                        "--defenders", "greedy", "--envs", "8", "--max-cycles", "100",
                        "--frames", "320", "--batch", "160", "--out", str(tmp_path))
    printed = [line.split(", ") for line in lines
               if line.startswith(("attacker, ", "defender, "))]
    assert [items[0] for items in printed] == ["attacker", "attacker"]   # group, iteration
    for items in printed:
        row = dict(item.rsplit(" ", 1) for item in items[1:])
        for key in ("loss_objective", "loss_critic"):
            assert math.isfinite(float(row[key]))
    assert any(tmp_path.iterdir())        # BenchMARL's logs


@pytest.mark.parametrize("envs, message", [
    ("16", "--batch: a batched step is envs (16) env steps"),
    ("0", "--envs: must be an integer >= 1, got 0")])
def test_the_example_refuses_no_copies_or_a_batch_that_is_not_whole_copies(envs, message):
    done = subprocess.run([sys.executable, str(ROOT / "examples" / "benchmarl_mappo.py"),
                           "--task", "attackers", "--envs", envs, "--batch", "1000"],
                          capture_output=True, text=True, timeout=300, cwd=ROOT,
                          env={**ENV, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 2 and done.stdout == ""
    last = done.stderr.splitlines()[-1]
    assert last.startswith("benchmarl_mappo.py: error: ") and message in last, done.stderr


@pytest.mark.parametrize("change, field", [
    ({"envs": 16, "batch": 1000}, "batch"), ({"envs": 0}, "envs"), ({"task": "both"}, "task"),
    ({"frames": 0}, "frames")])
def test_settings_refuse_a_bad_field_when_made(change, field):
    with pytest.raises(FieldError) as raised:
        MappoSettings(**{"task": "attackers", "envs": 10, "batch": 1000} | change)
    assert raised.value.field == field and str(raised.value).startswith(f"{field}: ")


def test_v2_task_takes_discrete_actions():
    task = ReachAvoidTask.REACH_AVOID_V2.get_task({"max_cycles": 20})
    assert task.supports_discrete_actions() and task.max_steps(None) == 20
    env = task.get_env_fun(num_envs=1, continuous_actions=False, seed=0, device="cpu")()
    assert task.group_map(env) == {"attacker": ["attacker_0", "attacker_1"],
                                   "defender": ["defender_0"]}
    rollout = env.rollout(25, break_when_any_done=False)
    assert rollout["next", "done"].squeeze(-1).nonzero().flatten().tolist() == [19]


@pytest.mark.parametrize("continuous", ["1", "0"])
def test_the_v2_script_sees_a_reward_and_ends(tmp_path, continuous):
    """docs/training-code.md's BenchMARL script at a tiny budget, sparse reward."""
    done = subprocess.run([sys.executable, str(ROOT / "examples" / "benchmarl_v2.py"),
                           "--reward", "sparse", "--frames", "4000", "--batch", "2000",
                           "--continuous-actions", continuous, "--out", str(tmp_path)],
                          capture_output=True, text=True, timeout=600, cwd=ROOT,
                          env={**ENV, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stdout.strip().splitlines()
    assert lines[-1] == "done"
    seen = [float(n) for line in lines for n in re.findall(r"(?:attacker|defender) ([\d.e+-]+)",
                                                           line)]
    assert seen and max(seen) > 0, done.stdout

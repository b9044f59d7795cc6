"""The shared-policy attacker team recipe (``reachavoid.training.recipe``), end to end on
a tiny budget: it trains, writes every output, evaluates three teams on the same starts, and
``--evaluate-only`` reproduces the evaluation of the saved model."""

from __future__ import annotations

import csv
import json
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("supersuit")

from checks import ROOT  # noqa: E402
from stable_baselines3 import PPO  # noqa: E402

from reachavoid.training import callbacks, cloning, config, recipe  # noqa: E402

TINY = ["--grid1", "11", "--grid2", "8", "--timesteps", "192", "--copies", "1",
        "--n-steps", "16", "--batch-size", "48", "--episodes", "3", "--video-every", "20"]


def test_recipe_trains_evaluates_and_records(tmp_path):
    report = recipe.main([*TINY, "--out", str(tmp_path)])

    assert report["defenders"] == "hj" and report["grids"] == [11, 8]
    assert report["training"]["agent_steps"] >= 192
    run = report["run"]
    assert 0 < report["training"]["cpu_seconds"] <= run["cpu_seconds"]
    assert 0 < run["evaluation_cpu_seconds"] <= run["cpu_seconds"]
    assert 0 < run["evaluation_seconds"] <= run["seconds"]
    assert report["training"]["game_steps"] == (
        report["training"]["agent_steps"] // 6 * report["action_repeat"])
    evaluation = report["evaluation"]
    for team in ("learned", "shortest-path", "random"):
        summary = evaluation[team]
        assert summary["episodes"] == 3
        assert 0.0 <= summary["arrival_rate"] <= 1.0
        low, high = summary["arrival_rate_ci95"]
        assert 0.0 <= low <= summary["arrival_rate"] <= high <= 1.0
        assert 0.0 <= summary["mean_captured"] <= 6.0
        assert summary["mean_arrived"] + summary["mean_captured"] <= 6.0
    difference = evaluation["learned_minus_shortest_path"]
    assert difference["arrival_rate"] == pytest.approx(
        evaluation["learned"]["arrival_rate"] - evaluation["shortest-path"]["arrival_rate"])

    assert json.loads((tmp_path / "report.json").read_text()) == json.loads(
        json.dumps(report))
    with open(tmp_path / "curve.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [int(row["timesteps"]) for row in rows] == [96, 192]
    for row in rows:
        if int(row["attacker_episodes"]):
            rates = [float(row[key]) for key in ("arrived_rate", "captured_rate",
                                                 "timeout_rate")]
            assert sum(rates) == pytest.approx(1.0)
    assert (tmp_path / "curve.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert report["video"]["frames"] > 1 and (tmp_path / "learned.mp4").stat().st_size > 0

    again = recipe.main([*TINY, "--out", str(tmp_path / "again"), "--teams", "learned",
                         "--no-video", "--evaluate-only", str(tmp_path / "model.zip")])
    assert again["evaluation"]["learned"] == evaluation["learned"]
    assert "training" not in again


def test_scripted_teams_alone_train_nothing(tmp_path):
    report = recipe.main(["--defenders", "greedy", "--teams", "shortest-path",
                          "--episodes", "2", "--out", str(tmp_path)])
    assert list(report["evaluation"]) == ["seeds", "shortest-path"]
    assert "training" not in report and "video" not in report
    assert sorted(path.name for path in tmp_path.iterdir()) == ["report.json"]


def test_the_recipe_replaces_a_users_file_only_with_force(tmp_path, capsys):
    """The recipe's outputs follow the command's rule: checked before any work, an existing
    file replaced only with ``--force``, a missing folder refused."""
    for name in ("model.zip", "report.json"):
        (tmp_path / name).write_text("mine")
    quick = ["--defenders", "greedy", "--episodes", "2", "--out", str(tmp_path)]
    for argv in ([*TINY, *quick], [*quick, "--teams", "shortest-path"],
                 [*TINY, "--out", str(tmp_path / "new"),
                  "--plot", str(tmp_path / "no-such-folder" / "c.png")]):
        with pytest.raises(SystemExit) as stopped:
            recipe.main(argv)
        assert stopped.value.code == 2
    errors = capsys.readouterr().err
    assert "report.json' exists; pass --force" in errors and "does not exist" in errors
    assert {p.name: p.read_text() for p in tmp_path.iterdir()} == {"model.zip": "mine",
                                                                   "report.json": "mine"}
    recipe.main([*quick, "--teams", "shortest-path", "--force"])
    assert (tmp_path / "model.zip").read_text() == "mine"
    assert json.loads((tmp_path / "report.json").read_text())["evaluation"]


def test_init_and_evaluate_only_refuse_a_model_others_can_change(tmp_path, capsys):
    """A model file is code: one in a folder others can write is not read."""
    shared = tmp_path / "shared"
    shared.mkdir()
    (shared / "model.zip").write_bytes(b"PK")
    shared.chmod(0o777)
    for flag in ("--init", "--evaluate-only"):
        with pytest.raises(SystemExit) as stopped:
            recipe.main(["--defenders", "greedy", flag, str(shared / "model.zip"),
                         "--out", str(tmp_path / "out")])
        assert stopped.value.code == 2
        last = capsys.readouterr().err.splitlines()[-1]   # argparse's usage, then one line
        assert f"error: {flag}: model" in last and "a model file is code" in last
    assert not (tmp_path / "out").exists()


def test_first_seed_shifts_the_evaluation_starts(tmp_path):
    """``--first-seed 1 --episodes 2`` plays the starts 1 and 2: the last two of
    ``--episodes 3``, episode by episode."""
    reports = [recipe.main(["--defenders", "greedy", "--teams", "shortest-path", *argv,
                            "--out", str(tmp_path / str(k))])
               for k, argv in enumerate((["--episodes", "3"],
                                         ["--episodes", "2", "--first-seed", "1"]))]
    assert reports[1]["evaluation"]["seeds"] == [1, 2]
    every, later = (report["per_episode"]["shortest-path"] for report in reports)
    assert later["arrived"] == every["arrived"][1:]
    assert later["captured"] == every["captured"][1:]


def test_easy_starts_open_the_map_over_the_training(tmp_path):
    """``--easy-starts 0.3 --easy-fraction 0.5``: the curve's rows carry the reach of their
    rollout, 0.3 map units at first, growing, then anywhere (empty) for the second half."""
    report = recipe.main(["--defenders", "greedy", "--scenario", "paper_2v1", "--copies", "2",
                          "--n-steps", "16", "--batch-size", "32", "--timesteps", "320",
                          "--easy-starts", "0.3", "--teams", "learned", "--episodes", "1",
                          "--no-video", "--out", str(tmp_path)])
    assert report["training"]["easy_starts"] == 0.3
    with open(tmp_path / "curve.csv", newline="") as handle:
        reaches = [row["start_reach"] for row in csv.DictReader(handle)]
    assert len(reaches) == 5 and float(reaches[0]) == pytest.approx(0.3)
    assert 0.3 < float(reaches[1]) < 2 * np.sqrt(2) and reaches[-2:] == ["", ""]
    assert callbacks.row_text({"timesteps": 320, "start_reach": None}) == (
        "PPO: timesteps 320, start_reach anywhere")


def test_bad_arguments_exit_2(tmp_path, capsys):
    for argv in (["--evaluate-only", str(tmp_path / "missing.zip")], ["--teams", "learnt"],
                 ["--episodes", "0"], ["--first-seed", "-1"], ["--easy-starts", "0"],
                 ["--easy-starts", "0.3", "--easy-fraction", "2"],
                 ["--easy-starts", "0.3", "--supersuit"], ["--past-selves", "-1"],
                 ["--past-selves", "2", "--supersuit"],
                 ["--past-selves", "2", "--team-reward", "0.5"],
                 ["--past-selves", "2", "--scenario", "paper_1v1"],
                 ["--past-selves", "100000"], ["--copies", "100000"],
                 ["--n-steps", "1", "--batch-size", "1"], ["--learning-rate", "nan"],
                 ["--ent-coef", "-1"], ["--shaping", "inf"],
                 ["--n-steps", "1", "--copies", "1", "--scenario", "paper_1v1"]):
        with pytest.raises(SystemExit) as stopped:
            recipe.main([*argv, "--out", str(tmp_path)])
        assert stopped.value.code == 2
    errors = capsys.readouterr().err
    assert "--past-selves: must be an integer in [0, 10000], got -1" in errors
    assert "--past-selves: needs the vector env" in errors
    assert "--past-selves: one attacker per copy learns" in errors
    assert "--past-selves: needs teammates" in errors
    assert "--teams: unknown team 'learnt'" in errors
    assert "--easy-starts: must be > 0, got 0.0" in errors
    assert "--easy-fraction: must be in (0, 1], got 2.0" in errors
    assert "--easy-starts: needs the vector env" in errors
    for message in ("--past-selves: must be an integer in [0, 10000], got 100000",
                    "--copies: must be an integer in [1, 65536], got 100000",
                    "--batch-size: must be an integer in [2, ", "--learning-rate: must be > 0",
                    "--ent-coef: must be >= 0", "--shaping: must be a finite number",
                    "--n-steps: a rollout of one agent step"):
        assert message in errors, message
    assert list(tmp_path.iterdir()) == []


def test_training_curve_counts_how_every_attacker_ended(tmp_path):
    """The curve reads the outcomes from what SuperSuit passes on (it overwrites the last
    step's infos with the reset infos); compare with the game's own statuses."""
    from pettingzoo.utils import BaseParallelWrapper
    from stable_baselines3 import PPO

    from reachavoid.training.views import make_attackers_parallel_env
    from reachavoid_env import load_scenario
    from reachavoid_env.integrations.supersuit import sb3_vec_env

    truth = tmp_path / "statuses.txt"

    class Statuses(BaseParallelWrapper):
        """Appends the attackers' status codes to ``truth`` when a game ends (the vector
        env works on pickled copies, so a file, not a list)."""

        def step(self, actions):
            result = self.env.step(actions)
            if not self.env.agents:
                with open(truth, "a") as handle:
                    handle.write(" ".join(str(status.code) for status
                                          in self.env.game_state().attacker_status) + "\n")
            return result

    scenario = load_scenario("paper_6v2").with_players(6, 2)
    game = make_attackers_parallel_env(scenario, defenders="greedy", action_repeat=10,
                                       shaping=1.0, timeout_reward=-1.0, max_cycles=300)
    envs = sb3_vec_env(Statuses(game))
    curve = callbacks.TrainingCurve()
    PPO("MlpPolicy", envs, n_steps=64, batch_size=64, seed=0, device="cpu").learn(
        64 * 6 * 6, callback=curve)
    ended = sum(row["attacker_episodes"] for row in curve.rows)
    codes = [int(code) for code in truth.read_text().split()][:ended]
    assert ended == len(codes) > 0
    for key, code in (("arrived_rate", 2), ("captured_rate", 1), ("timeout_rate", 0)):
        counted = sum(row[key] * row["attacker_episodes"] for row in curve.rows
                      if row["attacker_episodes"])
        assert counted == pytest.approx(codes.count(code))
    assert {0, 1} <= set(codes)     # time-outs and captures both occur in this run


def test_cloned_policy_alone_follows_the_script(tmp_path):
    """``--imitate-steps`` with ``--timesteps 0``: the shortest-path team's steps are
    recorded and cloned, no PPO runs, and the cloned policy is evaluated and saved."""
    report = recipe.main([*TINY, "--timesteps", "0", "--imitate-steps", "300",
                          "--imitate-epochs", "3", "--imitate-log-std", "-1.5",
                          "--teams", "learned", "--no-video", "--out", str(tmp_path)])
    imitation = report["imitation"]
    assert imitation["agent_steps"] == 300 and imitation["episodes"] >= 1
    assert 0.0 <= imitation["scripted_arrival_rate"] <= 1.0
    assert imitation["action_mse"] < 1.0
    assert 0 < imitation["cpu_seconds"] <= report["run"]["cpu_seconds"]
    assert report["training"]["agent_steps"] == 0 and "curve" not in report
    model = PPO.load(tmp_path / "model.zip", device="cpu")
    assert model.policy.log_std.detach().tolist() == pytest.approx([-1.5, -1.5])
    assert report["evaluation"]["learned"]["episodes"] == 3


def test_init_starts_ppo_from_a_saved_policy(tmp_path, capsys):
    """``--init`` continues from a saved policy (its network kept, the new run's PPO
    settings used); ``--team-reward`` reaches the training env and the report."""
    recipe.main([*TINY, "--timesteps", "0", "--imitate-steps", "100", "--imitate-epochs", "1",
                 "--net-arch", "8,8", "--teams", "learned", "--no-video",
                 "--out", str(tmp_path / "clone")])
    start = PPO.load(tmp_path / "clone" / "model.zip", device="cpu")
    report = recipe.main([*TINY, "--init", str(tmp_path / "clone" / "model.zip"),
                          "--learning-rate", "1e-5", "--team-reward", "0.5",
                          "--teams", "learned", "--no-video", "--out", str(tmp_path / "tuned")])
    training = report["training"]
    assert training["init"] == str(tmp_path / "clone" / "model.zip")
    assert training["net_arch"] == [8, 8] and training["agent_steps"] >= 192
    assert report["team_reward"] == 0.5
    tuned = PPO.load(tmp_path / "tuned" / "model.zip", device="cpu")
    assert tuned.learning_rate == 1e-5
    before = start.policy.state_dict()
    after = tuned.policy.state_dict()
    assert before.keys() == after.keys()
    assert any(not np.array_equal(before[k].numpy(), after[k].numpy()) for k in before)
    for argv in (["--init", str(tmp_path / "missing.zip")],
                 ["--init", str(tmp_path / "clone" / "model.zip"), "--imitate-steps", "10"]):
        with pytest.raises(SystemExit) as stopped:
            recipe.main([*argv, "--out", str(tmp_path / "refused")])
        assert stopped.value.code == 2
    assert "--init: the saved policy is the start" in capsys.readouterr().err
    assert not (tmp_path / "refused").exists()


def test_a_model_of_another_game_is_refused_in_one_line(tmp_path):
    """``--init`` and ``--evaluate-only`` with a policy of other observations (here
    Pendulum's) stop with a ``ModelError`` naming the flag and both shapes, before any
    training; the command prints it in one line and exits with status 2."""
    import gymnasium

    foreign = tmp_path / "pendulum.zip"
    PPO("MlpPolicy", gymnasium.make("Pendulum-v1"), device="cpu").save(foreign)
    for flag in ("--init", "--evaluate-only"):
        with pytest.raises(config.ModelError, match=f"^{flag}: .*pendulum.zip") as refused:
            recipe.main(["--defenders", "greedy", flag, str(foreign), "--no-video",
                         "--out", str(tmp_path / flag.strip("-"))])
        assert "\n" not in str(refused.value)
    script = ROOT / "examples" / "train_attacker_team.py"
    finished = subprocess.run([sys.executable, str(script), "--defenders", "greedy",
                               "--evaluate-only", str(foreign), "--out", str(tmp_path / "cli")],
                              capture_output=True, text=True, cwd=script.parent.parent)
    assert finished.returncode == 2, finished.stderr
    assert finished.stderr.startswith("train_attacker_team.py: error: --evaluate-only: ")
    assert finished.stderr.count("\n") == 1


def test_demonstrations_line_up_with_their_returns(tmp_path):
    """Every recorded row is a live attacker's observation, the script's unit action and
    the discounted return of the rewards that followed it."""
    args = config.parse_args(["--defenders", "greedy", "--imitate-steps", "200",
                              "--out", str(tmp_path)])
    demonstrations = cloning.collect_demonstrations(args, config.team_maps(args.scenario), 0.9)
    assert demonstrations.observations.shape == (200, 7 + 16 + 5 * 7 + 1)
    assert demonstrations.actions.shape == (200, 2) and demonstrations.returns.shape == (200,)
    lengths = np.linalg.norm(demonstrations.actions, axis=1)
    assert np.all((np.abs(lengths - 1.0) < 1e-4) | (lengths == 0.0))
    assert cloning.discounted([1.0, 0.0, 2.0], 0.5) == pytest.approx([1.5, 1.0, 2.0])


def test_the_hj_team_is_cloned_and_evaluated_beside_the_clone(tmp_path):
    """``--imitate-from hj``: the demonstrations are the HJ attackers' actions (on the
    defenders' 1 vs 1 tube), the teacher joins the evaluated teams with the paired
    differences learned - teacher and teacher - shortest-path, and the policy after the
    cloning is saved as ``cloned.zip``."""
    from policies.attackers import HJAttacker, ShortestPathAttacker
    from policies.tubes import tube_1v1

    args = config.parse_args(["--defenders", "greedy", "--grid1", "11", "--imitate-steps",
                              "6", "--imitate-from", "hj", "--out", str(tmp_path)])
    assert args.teams == ("learned", "shortest-path", "random", "hj")
    maps = config.team_maps(args.scenario)
    [scenario] = maps
    demonstrations = cloning.collect_demonstrations(args, maps, 0.9)
    env = config.game(args, maps)
    env.reset(seed=args.seed + cloning.IMITATION_SEED_OFFSET)
    first_steps = []                # the rows start with attacker_0's first step
    for teacher in (HJAttacker(tube_1v1(scenario, 11, progress=False)),
                    ShortestPathAttacker()):
        teacher.reset(scenario)
        first_steps.append(teacher.act(env.game_state())["attacker_0"])
    np.testing.assert_allclose(demonstrations.actions[0], first_steps[0], atol=1e-6)
    assert np.abs(first_steps[0] - first_steps[1]).max() > 0.05

    report = recipe.main([*TINY, "--timesteps", "0", "--imitate-steps", "60",
                          "--imitate-from", "hj", "--no-video", "--out", str(tmp_path)])
    assert report["imitation"]["teacher"] == "hj"
    evaluation = report["evaluation"]
    assert {"learned", "shortest-path", "random", "hj"} <= evaluation.keys()
    for first, second in (("learned", "shortest-path"), ("learned", "hj"),
                          ("hj", "shortest-path")):
        difference = evaluation[f"{first}_minus_{second}".replace("-", "_")]
        assert difference["arrival_rate"] == pytest.approx(
            evaluation[first]["arrival_rate"] - evaluation[second]["arrival_rate"])
    cloned = PPO.load(tmp_path / "cloned.zip", device="cpu")
    trained = PPO.load(tmp_path / "model.zip", device="cpu")
    for name, values in cloned.policy.state_dict().items():
        np.testing.assert_array_equal(values, trained.policy.state_dict()[name])


def test_teams_are_any_scripted_attackers(tmp_path):
    assert config.parse_args(["--out", str(tmp_path)]).teams == config.DEFAULT_TEAMS
    report = recipe.main(["--defenders", "greedy", "--teams", "straight,shortest-path",
                          "--episodes", "2", "--out", str(tmp_path)])
    assert {"straight", "shortest-path"} <= report["evaluation"].keys()
    assert "learned_minus_shortest_path" not in report["evaluation"]


def test_dagger_rounds_refit_a_wider_network_on_the_learner_states(tmp_path):
    """``--dagger-rounds 1``: after the cloning, the policy (``--net-arch 32,32``) plays the
    training env, the teacher labels the states it visits, the policy is refitted on all
    the rows, and that refitted policy is ``cloned.zip``; the report records the round."""
    report = recipe.main([*TINY, "--timesteps", "0", "--imitate-steps", "60",
                          "--imitate-epochs", "2", "--dagger-rounds", "1", "--dagger-steps",
                          "40", "--net-arch", "32,32", "--teams", "learned", "--no-video",
                          "--out", str(tmp_path)])
    dagger = report["imitation"]["dagger"]
    assert dagger["epochs"] == 2 and len(dagger["rounds"]) == 1
    played = dagger["rounds"][0]
    assert played["round"] == 1 and played["agent_steps"] == 40
    assert played["aggregate_steps"] == 100 and played["episodes"] >= 1
    assert 0.0 <= played["learner_arrival_rate"] <= 1.0
    assert played["action_mse"] >= 0.0 and played["learner_action_mse"] >= 0.0
    assert report["training"]["net_arch"] == [32, 32]
    cloned = PPO.load(tmp_path / "cloned.zip", device="cpu")
    assert cloned.policy.net_arch == [32, 32]
    trained = PPO.load(tmp_path / "model.zip", device="cpu")
    for name, values in cloned.policy.state_dict().items():
        np.testing.assert_array_equal(values, trained.policy.state_dict()[name])


def test_dagger_rows_are_the_learner_states_labelled_by_the_teacher(tmp_path):
    """With a player, the rows are the states the player visits, each with the teacher's
    action there, not the player's."""
    args = config.parse_args(["--defenders", "greedy", "--out", str(tmp_path)])
    maps = config.team_maps(args.scenario)

    class Still:
        def reset(self, env):
            pass

        def act(self, observations, env):
            return {name: np.zeros(2, dtype=np.float32) for name in env.agents}

    taught = cloning.collect_demonstrations(args, maps, 0.9, steps=30, seed=5)
    still = cloning.collect_demonstrations(args, maps, 0.9, player=Still(), steps=30,
                                          seed=5)
    # the rows start with attacker_0's steps: the same first state and label, then the
    # states where the player, not the teacher, has moved it
    np.testing.assert_array_equal(still.observations[0], taught.observations[0])
    np.testing.assert_array_equal(still.actions[0], taught.actions[0])
    assert not np.array_equal(still.observations[1, :2], taught.observations[1, :2])
    lengths = np.linalg.norm(still.actions, axis=1)
    assert np.all((np.abs(lengths - 1.0) < 1e-4) | (lengths == 0.0))
    both = taught + still
    assert len(both.actions) == 60 and both.episodes == taught.episodes + still.episodes


def test_dagger_arguments_are_checked(tmp_path, capsys):
    for argv in (["--dagger-rounds", "1"], ["--net-arch", "64,x"], ["--net-arch", "0"]):
        with pytest.raises(SystemExit) as stopped:
            config.parse_args([*argv, "--out", str(tmp_path)])
        assert stopped.value.code == 2
    assert "--dagger-rounds: needs --imitate-steps" in capsys.readouterr().err


def test_trained_on_one_library_evaluated_on_another(tmp_path):
    """``--scenario LIBRARY --evaluate-on LIBRARY``: training plays the first library's maps,
    the evaluation the second's, with the scripted teams built per map."""
    from reachavoid_env.maps import MapOptions, write_library

    small = MapOptions(obstacles=(1, 2), shapes=("box", "circle"), density=(0.0, 0.3))
    write_library(tmp_path / "train", small, 0, 2)
    write_library(tmp_path / "test", small, 1, 2)
    report = recipe.main(["--defenders", "greedy", "--scenario", str(tmp_path / "train"),
                          "--evaluate-on", str(tmp_path / "test"), "--imitate-steps", "20",
                          "--imitate-epochs", "1", "--timesteps", "0", "--teams",
                          "learned,shortest-path", "--episodes", "4", "--no-video",
                          "--out", str(tmp_path / "out")])
    assert [m.split("_")[0] for m in report["maps"]] == ["gen-s0-0000", "gen-s0-0001"]
    assert [m.split("_")[0] for m in report["evaluated_on"]] == ["gen-s1-0000", "gen-s1-0001"]
    assert report["evaluation"]["shortest-path"]["episodes"] == 4


def test_full_speed_actions_are_headings_in_training_and_play(tmp_path):
    """``--full-speed``: PPO's actions reach the games scaled to length 1, the saved model
    records it, and ``load_sb3`` plays it so."""
    import gymnasium

    from policies.learned import load_sb3

    report = recipe.main([*TINY, "--full-speed", "--teams", "learned", "--no-video",
                          "--out", str(tmp_path)])
    assert report["full_speed"] is True
    assert load_sb3(tmp_path / "model.zip").full_speed

    class Games:        # the least of a VecEnv that VecEnvWrapper reads
        num_envs, render_mode = 3, None
        observation_space = gymnasium.spaces.Box(-1.0, 1.0, (4,))
        action_space = gymnasium.spaces.Box(-1.0, 1.0, (2,))

        def step_async(self, actions):
            self.actions = actions

    games = Games()
    callbacks.FullSpeed(games).step_async(np.array([[0.3, 0.4], [0.0, 0.0], [-1.0, 1.0]]))
    np.testing.assert_allclose(games.actions, [[0.6, 0.8], [0.0, 0.0],
                                               [-0.5 ** 0.5, 0.5 ** 0.5]])


def test_a_two_vs_one_policy_of_the_nearest_players_plays_six_vs_two(tmp_path):
    """``--teammates 1 --opponents 1``: the model trained in 2 vs 1 stores that observation,
    and the same flags evaluate it (and ``sb3:`` plays it) in 6 vs 2, whose full
    observation it could not read; one flag alone is a one-line error."""
    from policies.learned import load_sb3
    from reachavoid_env import builtin_scenario

    nearest = ["--teammates", "1", "--opponents", "1", "--defenders", "greedy", "--no-video"]
    recipe.main([*TINY, *nearest, "--scenario", "paper_2v1", "--teams", "learned",
                 "--out", str(tmp_path / "two")])
    model = tmp_path / "two" / "model.zip"
    report = recipe.main([*TINY, *nearest, "--scenario", "paper_6v2", "--evaluate-only",
                          str(model), "--teams", "learned,shortest-path",
                          "--out", str(tmp_path / "six")])
    assert report["evaluation"]["learned"]["episodes"] == 3
    assert load_sb3(model).observation.teammates == 1
    load_sb3(model).reset(builtin_scenario("paper_6v2"))
    with pytest.raises(config.ModelError, match="^--evaluate-only: .*observes"):
        recipe.main([*TINY, "--defenders", "greedy", "--scenario", "paper_6v2",
                     "--evaluate-only", str(model), "--out", str(tmp_path / "full")])
    with pytest.raises(SystemExit) as stopped:
        recipe.main(["--teammates", "1", "--out", str(tmp_path / "refused")])
    assert stopped.value.code == 2


def test_past_selves_train_one_attacker_per_copy(tmp_path):
    """``--past-selves POOL``: one slot per copy (agent steps are game decisions), the
    teammates played by snapshots (its refusals: ``test_bad_arguments_exit_2``)."""
    report = recipe.main([*TINY, "--copies", "2", "--past-selves", "2", "--teams", "learned",
                          "--no-video", "--out", str(tmp_path / "run")])
    training = report["training"]
    assert training["past_selves"] == 2
    assert training["game_steps"] == training["agent_steps"] * report["action_repeat"]


def test_a_scenario_that_does_not_load_is_a_one_line_error(tmp_path, capsys):
    for flag in ("--scenario", "--evaluate-on"):
        with pytest.raises(SystemExit) as stopped:
            recipe.main([flag, str(tmp_path / "missing"), "--out", str(tmp_path / "out")])
        assert stopped.value.code == 2
        assert f"argument {flag}: scenario: no such file" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()

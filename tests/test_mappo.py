"""The learned defenders ``learned-mappo``: the padded layout, the weights file (shipped,
missing, damaged, foreign), play through the registry and the command line, and the
training recipe end to end at a tiny size (the pipeline, not the shipped weights)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import reachavoid_env
from policies.mappo import (
    MAX_ATTACKERS,
    ActorWeights,
    LearnedMappoDefenders,
    load_weights,
    pad_observations,
    padded_size,
    save_weights,
)
from policies.registry import make_policy
from reachavoid_env import PolicyMismatch, builtin_scenario
from reachavoid_env.observations import ObservationConfig

SHIPPED = load_weights()


def test_padding_sorts_each_group_nearest_first_and_leaves_absent_players_zero():
    rays = 0
    head = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]
    teammate = [0.3, 0.0, 0.1, 0.1, 1.0]
    far, near, gone = [0.5, 0.0, 0, 0, 1.0], [0.0, 0.2, 0, 0, 1.0], [0.01, 0.0, 0, 0, 0.0]
    row = np.array([head + teammate + far + gone + near + [0.9]], dtype=np.float32)
    padded = pad_observations(row, 3, 2, rays)[0]
    assert padded.shape == (padded_size(rays),)
    assert padded[:7].tolist() == pytest.approx(head) and padded[-1] == pytest.approx(0.9)
    teammates = padded[7:22].reshape(3, 5)
    assert teammates[0].tolist() == pytest.approx(teammate) and not teammates[1:].any()
    opponents = padded[22:-1].reshape(MAX_ATTACKERS, 5)
    np.testing.assert_allclose(opponents[:3], [near, far, gone], rtol=1e-6)
    assert not opponents[3:].any()


def test_the_shipped_actor_is_small_and_acts_in_bounds():
    assert SHIPPED.layers[0][0].shape[0] == padded_size(SHIPPED.lidar_rays)
    assert sum(w.size + b.size for w, b in SHIPPED.layers) * 4 < 64_000
    rng = np.random.default_rng(0)
    actions = SHIPPED.act(rng.uniform(-1, 1, (50, padded_size(SHIPPED.lidar_rays))))
    assert actions.shape == (50, 2) and np.abs(actions).max() <= 1.0


@pytest.mark.parametrize("name", ["paper_1v1", "paper_6v2", "paper_8v4", "paper_6v4_equal"])
def test_the_registry_builds_it_and_it_plays_a_whole_episode(name):
    from reachavoid.rollout import run_episode

    scenario = builtin_scenario(name)
    defenders = make_policy("defenders", "learned-mappo", scenario)
    assert isinstance(defenders, LearnedMappoDefenders)
    env = reachavoid_env.parallel_env(scenario=scenario, starts="random")
    attackers = make_policy("attackers", "shortest-path", scenario)
    seen = []
    act = defenders.act
    defenders.act = lambda state: seen.append(act(state)) or seen[-1]
    result = run_episode(env, attackers, defenders, seed=3)
    assert result.steps > 0 and seen
    actions = np.array([a for step in seen for a in step.values()])
    assert actions.shape[1] == 2 and np.abs(actions).max() <= 1.0
    assert all(set(step) == set(scenario.defender_names) for step in seen)


def test_a_game_too_big_is_refused_in_one_line():
    big = builtin_scenario("paper_2v1").with_players(2, 5)
    with pytest.raises(PolicyMismatch, match="learned-mappo plays up to .* 5 defenders"):
        make_policy("defenders", "learned-mappo", big)
    policy = LearnedMappoDefenders(SHIPPED)
    with pytest.raises(PolicyMismatch, match="9 attackers"):
        policy.reset(builtin_scenario("paper_2v1").with_players(9, 1))


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "reachavoid", *args], capture_output=True,
                          text=True, timeout=300)


def test_the_command_line_plays_it_and_refuses_a_game_too_big():
    good = _cli("play", "--scenario", "paper_2v1", "--defenders", "learned-mappo",
                "--attackers", "shortest-path")
    assert good.returncode == 0, good.stderr
    assert "attackers:" in good.stdout
    bad = _cli("bench", "--scenario", "paper_2v1", "--config", "2v5", "--defenders",
               "learned-mappo,greedy", "--episodes", "1")
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    [line] = bad.stderr.strip().splitlines()
    assert "learned-mappo plays up to" in line and "5 defenders" in line


def test_missing_damaged_and_foreign_weights_are_refused(tmp_path):
    with pytest.raises(ValueError, match="is not a file"):
        load_weights(tmp_path / "none.npz")
    path = tmp_path / "actor.npz"
    save_weights(path, SHIPPED)
    assert load_weights(path).layers[0][0].tolist() == SHIPPED.layers[0][0].tolist()
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    damaged = tmp_path / "damaged.npz"
    damaged.write_bytes(bytes(data))
    with pytest.raises(ValueError, match="damaged.npz"):
        load_weights(damaged)
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(bytes(data[:100]))
    with pytest.raises(ValueError, match="not a readable .npz"):
        load_weights(truncated)
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, meta=np.array([1, 16, 10]), w0=np.zeros((3, 2), np.float32),
             b0=np.zeros(2, np.float32))
    with pytest.raises(ValueError, match="layer 0 has shapes"):
        load_weights(foreign)
    pickled = tmp_path / "pickled.npz"
    np.savez(pickled, meta=np.array([{"a": 1}], dtype=object))
    with pytest.raises(ValueError, match="pickled.npz"):
        load_weights(pickled)
    nan = ActorWeights(((SHIPPED.layers[0][0] * np.nan, SHIPPED.layers[0][1]),
                        *SHIPPED.layers[1:]), SHIPPED.lidar_rays, SHIPPED.action_repeat)
    save_weights(tmp_path / "nan.npz", nan)
    with pytest.raises(ValueError, match="not finite"):
        load_weights(tmp_path / "nan.npz")


def test_weights_that_expand_hugely_are_refused_before_loading(tmp_path):
    from policies.mappo import MAX_WEIGHTS_BYTES

    bomb = tmp_path / "bomb.npz"
    np.savez_compressed(bomb, meta=np.array([1, 16, 10]),
                        w0=np.zeros(MAX_WEIGHTS_BYTES // 4 + 1, np.float32))
    assert bomb.stat().st_size < MAX_WEIGHTS_BYTES // 100
    with pytest.raises(ValueError, match="bomb.npz' expands to .* not loaded"):
        load_weights(bomb)


def test_the_recipe_checks_every_flag_and_output_before_any_work(tmp_path, capsys):
    pytest.importorskip("torchrl")
    from reachavoid.training import mappo as recipe

    mine = tmp_path / "mine.npz"
    mine.write_bytes(b"my weights")
    out = ["--out", str(tmp_path / "w.npz")]
    for argv in ([*out, "--copies", "0"], [*out, "--games", "bogus"],
                 [*out, "--games", "paper_2v1/bogus"], [*out, "--lr", "nan"],
                 [*out, "--steps", "0"], [*out, "--minibatch", "0"], [*out, "--hidden", "0"],
                 [*out, "--iterations", "-1"], [*out, "--entropy", "-1"],
                 ["--out", str(mine)], ["--out", str(tmp_path / "no-such-folder" / "w.npz")],
                 [*out, "--report", str(mine)], [*out, "--report", str(tmp_path / "w.npz")]):
        with pytest.raises(SystemExit) as stopped:
            recipe.main(argv)
        assert stopped.value.code == 2, argv
    errors = [line for line in capsys.readouterr().err.splitlines() if "error:" in line]
    assert len(errors) == 13
    for message in ("--copies: must be an integer in [1, ", "--games: 'bogus': 'bogus' is not",
                    "--games: 'paper_2v1/bogus': 'bogus' is not an attacker",
                    "--lr: must be > 0, got nan", "--steps: must be", "--minibatch: must be",
                    "--hidden: must be", "--iterations: must be", "--entropy: must be >= 0",
                    "mine.npz' exists; pass --force", "does not exist", "--report: ",
                    "give each output its own file"):
        assert any(message in line for line in errors), message
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.npz"]
    assert mine.read_bytes() == b"my weights"
    assert recipe.parse_args(["--out", str(mine), "--force"]).force


def test_the_exported_actor_acts_as_the_trained_one_in_mean():
    torch = pytest.importorskip("torch")
    from reachavoid.training.mappo import TrainConfig, build_modules, export

    config = TrainConfig(hidden=8)
    net, *_ = build_modules(config)
    batch = np.random.default_rng(1).uniform(-1, 1, (20, padded_size(config.lidar_rays)))
    with torch.no_grad():
        loc, _ = net(torch.as_tensor(batch, dtype=torch.float32))
    assert export(net, config).act(batch) == pytest.approx(torch.tanh(loc).numpy(), abs=1e-6)


def test_the_recipe_trains_writes_and_plays_at_a_tiny_size(tmp_path):
    pytest.importorskip("torchrl")
    from reachavoid.training.mappo import Game, TrainConfig, train_defenders

    config = TrainConfig(games=(Game("paper_2v1", "shortest-path"), Game("paper_6v2", "random")),
                         iterations=2, copies=2, steps=8, minibatch=8, hidden=8,
                         teacher="greedy", teacher_steps=4, clone_epochs=2)
    weights, history = train_defenders(config)
    assert history[0]["stage"] == "clone" and history[0]["rows"] >= 2 * 4 * 3
    assert [record["game"] for record in history[1:]] == ["paper_2v1/shortest-path",
                                                          "paper_6v2/random"]
    assert all(np.isfinite(record["loss_objective"]) for record in history[1:])
    again, _ = train_defenders(config)          # seeded: random attackers included
    assert all((w == w2).all() and (b == b2).all()
               for (w, b), (w2, b2) in zip(weights.layers, again.layers, strict=True))
    save_weights(tmp_path / "tiny.npz", weights)
    policy = make_policy("defenders", "learned-mappo", builtin_scenario("paper_6v2"),
                         weights=str(tmp_path / "tiny.npz"))
    assert policy.weights.layers[0][0].shape == (padded_size(16), 8)
    assert policy.observation == ObservationConfig()

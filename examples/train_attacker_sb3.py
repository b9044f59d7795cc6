"""Train one attacker with Stable-Baselines3 PPO against the HJ defenders, evaluate it
against a random attacker on the same seeded starts, and record a video of it.

Needs the ``rl`` extra (``pip install -e '.[rl]'``: torch and stable-baselines3).

    python examples/train_attacker_sb3.py --timesteps 30000 --out runs/attacker

By default the game is ``paper_1v1`` with random starts (``--fixed-starts`` keeps the
scenario's), one env step is held for ``--action-repeat 10`` steps of the game (0.05 s),
the reward has the potential-based progress term (``--shaping 1``), and still being in
play at the time limit scores -1 like a capture (``--timeout-reward -1``: in the game
only arrival wins, so hiding from the defenders earns nothing). The defenders' HJ tubes
are solved once (``--grid1``/``--grid2`` nodes per axis) and cached on disk.

Writes into ``--out``: ``model.zip`` (the PPO policy), ``report.json`` (arrival, capture
and timeout rates over ``--episodes`` evaluation episodes of the trained attacker, a
random one and the paper's scripted shortest-path one, all from the same seeded starts)
and ``trained.mp4`` (one episode, real time).
Ctrl-C leaves no half-written file.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

from policies.training import (
    add_defender_arguments,
    add_reward_arguments,
    attacker_factory,
    defender_factory,
    defender_options,
    make_attacker_env,
    reward_options,
)
from reachavoid_env import AttackerStatus, Scenario, load_scenario
from reachavoid_env.video import VideoWriter
from reachavoid_env.wrappers import SingleAttackerEnv

EVAL_SEED = 10_000  # evaluation episode k starts from reset(seed=EVAL_SEED + k)

Act = Callable[[np.ndarray, SingleAttackerEnv], np.ndarray]


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    add_defender_arguments(parser, scenario="paper_1v1")
    parser.add_argument("--fixed-starts", action="store_true",
                        help="keep the scenario's start positions (default: random starts "
                             "every episode)")
    parser.add_argument("--timesteps", type=int, default=30_000,
                        help="PPO training steps (default: %(default)s)")
    parser.add_argument("--envs", type=int, default=4,
                        help="parallel training envs (default: %(default)s)")
    parser.add_argument("--subprocess", action="store_true",
                        help="run the training envs in subprocesses (SubprocVecEnv)")
    add_reward_arguments(parser)
    parser.add_argument("--episodes", type=int, default=100,
                        help="evaluation episodes per attacker (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=0, help="seed (default: %(default)s)")
    parser.add_argument("--out", type=Path, default=Path("runs/attacker"),
                        help="output folder (default: %(default)s)")
    parser.add_argument("--no-video", action="store_true", help="skip the video")
    args = parser.parse_args(argv)
    for name in ("timesteps", "envs", "action_repeat", "episodes"):
        if getattr(args, name) < 1:
            parser.error(f"--{name.replace('_', '-')}: must be a positive integer")
    return args


def training_scenario(args: argparse.Namespace) -> Scenario:
    scenario = load_scenario(args.scenario)
    if args.fixed_starts:
        return scenario
    return scenario.with_players(scenario.num_attackers, scenario.num_defenders)


def env_kwargs(args: argparse.Namespace, scenario: Scenario) -> dict[str, Any]:
    return {"scenario": scenario, "defenders": args.defenders,
            "defender_options": defender_options(args), **reward_options(args)}


def evaluate(kwargs: dict[str, Any], act: Act, episodes: int) -> dict[str, float]:
    """Arrival, capture and timeout rates of ``act`` over the seeded evaluation starts."""
    env = make_attacker_env(**kwargs)
    counts = {"arrived": 0, "captured": 0, "timeout": 0}
    for k in range(episodes):
        obs, _ = env.reset(seed=EVAL_SEED + k)
        terminated = truncated = False
        while not (terminated or truncated):
            obs, _, terminated, truncated, info = env.step(act(obs, env))
        status = AttackerStatus.from_code(info["status"])
        counts["timeout" if status is AttackerStatus.ACTIVE else status.value] += 1
    env.close()
    return {f"{key}_rate": value / episodes for key, value in counts.items()}


def random_act(seed: int) -> Act:
    rng = np.random.default_rng(seed)
    return lambda obs, env: rng.uniform(-1.0, 1.0, 2).astype(np.float32)


def scripted_act(name: str) -> Act:
    """The scripted attacker ``name`` (``policies.training.ATTACKERS``) in the learner's
    place."""
    factory = attacker_factory(name)
    built: dict[str, Any] = {}

    def act(obs: np.ndarray, env: SingleAttackerEnv) -> np.ndarray:
        state = env.game_state()
        if state.step == 0:
            policy = built.setdefault("policy", factory(env.game.base_scenario))
            policy.reset(env.game.scenario)
        return built["policy"].act(state)[env.learner]

    return act


def model_act(model: PPO) -> Act:
    return lambda obs, env: model.predict(obs, deterministic=True)[0]


def record(kwargs: dict[str, Any], model: PPO, path: Path, seed: int) -> int:
    """One episode of the trained attacker to ``path`` in real time; returns the frames."""
    env = make_attacker_env(**kwargs, render_mode="rgb_array")
    fps = 1.0 / (env.game.base_scenario.dt * kwargs["action_repeat"])
    obs, _ = env.reset(seed=seed)
    with VideoWriter(path, fps) as writer:
        writer.append(env.render())
        terminated = truncated = False
        while not (terminated or truncated):
            obs, _, terminated, truncated, _ = env.step(model.predict(obs, deterministic=True)[0])
            writer.append(env.render())
    env.close()
    return writer.frames


def write_json(path: Path, data: dict[str, Any]) -> None:
    with tempfile.NamedTemporaryFile("w", dir=path.parent, suffix=".tmp", delete=False) as f:
        json.dump(data, f, indent=2)
    os.replace(f.name, path)


def save_model(model: PPO, path: Path) -> None:
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.zip")
    try:
        model.save(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    args = parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(1)
    scenario = training_scenario(args)
    kwargs = env_kwargs(args, scenario)
    if args.defenders == "hj":
        print("loading (or solving and caching) the defenders' HJ tubes ...", flush=True)
        defender_factory("hj", grid1=args.grid1, grid2=args.grid2)(scenario)
    vec_cls = SubprocVecEnv if args.subprocess else DummyVecEnv
    train_envs = make_vec_env(make_attacker_env, n_envs=args.envs, seed=args.seed,
                              env_kwargs=kwargs, vec_env_cls=vec_cls)
    model = PPO("MlpPolicy", train_envs, n_steps=256, batch_size=256, seed=args.seed,
                device="cpu", verbose=0)
    model.learn(args.timesteps, progress_bar=sys.stderr.isatty())
    train_envs.close()
    save_model(model, args.out / "model.zip")

    report: dict[str, Any] = {
        "scenario": scenario.name, "defenders": args.defenders,
        "grids": [args.grid1, args.grid2] if args.defenders == "hj" else None,
        "timesteps": args.timesteps, "seed": args.seed, "action_repeat": args.action_repeat,
        "shaping": args.shaping, "timeout_reward": args.timeout_reward,
        "episodes": args.episodes,
        "eval_seeds": [EVAL_SEED, EVAL_SEED + args.episodes - 1],
    }
    for name, act in (("trained", model_act(model)), ("random", random_act(args.seed)),
                      ("shortest-path", scripted_act("shortest-path"))):
        report[name] = evaluate(kwargs, act, args.episodes)
        print(f"{name:>13}: " + ", ".join(f"{k} {v:.2f}" for k, v in report[name].items()),
              flush=True)
    if not args.no_video:
        frames = record(kwargs, model, args.out / "trained.mp4", EVAL_SEED)
        report["video"] = {"path": str(args.out / "trained.mp4"), "frames": frames}
    write_json(args.out / "report.json", report)
    print(f"wrote {args.out / 'model.zip'}, {args.out / 'report.json'}"
          + ("" if args.no_video else f", {args.out / 'trained.mp4'}"))
    return report


if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:
        sys.exit(130)

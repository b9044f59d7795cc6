"""Train one attacker with Stable-Baselines3 PPO against the HJ defenders, evaluate it
against a random attacker on the same seeded starts, and record a video of it.

The one-attacker recipe (``main(argv) -> report``, ``run``); ``examples/train_attacker_sb3.py``
runs it. Needs the ``rl`` extra (``pip install -e '.[rl]'``: torch and stable-baselines3).

    python examples/train_attacker_sb3.py --out runs/attacker
    python examples/train_attacker_sb3.py --evaluate-only runs/attacker/model.zip

By default the game is ``paper_1v1`` with random starts (``--fixed-starts`` keeps the
scenario's), one env step is held for ``--action-repeat 10`` steps of the game (0.05 s),
the reward has the potential-based progress term (``--shaping 1``), and still being in
play at the time limit scores -1 like a capture (``--timeout-reward -1``: in the game
only arrival wins, so hiding from the defenders earns nothing). The defenders' HJ tubes
are solved once (``--grid1``/``--grid2`` nodes per axis) and cached on disk.

Training runs on the vector env (``--envs`` copies of the game stepped together, the
defenders acting on every copy in one call; ``--single-envs`` uses one Gymnasium env per
copy instead, in this process or with ``--subprocess`` in subprocesses). It prints a line
every ``--print-seconds`` (agent steps, wall time, and over the training episodes ended
since the last line: mean return and arrival rate) and stops at
``--timesteps`` or after ``--max-minutes``, whichever comes first. Then the trained
attacker, a random one and the paper's scripted shortest-path one play the same
``--episodes`` seeded starts, and a closing table gives their arrival, capture and
time-out rates (95% Wilson intervals) and the trained attacker's paired difference in
arrival rate to the other two (95% bootstrap intervals over the seeds).

Writes into ``--out``: ``model.zip`` (the PPO policy), ``curve.csv`` (one row per PPO
rollout), ``report.json`` (the closing table) and ``trained.mp4`` (one episode, real time).
``--evaluate-only MODEL.zip`` skips training and evaluates (and records) a saved model.
Ctrl-C leaves no half-written file.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecMonitor

from policies.learned import (
    DEFAULT_OBSERVATION,
    TRAINING_ATTRIBUTE,
    check_model_file,
    read_sb3,
    training_record,
)
from reachavoid.evaluation import bootstrap_interval, wilson_interval, write_csv
from reachavoid.paths import UsageError, check_outputs, writable_folder
from reachavoid.training.flags import (
    Bounds,
    add_defender_arguments,
    add_reward_arguments,
    check_ranges,
    defender_options,
    reward_options,
)
from reachavoid.training.views import (
    attacker_factory,
    defender_factory,
    make_attacker_env,
    make_attacker_vector_env,
)
from reachavoid_env import AttackerStatus, Scenario, load_scenario
from reachavoid_env.files import atomic_write, one_command, write_json
from reachavoid_env.integrations.vector import sb3_vec_env
from reachavoid_env.vector import MAX_COPIES
from reachavoid_env.video import VideoWriter
from reachavoid_env.wrappers import SingleAttackerEnv

EVAL_SEED = 10_000  # evaluation episode k starts from reset(seed=EVAL_SEED + k)
OUTCOMES = ("arrived", "captured", "timeout")

Act = Callable[[np.ndarray, SingleAttackerEnv], np.ndarray]
RANGES: dict[str, Bounds] = {
    "timesteps": (1, 10**13), "envs": (1, MAX_COPIES), "action_repeat": (1, 1_000_000),
    "episodes": (1, 10**7), "seed": (0, 2**32 - 1), "max_minutes": (0.0, None, True),
    "print_seconds": (0.0, None, True), "shaping": (None, None),
    "timeout_reward": (None, None)}
"""Every number's range (``check_ranges``), checked before any work."""


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
        epilog="Needs the rl extra (torch, stable-baselines3). Writes model.zip, curve.csv, "
               "report.json and trained.mp4 into --out.")
    add_defender_arguments(parser, scenario="paper_1v1")
    parser.add_argument("--fixed-starts", action="store_true",
                        help="keep the scenario's start positions instead of random starts "
                             "every episode")
    parser.add_argument("--timesteps", type=int, default=150_000,
                        help="PPO training steps (default: %(default)s)")
    parser.add_argument("--max-minutes", type=float, default=None,
                        help="stop training after this much wall time (None: no limit)")
    parser.add_argument("--envs", type=int, default=16,
                        help="copies of the game trained on at once (default: %(default)s)")
    parser.add_argument("--single-envs", action="store_true",
                        help="one Gymnasium env per copy (SB3's make_vec_env) instead of the "
                             "vector env")
    parser.add_argument("--subprocess", action="store_true",
                        help="with --single-envs: run them in subprocesses (SubprocVecEnv)")
    add_reward_arguments(parser)
    parser.add_argument("--episodes", type=int, default=200,
                        help="evaluation episodes per attacker (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=0, help="seed (default: %(default)s)")
    parser.add_argument("--print-seconds", type=float, default=30.0,
                        help="wall seconds between progress lines (default: %(default)s)")
    parser.add_argument("--out", type=Path, default=Path("runs/attacker"),
                        help="output folder (default: %(default)s)")
    parser.add_argument("--evaluate-only", type=Path, default=None, metavar="MODEL.zip",
                        help="skip training: evaluate (and record) this saved model")
    parser.add_argument("--no-video", action="store_true", help="skip the video")
    parser.add_argument("--force", action="store_true",
                        help="replace output files that exist (default: refuse, before any work)")
    args = parser.parse_args(argv)
    check_ranges(parser, args, RANGES)
    if args.evaluate_only is not None:
        try:
            check_model_file(args.evaluate_only, "--evaluate-only")
        except ValueError as err:
            parser.error(str(err))
    written = [("--out", args.out / "report.json")]
    if args.evaluate_only is None:
        written += [("--out", args.out / "model.zip"), ("--out", args.out / "curve.csv")]
    if not args.no_video:
        written.append(("--out", args.out / "trained.mp4"))
    try:
        check_outputs(written, args.force, writable_folder(str(args.out), "--out"))
    except UsageError as err:
        parser.error(str(err))
    return args


def training_scenario(args: argparse.Namespace) -> Scenario:
    scenario = load_scenario(args.scenario)
    if args.fixed_starts:
        return scenario
    return scenario.with_players(scenario.num_attackers, scenario.num_defenders)


def env_kwargs(args: argparse.Namespace, scenario: Scenario) -> dict[str, Any]:
    return {"scenario": scenario, "defenders": args.defenders,
            "defender_options": defender_options(args), **reward_options(args)}


class Progress(BaseCallback):
    """One row per PPO rollout (agent steps, wall seconds, and over the training episodes
    that ended in it: count, mean return, arrival rate); a printed line every
    ``print_seconds``; stops training after ``max_seconds``."""

    def __init__(self, print_seconds: float, max_seconds: float | None) -> None:
        super().__init__()
        self.print_seconds, self.max_seconds = print_seconds, max_seconds
        self.rows: list[dict[str, float]] = []
        self._returns: list[float] = []
        self._arrived: list[bool] = []

    def _on_training_start(self) -> None:
        self.start = self.printed = time.perf_counter()

    def _on_step(self) -> bool:
        for info in self.locals["infos"]:
            if "episode" in info:    # Monitor's summary, on the step that ends an episode
                self._returns.append(float(info["episode"]["r"]))
                self._arrived.append(bool(info.get("is_success", False)))
        return self.max_seconds is None or time.perf_counter() - self.start < self.max_seconds

    def _on_rollout_end(self) -> None:
        now = time.perf_counter()
        row = {"timesteps": self.num_timesteps, "seconds": round(now - self.start, 1),
               "episodes": len(self._returns),
               "mean_return": float(np.mean(self._returns)) if self._returns else float("nan"),
               "arrived_rate": float(np.mean(self._arrived)) if self._arrived else float("nan")}
        self.rows.append(row)
        self._returns, self._arrived = [], []
        if now - self.printed >= self.print_seconds:
            self.printed = now
            recent = self.rows[-10:]
            print(f"{row['timesteps']:>9,} steps {row['seconds'] / 60:5.1f} min  last "
                  f"{sum(r['episodes'] for r in recent)} episodes: return "
                  f"{np.nanmean([r['mean_return'] for r in recent]):+.3f}, arrived "
                  f"{np.nanmean([r['arrived_rate'] for r in recent]):.1%}", flush=True)


def evaluate(kwargs: dict[str, Any], act: Act, episodes: int) -> list[str]:
    """How the attacker ``act`` ended (one of ``OUTCOMES``) from each seeded evaluation
    start, in seed order."""
    env = make_attacker_env(**kwargs)
    outcomes = []
    for k in range(episodes):
        obs, _ = env.reset(seed=EVAL_SEED + k)
        terminated = truncated = False
        while not (terminated or truncated):
            obs, _, terminated, truncated, info = env.step(act(obs, env))
        status = AttackerStatus.from_code(info["status"])
        outcomes.append("timeout" if status is AttackerStatus.ACTIVE else status.value)
    env.close()
    return outcomes


def rates(outcomes: list[str]) -> dict[str, Any]:
    """Each outcome's rate and 95% Wilson interval."""
    summary: dict[str, Any] = {}
    for outcome in OUTCOMES:
        count = outcomes.count(outcome)
        summary[f"{outcome}_rate"] = count / len(outcomes)
        summary[f"{outcome}_ci"] = [round(x, 4) for x in wilson_interval(count, len(outcomes))]
    return summary


def paired_arrival_difference(first: list[str], second: list[str]) -> dict[str, Any]:
    """Arrival rate of ``first`` minus ``second`` on the same seeds, with a 95% bootstrap
    interval over the seeds."""
    differences = [float(a == "arrived") - float(b == "arrived")
                   for a, b in zip(first, second, strict=True)]
    low, high = bootstrap_interval(differences)
    return {"difference": float(np.mean(differences)), "ci": [round(low, 4), round(high, 4)]}


def random_act(seed: int) -> Act:
    rng = np.random.default_rng(seed)
    return lambda obs, env: rng.uniform(-1.0, 1.0, 2).astype(np.float32)


def scripted_act(name: str) -> Act:
    """The scripted attacker ``name`` (``policies.registry.ATTACKERS``) in the learner's
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
    """One episode of the trained attacker to ``path`` in real time (the env's
    ``render_fps``: one frame per agent step); returns the frames."""
    env = make_attacker_env(**kwargs, render_mode="rgb_array")
    obs, _ = env.reset(seed=seed)
    with VideoWriter(path, env.metadata["render_fps"]) as writer:
        writer.append(env.render())
        terminated = truncated = False
        while not (terminated or truncated):
            obs, _, terminated, truncated, _ = env.step(model.predict(obs, deterministic=True)[0])
            writer.append(env.render())
    env.close()
    return writer.frames


def training_envs(args: argparse.Namespace, kwargs: dict[str, Any]) -> Any:
    """The SB3 ``VecEnv`` of ``--envs`` copies: the vector env (under ``VecMonitor``), or one
    Gymnasium env per copy with ``--single-envs``."""
    if args.single_envs:
        vec_cls = SubprocVecEnv if args.subprocess else DummyVecEnv
        return make_vec_env(make_attacker_env, n_envs=args.envs, seed=args.seed,
                            env_kwargs=kwargs, vec_env_cls=vec_cls)
    starts = "scenario" if args.fixed_starts else "random"
    view = make_attacker_vector_env(num_envs=args.envs, starts=starts, **kwargs)
    envs = sb3_vec_env(view)
    envs.seed(args.seed)
    return VecMonitor(envs)


def train(args: argparse.Namespace, kwargs: dict[str, Any]) -> tuple[PPO, Progress]:
    train_envs = training_envs(args, kwargs)
    model = PPO("MlpPolicy", train_envs, n_steps=256, batch_size=256, seed=args.seed,
                device="cpu", verbose=0)
    progress = Progress(args.print_seconds,
                        None if args.max_minutes is None else 60.0 * args.max_minutes)
    try:
        model.learn(args.timesteps, callback=progress, progress_bar=sys.stderr.isatty())
    finally:
        train_envs.close()
    return model, progress


def print_table(report: dict[str, Any]) -> None:
    print(f"{report['episodes']} seeded starts (seeds {report['eval_seeds'][0]}.."
          f"{report['eval_seeds'][1]}), {report['scenario']}, {report['defenders']} defenders")
    print(f"  {'attacker':<14} {'arrived [95% CI]':<22} {'captured':>9} {'timeout':>9}")
    for name in ("trained", "random", "shortest-path"):
        row = report[name]
        low, high = row["arrived_ci"]
        print(f"  {name:<14} {row['arrived_rate']:6.1%} [{low:.1%}, {high:.1%}]   "
              f"{row['captured_rate']:9.1%} {row['timeout_rate']:9.1%}")
    for other in ("random", "shortest-path"):
        paired = report[f"trained_minus_{other}"]
        print(f"  trained - {other}: {paired['difference']:+.1%} "
              f"[{paired['ci'][0]:+.1%}, {paired['ci'][1]:+.1%}] (paired)")


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    with one_command():
        return run(parse_args(argv))


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Train (or load) and evaluate as ``args`` (checked by ``parse_args``) say; write."""
    args.out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(1)
    scenario = training_scenario(args)
    kwargs = env_kwargs(args, scenario)
    if args.defenders == "hj":
        print("loading (or solving and caching) the defenders' HJ tubes ...", flush=True)
        defender_factory("hj", grid1=args.grid1, grid2=args.grid2)(scenario)
    report: dict[str, Any] = {
        "scenario": scenario.name, "defenders": args.defenders,
        "grids": [args.grid1, args.grid2] if args.defenders == "hj" else None,
        "seed": args.seed, "action_repeat": args.action_repeat,
        "shaping": args.shaping, "timeout_reward": args.timeout_reward,
        "episodes": args.episodes,
        "eval_seeds": [EVAL_SEED, EVAL_SEED + args.episodes - 1],
    }
    if args.evaluate_only is None:
        model, progress = train(args, kwargs)
        setattr(model, TRAINING_ATTRIBUTE, training_record(
            DEFAULT_OBSERVATION, action_repeat=args.action_repeat, scenario=scenario.name))
        with atomic_write(args.out / "model.zip", "wb") as handle:
            model.save(handle)
        write_csv(args.out / "curve.csv", progress.rows)
        report.update(timesteps=model.num_timesteps,
                      training_seconds=progress.rows[-1]["seconds"])
    else:
        try:
            model = read_sb3(args.evaluate_only, "--evaluate-only")
        except ValueError as err:   # not SB3's, damaged, or weights not finite
            print(f"{Path(sys.argv[0]).name}: error: {err}", file=sys.stderr)
            raise SystemExit(2) from None
        report.update(model=str(args.evaluate_only))
    outcomes = {name: evaluate(kwargs, act, args.episodes)
                for name, act in (("trained", model_act(model)),
                                  ("random", random_act(args.seed)),
                                  ("shortest-path", scripted_act("shortest-path")))}
    report.update({name: rates(found) for name, found in outcomes.items()})
    for other in ("random", "shortest-path"):
        report[f"trained_minus_{other}"] = paired_arrival_difference(outcomes["trained"],
                                                                      outcomes[other])
    print_table(report)
    if not args.no_video:
        frames = record(kwargs, model, args.out / "trained.mp4", EVAL_SEED)
        report["video"] = {"path": str(args.out / "trained.mp4"), "frames": frames}
    write_json(args.out / "report.json", report)
    print(f"wrote into {args.out}/: " + ", ".join(
        sorted(p.name for p in args.out.iterdir() if not p.name.startswith("."))))
    return report


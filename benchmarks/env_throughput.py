"""Environment throughput: reach-avoid paper_8v4 against MPE simple_tag (12 agents each).

Measures, in one run:

- parallel ``step`` calls per second with random actions and no rendering, for
  ``paper_8v4`` (8 attackers, 4 defenders; v0's global observation, ``--observation v1``
  for the egocentric one) and for ``mpe2.simple_tag_v3`` with 8 good
  agents, 4 adversaries, 2 obstacles and continuous actions. Both run 1000-step episodes
  (resets included). Actions are drawn beforehand ("step only") and, separately, by
  ``action_space(agent).sample()`` inside the loop ("with sampling");
- ``render()`` frames per second in ``rgb_array`` mode (``paper_8v4``, 640 px wide);
- MP4 encoding frames per second through ``reachavoid_env.video.VideoWriter``.

Each figure is the best and the median of ``--repeats`` timed runs (the machine is shared;
the best is the least disturbed). ``--profile`` prints where an env step spends its time.
``--against DIR [DIR ...]`` compares the step-only rate of this tree with the checkouts in
``DIR`` (other revisions, e.g. ``git worktree add /tmp/base HEAD~1``) side by side: each
of ``--repeats`` rounds runs one fresh process per tree (``cd`` into it, ``PYTHONPATH``
set to it, this script's harness) and one for MPE, so every tree's ratio to MPE is taken
within its round.

    SDL_VIDEODRIVER=dummy .venv/bin/python benchmarks/env_throughput.py [--steps 5000]
    taskset -c 0 .venv/bin/python benchmarks/env_throughput.py --against /tmp/base \\
        --repeats 7 --json benchmarks/results/env_side_by_side.json

``--json PATH`` writes the figures as a result record (``benchmarks/result_file.py``):
``steps_per_s.*`` and ``ratio`` (best runs), or with ``--against``, per tree (``this_tree``,
the others by their short commit) and for MPE, ``steps_per_cpu_s.*`` and the per-round
``ratio_to_mpe.*`` as ``[median, lowest, highest]`` over the rounds, and each other tree's
``relative_to_this_tree.*`` (median over median).
"""

from __future__ import annotations

import argparse
import cProfile
import inspect
import os
import platform
import pstats
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import reachavoid_env  # noqa: E402
from reachavoid_env.video import VideoWriter  # noqa: E402

EPISODE_STEPS = 1000


OBSERVATION = "v0"
"""The observation measured (``--observation``): v0's global vector (the only one before
v1, so older trees compare like with like) or v1's egocentric one."""


def make_reachavoid(render_mode: str | None = None):
    options: dict = {}
    if "observation" in inspect.signature(reachavoid_env.ReachAvoidEnv).parameters:
        options["observation"] = {"egocentric": OBSERVATION == "v1"}
    elif OBSERVATION == "v1":
        sys.exit(f"{reachavoid_env.__file__}: this revision has no v1 observation")
    return reachavoid_env.parallel_env(scenario="paper_8v4", max_cycles=EPISODE_STEPS,
                                       render_mode=render_mode, **options)


def make_mpe():
    from mpe2 import simple_tag_v3

    return simple_tag_v3.parallel_env(num_good=8, num_adversaries=4, num_obstacles=2,
                                      continuous_actions=True, max_cycles=EPISODE_STEPS)


def random_actions(env, steps: int, seed: int) -> list[dict[str, np.ndarray]]:
    """Pre-drawn actions for every possible agent, one dict per step."""
    rng = np.random.default_rng(seed)
    draws = []
    for _ in range(steps):
        actions = {}
        for agent in env.possible_agents:
            space = env.action_space(agent)
            actions[agent] = rng.uniform(space.low, space.high).astype(space.dtype)
        draws.append(actions)
    return draws


def run_steps(env, actions: list[dict[str, np.ndarray]] | None, steps: int,
              clock: Callable[[], float] = time.perf_counter) -> float:
    """Seconds of ``clock`` for ``steps`` parallel steps (resetting when an episode ends)."""
    env.reset(seed=0)
    start = clock()
    for k in range(steps):
        if not env.agents:
            env.reset()
        live = env.agents
        if actions is None:
            step_actions = {agent: env.action_space(agent).sample() for agent in live}
        else:
            drawn = actions[k]
            step_actions = {agent: drawn[agent] for agent in live}
        env.step(step_actions)
    return clock() - start


def rate(label: str, work: Callable[[], float], count: int, repeats: int) -> dict[str, float]:
    """Best and median of ``count / seconds`` over ``repeats`` runs."""
    rates = [count / work() for _ in range(repeats)]
    result = {"best": max(rates), "median": statistics.median(rates)}
    print(f"{label:<50} best {result['best']:>9,.0f}/s   median {result['median']:>9,.0f}/s",
          flush=True)
    return result


def render_fps(frames: int) -> tuple[Callable[[], float], list[np.ndarray]]:
    env = make_reachavoid(render_mode="rgb_array")
    env.reset(seed=0)
    rng = np.random.default_rng(1)
    kept: list[np.ndarray] = []

    def work() -> float:
        env.reset(seed=0)
        kept.clear()
        seconds = 0.0
        for _ in range(frames):
            env.step({agent: rng.uniform(-1, 1, 2).astype(np.float32) for agent in env.agents})
            start = time.perf_counter()
            kept.append(env.render())
            seconds += time.perf_counter() - start
        return seconds

    return work, kept


def encode_fps(frames: list[np.ndarray], fps: int) -> Callable[[], float]:
    def work() -> float:
        with tempfile.TemporaryDirectory() as folder:
            start = time.perf_counter()
            with VideoWriter(Path(folder) / "bench.mp4", fps) as writer:
                for frame in frames:
                    writer.append(frame)
            return time.perf_counter() - start

    return work


def profile(steps: int) -> None:
    env = make_reachavoid()
    actions = random_actions(env, steps, seed=2)
    profiler = cProfile.Profile()
    profiler.enable()
    run_steps(env, actions, steps)
    profiler.disable()
    print(f"\ncProfile of {steps} paper_8v4 steps (tottime, top 20):")
    pstats.Stats(profiler).sort_stats("tottime").print_stats(20)


def step_rate(make: Callable[[], object], steps: int) -> float:
    """Step-only steps per CPU second of the env ``make`` builds (process time, which other
    jobs on a shared machine disturb less than wall time), best of three runs in this
    process."""
    env = make()
    actions = random_actions(env, steps, seed=0)
    return max(steps / run_steps(env, actions, steps, time.process_time) for _ in range(3))


def short_commit(tree: Path) -> str:
    """The commit checked out in ``tree``, short (``+dirty`` with uncommitted changes)."""
    try:
        head = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"],
                              check=True, capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(tree), "status", "--porcelain",
                                "--untracked-files=no"], check=True, capture_output=True,
                               text=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return tree.name
    return head + ("+dirty" if dirty else "")


def child_rate(tree: Path, option: str, steps: int) -> float:
    """One fresh process of this script in ``tree`` (its ``reachavoid_env``) printing the
    step-only rate ``option`` measures."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    done = subprocess.run([sys.executable, str(Path(__file__).resolve()), option, str(steps),
                           "--observation", OBSERVATION],
                          env=env, cwd=tree, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{option} in {tree} failed:\n{done.stderr}")
    return float(done.stdout)


def spread(values: list[float]) -> list[float]:
    """``[median, lowest, highest]``: a figure with its range over the rounds."""
    return [statistics.median(values), min(values), max(values)]


def against(others: list[Path], steps: int, mpe_steps: int, rounds: int) -> dict:
    """Step-only rates of this tree, of ``others`` and of MPE in alternating fresh
    processes, ``rounds`` rounds; each tree's ratio to the MPE run of the same round. The
    figures of the result record."""
    here = Path(__file__).resolve().parents[1]
    trees = {"this_tree": here} | {short_commit(other): other.resolve() for other in others}
    rates: dict[str, list[float]] = {name: [] for name in trees}
    mpe: list[float] = []
    for round_ in range(rounds):
        for name, tree in trees.items():
            rates[name].append(child_rate(tree, "--only-steps", steps))
        mpe.append(child_rate(here, "--only-mpe", mpe_steps))
        print(f"round {round_ + 1}: " + ", ".join(f"{name} {values[-1]:,.0f}/s"
                                                 for name, values in rates.items())
              + f", MPE {mpe[-1]:,.0f}/s; load average {os.getloadavg()[0]:.2f}", flush=True)
    figures: dict = {"steps_per_cpu_s.mpe_simple_tag": spread(mpe)}
    ours = statistics.median(rates["this_tree"])
    print(f"\n{'tree':<16} {'median':>9} {'best':>9}  ratio to MPE, median (range)  "
          f"/ this tree   ({OBSERVATION} observation, steps per CPU second)")
    for name, values in rates.items():
        ratios = spread([rate / base for rate, base in zip(values, mpe, strict=True)])
        figures[f"steps_per_cpu_s.{name}"] = spread(values)
        figures[f"ratio_to_mpe.{name}"] = ratios
        relative = statistics.median(values) / ours
        if name != "this_tree":
            figures[f"relative_to_this_tree.{name}"] = relative
        print(f"{name:<16} {statistics.median(values):>9,.0f} {max(values):>9,.0f}  "
              f"{ratios[0]:>5.1f}x ({ratios[1]:.1f}-{ratios[2]:.1f}){'':>12}{relative:.3f}")
    print(f"MPE simple_tag 8+4: median {statistics.median(mpe):,.0f}/s")
    return figures


def main() -> None:
    global OBSERVATION
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=5000, help="steps per timed run")
    parser.add_argument("--mpe-steps", type=int, default=1000, help="MPE steps per timed run")
    parser.add_argument("--frames", type=int, default=300, help="frames to render and encode")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per figure")
    parser.add_argument("--profile", action="store_true", help="cProfile an env run too")
    parser.add_argument("--against", type=Path, metavar="DIR", nargs="+",
                        help="compare the step rate with other checkouts, side by side")
    parser.add_argument("--observation", choices=("v0", "v1"), default=OBSERVATION,
                        help="v0's global vector (default; every revision has it) or v1's "
                             "egocentric observation")
    parser.add_argument("--only-steps", type=int, metavar="N", help=argparse.SUPPRESS)
    parser.add_argument("--only-mpe", type=int, metavar="N", help=argparse.SUPPRESS)
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    args = parser.parse_args()
    OBSERVATION = args.observation
    if args.only_steps:
        print(step_rate(make_reachavoid, args.only_steps))
        return
    if args.only_mpe:
        print(step_rate(make_mpe, args.only_mpe))
        return

    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}; load average "
          f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}")
    # imported here: ``--only-steps`` runs this file under another tree's PYTHONPATH
    from result_file import write_result

    if args.against is not None:
        figures = against(args.against, args.steps, args.mpe_steps, args.repeats)
        if args.json:
            write_result(args.json, "env_throughput", figures, {
                "steps_per_cpu_s": f"paper_8v4 parallel env ({OBSERVATION} observation) and "
                                   "MPE simple_tag 8+4 steps per CPU second, random actions "
                                   "drawn beforehand, best of 3 runs per process: [median, "
                                   "lowest, highest] over the rounds; trees by short commit",
                "ratio_to_mpe": "a tree's steps per CPU second over MPE's in the same "
                                "round: [median, lowest, highest]",
                "relative_to_this_tree": "a tree's median over this tree's"})
        return
    ours, mpe = make_reachavoid(), make_mpe()
    ours_actions = random_actions(ours, args.steps, seed=0)
    mpe_actions = random_actions(mpe, args.mpe_steps, seed=0)
    r = args.repeats
    ours_step = rate("reach-avoid paper_8v4, step only",
                     lambda: run_steps(ours, ours_actions, args.steps), args.steps, r)
    rate("reach-avoid paper_8v4, with sampling",
         lambda: run_steps(ours, None, args.steps), args.steps, r)
    mpe_step = rate("MPE simple_tag 8 good/4 adv/2 obst, step only",
                    lambda: run_steps(mpe, mpe_actions, args.mpe_steps), args.mpe_steps, r)
    rate("MPE simple_tag 8 good/4 adv/2 obst, with sampling",
         lambda: run_steps(mpe, None, args.mpe_steps), args.mpe_steps, r)
    print(f"ratio (step only): best {ours_step['best'] / mpe_step['best']:.1f}x, "
          f"median {ours_step['median'] / mpe_step['median']:.1f}x  (goal: 20x)")
    if args.json:
        write_result(args.json, "env_throughput", {
            "steps_per_s.reachavoid_8v4": ours_step["best"],
            "steps_per_s.mpe_simple_tag": mpe_step["best"],
            "ratio": ours_step["best"] / mpe_step["best"]}, {
            "steps_per_s": "best of --repeats runs, 12 agents, actions drawn beforehand",
            "ratio": "reach-avoid over MPE simple_tag"})
    work, frames = render_fps(args.frames)
    rate("render rgb_array paper_8v4 (frames)", work, args.frames, r)
    print(f"  frame size {frames[0].shape[1]}x{frames[0].shape[0]}")
    rate("MP4 encode via VideoWriter (frames)",
         encode_fps(frames, reachavoid_env.ReachAvoidEnv.metadata["render_fps"]), len(frames),
         min(r, 3))
    if args.profile:
        profile(args.steps)


if __name__ == "__main__":
    main()

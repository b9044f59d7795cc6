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
the best is the least disturbed; ``harness.timed``). ``--profile`` prints where an env step
spends its time. ``--against REV [REV ...]`` compares the step-only rate of this tree with
other checkouts (folders, e.g. a ``git worktree``, or revisions: ``harness.checkout``)
side by side: each of ``--repeats`` rounds runs one fresh process per tree (that tree first
on the path, this script's ``step_rate``: ``harness.side_by_side``) and one for MPE, so
every tree's ratio to MPE is taken within its round.

    SDL_VIDEODRIVER=dummy .venv/bin/python benchmarks/env_throughput.py [--steps 5000]
    taskset -c 0 .venv/bin/python benchmarks/env_throughput.py --against HEAD~1 \\
        --repeats 7 --json benchmarks/results/env_side_by_side.json

``--json PATH`` writes the figures as a result record (``benchmarks/result_file.py``):
``steps_per_s.*`` and ``ratio`` (best runs), or with ``--against``, per tree (``this_tree``,
the others by their short commit) and for MPE, ``steps_per_cpu_s.*`` and the per-round
``ratio_to_mpe.*`` as ``[median, lowest, highest]`` over the rounds, and each other tree's
``relative_to_this_tree.*`` (median over median).
"""

from __future__ import annotations

import argparse
import contextlib
import cProfile
import inspect
import os
import platform
import pstats
import statistics
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
from harness import CPU, ROOT, WALL, Job, Timing, checkout, commit_of, side_by_side, spread, timed

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


def run_steps(env, actions: list[dict[str, np.ndarray]] | None, steps: int) -> int:
    """``steps`` parallel steps from a reset (resetting when an episode ends): the steps."""
    env.reset(seed=0)
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
    return steps


def rate(label: str, work: Callable[[], float], repeats: int,
         untimed: Callable[[], float] | None = None) -> Timing:
    """``repeats`` wall-clock runs of ``work`` (``harness.timed``), best and median printed."""
    timing = timed(work, repeats, clock=WALL, untimed=untimed)
    print(f"{label:<50} best {timing.best:>9,.0f}/s   median {timing.median:>9,.0f}/s",
          flush=True)
    return timing


def render_frames(frames: int) -> tuple[Callable[[], int], Callable[[], float],
                                        list[np.ndarray]]:
    """Work drawing ``frames`` frames of an episode, the seconds of its steps (untimed), and
    the frames drawn."""
    env = make_reachavoid(render_mode="rgb_array")
    env.reset(seed=0)
    rng = np.random.default_rng(1)
    kept: list[np.ndarray] = []
    stepping = [0.0]

    def work() -> int:
        env.reset(seed=0)
        kept.clear()
        stepping[0] = 0.0
        for _ in range(frames):
            start = WALL()
            env.step({agent: rng.uniform(-1, 1, 2).astype(np.float32) for agent in env.agents})
            stepping[0] += WALL() - start
            kept.append(env.render())
        return frames

    return work, lambda: stepping[0], kept


def encode_frames(frames: list[np.ndarray], fps: int) -> Callable[[], int]:
    """Work encoding ``frames`` to an MP4 file."""
    def work() -> int:
        with tempfile.TemporaryDirectory() as folder:
            with VideoWriter(Path(folder) / "bench.mp4", fps) as writer:
                for frame in frames:
                    writer.append(frame)
        return len(frames)

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


def step_rate(game: str, steps: int, observation: str) -> float:
    """Step-only steps per CPU second of ``game`` (``reachavoid``: paper_8v4 with
    ``observation``; ``mpe``: simple_tag 8+4), best of three runs in this process (process
    time, which other jobs on a shared machine disturb less than wall time)."""
    global OBSERVATION
    OBSERVATION = observation
    env = make_reachavoid() if game == "reachavoid" else make_mpe()
    actions = random_actions(env, steps, seed=0)
    return timed(lambda: run_steps(env, actions, steps), 3, clock=CPU).best


def against(others: list[str], steps: int, mpe_steps: int, rounds: int) -> dict:
    """Step-only rates of this tree, of ``others`` and of MPE in alternating fresh
    processes, ``rounds`` rounds; each tree's ratio to the MPE run of the same round. The
    figures of the result record."""
    with contextlib.ExitStack() as stack:
        trees = {"this_tree": ROOT} | {commit_of(other) or Path(other).name:
                                       stack.enter_context(checkout(other))
                                       for other in others}
        jobs = {name: Job(tree, "env_throughput:step_rate", ("reachavoid", steps, OBSERVATION))
                for name, tree in trees.items()}
        jobs["mpe"] = Job(ROOT, "env_throughput:step_rate", ("mpe", mpe_steps, OBSERVATION))
        rates = side_by_side(jobs, rounds)
    mpe = rates.pop("mpe")
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
    parser.add_argument("--against", metavar="REV", nargs="+",
                        help="compare the step rate with other checkouts (folders or "
                             "revisions), side by side")
    parser.add_argument("--observation", choices=("v0", "v1"), default=OBSERVATION,
                        help="v0's global vector (default; every revision has it) or v1's "
                             "egocentric observation")
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    args = parser.parse_args()
    OBSERVATION = args.observation

    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}; load average "
          f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}")
    # imported here: ``step_rate`` runs in other trees, which may lack what it imports
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
                     lambda: run_steps(ours, ours_actions, args.steps), r)
    rate("reach-avoid paper_8v4, with sampling", lambda: run_steps(ours, None, args.steps), r)
    mpe_step = rate("MPE simple_tag 8 good/4 adv/2 obst, step only",
                    lambda: run_steps(mpe, mpe_actions, args.mpe_steps), r)
    rate("MPE simple_tag 8 good/4 adv/2 obst, with sampling",
         lambda: run_steps(mpe, None, args.mpe_steps), r)
    print(f"ratio (step only): best {ours_step.best / mpe_step.best:.1f}x, "
          f"median {ours_step.median / mpe_step.median:.1f}x  (goal: 20x)")
    if args.json:
        write_result(args.json, "env_throughput", {
            "steps_per_s.reachavoid_8v4": ours_step.best,
            "steps_per_s.mpe_simple_tag": mpe_step.best,
            "ratio": ours_step.best / mpe_step.best}, {
            "steps_per_s": "best of --repeats runs, 12 agents, actions drawn beforehand",
            "ratio": "reach-avoid over MPE simple_tag"})
    work, stepping, frames = render_frames(args.frames)
    rate("render rgb_array paper_8v4 (frames)", work, r, untimed=stepping)
    print(f"  frame size {frames[0].shape[1]}x{frames[0].shape[0]}")
    rate("MP4 encode via VideoWriter (frames)",
         encode_frames(frames, reachavoid_env.ReachAvoidEnv.metadata["render_fps"]), min(r, 3))
    if args.profile:
        profile(args.steps)


if __name__ == "__main__":
    main()

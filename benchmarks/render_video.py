"""Rendering and video speed: frame drawing, RGB readout, MP4/GIF encoding, a recorded episode.

Run: ``SDL_VIDEODRIVER=dummy python benchmarks/render_video.py [--runs 3] [--json PATH]``
(BENCHMARKS.md, "Rendering and video"). Each run prints its figures; ``--json`` writes the
lowest and highest over the runs as a result record (``benchmarks/result_file.py``).
"""

from __future__ import annotations

import argparse
import functools
import tempfile
from pathlib import Path

from harness import WALL, once, timed
from result_file import write_result

import reachavoid_env
from policies import GreedyDefender, IdleDefender, RandomAttacker, StraightAttacker
from reachavoid.rollout import merged_overlay, run_episode
from reachavoid_env.render import Renderer
from reachavoid_env.video import VideoWriter


def played_frames(count: int) -> tuple[reachavoid_env.ReachAvoidEnv, list, list]:
    """States and overlays of a paper_6v2 episode (straight vs greedy), looped to ``count``."""
    env = reachavoid_env.parallel_env(scenario="paper_6v2", render_mode="rgb_array")
    env.reset(seed=0)
    attackers, defenders = StraightAttacker(), GreedyDefender()
    attackers.reset(env.scenario)
    defenders.reset(env.scenario)
    states, overlays = [], []
    while env.agents:
        state = env.game_state()
        actions = {**attackers.act(state), **defenders.act(state)}
        states.append(state)
        overlays.append(merged_overlay(attackers, defenders))
        env.step({a: actions[a] for a in env.agents})
    reps = -(-count // len(states))
    return env, (states * reps)[:count], (overlays * reps)[:count]


def measure(count: int) -> dict[str, float]:
    """One run: draw, readout, encodes and episodes; each figure printed and returned."""
    env, states, overlays = played_frames(count)
    renderer = Renderer(env.scenario.map, env.scenario.capture_radius)
    draw = readout = 0.0
    # Each frame is dropped after readout, as when streaming to a video.
    for state, overlay in zip(states, overlays, strict=True):
        draw += once(functools.partial(renderer.draw, state, overlay))[1]
        readout += once(renderer.rgb_array)[1]
    renderer.reset()
    frames = []
    for state, overlay in zip(states, overlays, strict=True):
        renderer.draw(state, overlay)
        frames.append(renderer.rgb_array())
    height, width = frames[0].shape[:2]
    print(f"frame {width}x{height}: draw {draw / count * 1e3:.2f} ms, "
          f"rgb_array {readout / count * 1e3:.2f} ms")
    figures = {"draw_ms": draw / count * 1e3, "rgb_array_ms": readout / count * 1e3}
    with tempfile.TemporaryDirectory() as folder:
        for suffix in (".mp4", ".gif"):
            path = Path(folder) / f"bench{suffix}"

            def encode(path: Path = path) -> int:
                with VideoWriter(path, fps=50) as writer:
                    for frame in frames:
                        writer.append(frame)
                return len(frames)

            rate = timed(encode, clock=WALL).median
            print(f"{suffix[1:]} encode: {rate:.0f} frames/s "
                  f"({path.stat().st_size / count / 1e3:.1f} kB/frame)")
            figures[f"{suffix[1:]}_frames_per_s"] = rate
        for video in (None, Path(folder) / "episode.mp4"):
            env = reachavoid_env.parallel_env(scenario="paper_6v2", max_cycles=count,
                                              render_mode="rgb_array")
            result = run_episode(env, RandomAttacker(0), IdleDefender(), seed=0, video=video)
            label = "with MP4" if video else "no video"
            print(f"run_episode paper_6v2, {result.steps} steps, {label}: "
                  f"{result.steps / result.seconds:.0f} steps/s")
            key = "episode_with_mp4" if video else "episode"
            figures[f"{key}_steps_per_s"] = result.steps / result.seconds
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=300, help="frames drawn and encoded")
    parser.add_argument("--runs", type=int, default=3, help="runs (the machine is shared)")
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    args = parser.parse_args()
    runs = [measure(args.frames) for _ in range(args.runs)]
    if args.json:
        figures = {f"{key}.{end}": pick(run[key] for run in runs)
                   for key in runs[0] for end, pick in (("lowest", min), ("highest", max))}
        write_result(args.json, "render_video", figures, {
            "draw_ms": "Renderer.draw of a paper_6v2 frame, milliseconds, over the runs",
            "rgb_array_ms": "Renderer.rgb_array, milliseconds",
            "mp4_frames_per_s": "libx264 veryfast encode, frames streamed",
            "gif_frames_per_s": "GIF encode, frames streamed",
            "episode_steps_per_s": "run_episode without video",
            "episode_with_mp4_steps_per_s": "run_episode writing an MP4 of every step"})


if __name__ == "__main__":
    main()

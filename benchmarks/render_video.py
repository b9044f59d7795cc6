"""Rendering and video speed: frame drawing, RGB readout, MP4/GIF encoding, a recorded episode.

Run: ``SDL_VIDEODRIVER=dummy python benchmarks/render_video.py`` (figures in BENCHMARKS.md,
section "Rendering and video").
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

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


def main() -> None:
    count = 300
    env, states, overlays = played_frames(count)
    renderer = Renderer(env.scenario.map, env.scenario.capture_radius)
    draw = readout = 0.0
    # Each frame is dropped after readout, as when streaming to a video.
    for state, overlay in zip(states, overlays, strict=True):
        start = time.perf_counter()
        renderer.draw(state, overlay)
        middle = time.perf_counter()
        renderer.rgb_array()
        draw, readout = draw + middle - start, readout + time.perf_counter() - middle
    renderer.reset()
    frames = []
    for state, overlay in zip(states, overlays, strict=True):
        renderer.draw(state, overlay)
        frames.append(renderer.rgb_array())
    height, width = frames[0].shape[:2]
    print(f"frame {width}x{height}: draw {draw / count * 1e3:.2f} ms, "
          f"rgb_array {readout / count * 1e3:.2f} ms")
    with tempfile.TemporaryDirectory() as folder:
        for suffix in (".mp4", ".gif"):
            path = Path(folder) / f"bench{suffix}"
            start = time.perf_counter()
            with VideoWriter(path, fps=50) as writer:
                for frame in frames:
                    writer.append(frame)
            seconds = time.perf_counter() - start
            print(f"{suffix[1:]} encode: {count / seconds:.0f} frames/s "
                  f"({path.stat().st_size / count / 1e3:.1f} kB/frame)")
        for video in (None, Path(folder) / "episode.mp4"):
            env = reachavoid_env.parallel_env(scenario="paper_6v2", max_cycles=count,
                                              render_mode="rgb_array")
            result = run_episode(env, RandomAttacker(0), IdleDefender(), seed=0, video=video)
            label = "with MP4" if video else "no video"
            print(f"run_episode paper_6v2, {result.steps} steps, {label}: "
                  f"{result.steps / result.seconds:.0f} steps/s")


if __name__ == "__main__":
    main()

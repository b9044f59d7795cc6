"""Play the paper's 6 vs 2 game with simple policies and record it, two ways.

1. ``run_episode``: the library's episode loop (what ``reachavoid play`` runs).
2. A hand-written PettingZoo loop wrapped in ``RecordEpisode``, for any policy or trainer.

    python examples/play_and_record.py [OUT_FOLDER]

Writes ``paper_6v2_greedy.mp4`` and ``paper_6v2_loop.gif`` into ``OUT_FOLDER`` (default: the
current folder); works without a display.
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import reachavoid_env
from policies import GreedyDefender, StraightAttacker
from reachavoid.rollout import run_episode
from reachavoid_env.video import RecordEpisode


@dataclass
class Config:
    # the folder for the videos, a positional argument (nargs "?"): the current one if left out
    out: Path = field(default=Path.cwd(), metadata={
        "nargs": "?", "help": "folder for the two videos"})


def with_run_episode(folder: Path) -> None:
    env = reachavoid_env.parallel_env(scenario="paper_6v2", render_mode="rgb_array")
    result = run_episode(env, StraightAttacker(), GreedyDefender(), seed=0,
                         video=folder / "paper_6v2_greedy.mp4", progress=True)
    env.close()
    print(f"run_episode: captured {result.captured_count}, arrived {result.arrived_count} "
          f"in {result.steps} steps; {result.frames} frames written")


def with_own_loop(folder: Path) -> None:
    env = reachavoid_env.parallel_env(scenario="paper_6v2", render_mode="rgb_array",
                                      render_width=400)
    attackers, defenders = StraightAttacker(), GreedyDefender()
    with RecordEpisode(env, folder / "paper_6v2_loop.gif", every=4) as recorded:
        recorded.reset(seed=0)
        attackers.reset(recorded.unwrapped.scenario)
        defenders.reset(recorded.unwrapped.scenario)
        while recorded.agents:
            state = recorded.unwrapped.game_state()
            actions = {**attackers.act(state), **defenders.act(state)}
            recorded.unwrapped.set_overlay(defenders.overlay())
            recorded.step({agent: actions[agent] for agent in recorded.agents})
    steps = recorded.unwrapped.game_state().step
    print(f"own loop: {steps} steps, every 4th one (and the last) in the GIF")


def main(config: Config) -> None:
    with_run_episode(config.out)
    with_own_loop(config.out)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    for option in dataclasses.fields(Config):   # positional: no dashes
        parser.add_argument(option.name, type=type(option.default), default=option.default,
                            **option.metadata)
    config = Config(**vars(parser.parse_args()))
    if not config.out.is_dir():
        parser.error(f"out: folder {str(config.out)!r} does not exist")
    main(config)

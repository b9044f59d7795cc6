"""The ``reachavoid`` command (design.md section 6).

``reachavoid play`` runs one episode of a scenario with a choice of policies, prints a
summary (or one JSON object with ``--json``) and optionally writes a video. This is the
one module of ``reachavoid_env`` that imports ``policies`` (and, through them, solvers).
Bad arguments or scenario files end with a one-line message and exit status 2.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NoReturn

from policies import GreedyDefender, IdleDefender, Policy, RandomAttacker, StraightAttacker
from reachavoid_env.rollout import EpisodeResult, run_episode
from reachavoid_env.scenario import Scenario, ScenarioError, load_scenario
from reachavoid_env.video import check_video_path

EXIT_USAGE = 2


@dataclass(frozen=True)
class PolicyChoice:
    """One ``--attackers`` / ``--defenders`` option: a help line and a factory.

    ``make(scenario, seed)`` builds the policy for the scenario about to be played; heavy
    policies import what they need inside their factory, so the command starts fast.
    """

    help: str
    make: Callable[[Scenario, int | None], Policy]


ATTACKER_POLICIES: dict[str, PolicyChoice] = {
    "straight": PolicyChoice("run straight for the nearest target centre",
                             lambda scenario, seed: StraightAttacker()),
    "random": PolicyChoice("run in random directions, redrawn every 0.25 s (uses --seed)",
                           lambda scenario, seed: RandomAttacker(seed)),
}

DEFENDER_POLICIES: dict[str, PolicyChoice] = {
    "idle": PolicyChoice("stand still", lambda scenario, seed: IdleDefender()),
    "greedy": PolicyChoice("chase the nearest active attacker",
                           lambda scenario, seed: GreedyDefender()),
}


class UsageError(Exception):
    """A bad argument or input file: reported in one line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _choices_help(table: dict[str, PolicyChoice]) -> str:
    return "; ".join(f"{name}: {choice.help}" for name, choice in table.items())


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="reachavoid",
                     description="Multi-agent reach-avoid games: play, record, solve.")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    play = commands.add_parser("play", help="play one episode and print the outcome",
                               description="Play one episode of a scenario.")
    play.add_argument("--scenario", default="paper_6v2", metavar="NAME|FILE.toml",
                      help="a built-in scenario name or a TOML scenario file "
                           "(default: %(default)s)")
    play.add_argument("--attackers", choices=ATTACKER_POLICIES, default="straight",
                      help=f"attacker policy (default: %(default)s). "
                           f"{_choices_help(ATTACKER_POLICIES)}")
    play.add_argument("--defenders", choices=DEFENDER_POLICIES, default="greedy",
                      help=f"defender policy (default: %(default)s). "
                           f"{_choices_help(DEFENDER_POLICIES)}")
    play.add_argument("--seed", type=int, default=0,
                      help="seed of the env (random starts) and random policies "
                           "(default: %(default)s)")
    play.add_argument("--video", metavar="OUT.mp4|OUT.gif",
                      help="write the episode to an MP4 (H.264) or GIF video")
    play.add_argument("--fps", type=float, default=None,
                      help="video frames per second (default: the env's render_fps)")
    play.add_argument("--every", type=int, default=1, metavar="N",
                      help="put every N-th step in the video (default: %(default)s)")
    play.add_argument("--width", type=int, default=640,
                      help="video width in pixels, rounded up to a multiple of 16 "
                           "(default: %(default)s)")
    play.add_argument("--json", action="store_true",
                      help="print one JSON object instead of a summary")
    play.set_defaults(run=_play)
    solve = commands.add_parser("solve", help="solve a 1 vs 1 or 2 vs 1 HJ reach-avoid game",
                                description="Solve a scenario's 1 vs 1 or 2 vs 1 game to "
                                            "convergence (cached in $REACHAVOID_CACHE_DIR).")
    solve.add_argument("--scenario", default="paper_2v1", metavar="NAME|FILE.toml",
                       help="a built-in scenario name or a TOML scenario file "
                            "(default: %(default)s)")
    solve.add_argument("--game", choices=["1v1", "2v1"], default="1v1",
                       help="which game (default: %(default)s)")
    solve.add_argument("--grid", type=int, default=None, metavar="N",
                       help="grid nodes per axis (default: 45 for 1v1, 30 for 2v1)")
    solve.add_argument("--out", metavar="DIR", help="also save the value function here")
    solve.set_defaults(run=_solve)
    return parser


def _load(source: str) -> Scenario:
    try:
        return load_scenario(source)
    except OSError as err:
        raise UsageError(f"scenario: cannot read {source!r}: {err.strerror}") from None


def _play(args: argparse.Namespace) -> int:
    import reachavoid_env

    if args.video is not None:
        try:
            check_video_path(args.video)
        except ValueError as err:
            raise UsageError(str(err)) from None
        if args.fps is not None and not args.fps > 0:
            raise UsageError(f"--fps: must be positive, got {args.fps:g}")
        if args.every < 1:
            raise UsageError(f"--every: must be a positive integer, got {args.every}")
        if args.width < 16:
            raise UsageError(f"--width: need at least 16 pixels, got {args.width}")
    scenario = _load(args.scenario)
    attackers = ATTACKER_POLICIES[args.attackers].make(scenario, args.seed)
    defenders = DEFENDER_POLICIES[args.defenders].make(scenario, args.seed)
    env = reachavoid_env.parallel_env(
        scenario=scenario, render_mode="rgb_array" if args.video else None,
        render_width=args.width)
    try:
        result = run_episode(env, attackers, defenders, seed=args.seed, video=args.video,
                             fps=args.fps, every=args.every,
                             progress=args.video is not None and not args.json
                             and sys.stderr.isatty())
    finally:
        env.close()
    if args.json:
        print(json.dumps(_json_report(result, args)))
    else:
        print(_summary(result, args))
    return 0


def _solve(args: argparse.Namespace) -> int:
    from solvers.hj import solve_game

    try:
        report = solve_game(args.scenario, args.game, args.grid, out=args.out,
                            progress=sys.stderr.isatty())
    except (ValueError, MemoryError) as err:
        raise UsageError(str(err)) from None
    print(report.summary())
    return 0


def _json_report(result: EpisodeResult, args: argparse.Namespace) -> dict[str, object]:
    report = result.to_dict()
    report.update(defenders=args.defenders, attackers=args.attackers, video=args.video)
    order = ("scenario", "defenders", "attackers", "seed", "steps", "captured", "arrived",
             "captured_count", "arrived_count", "seconds", "game_time", "video")
    return {key: report[key] for key in order}


def _summary(result: EpisodeResult, args: argparse.Namespace) -> str:
    lines = [f"{result.scenario} (seed {result.seed}): {args.defenders} defenders vs "
             f"{args.attackers} attackers"]
    for word, names in (("captured", result.captured), ("arrived ", result.arrived)):
        lines.append(f"  {word} {len(names)}" + (f": {', '.join(names)}" if names else ""))
    lines.append(f"  {result.steps} steps, {result.game_time:.3f} s of game time, "
                 f"{result.seconds:.2f} s wall clock")
    if args.video is not None:
        lines.append(f"  video: {args.video} ({result.frames} frames)")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``reachavoid`` console script; returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    try:
        return args.run(args)
    except (UsageError, ScenarioError) as err:
        print(f"reachavoid {args.command}: error: {err}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"reachavoid {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())

"""The ``reachavoid`` command (design.md section 6).

``reachavoid play`` runs one episode of a scenario with a choice of policies, prints a
summary (or one JSON object with ``--json``) and optionally writes a video;
``reachavoid solve`` solves a 1 vs 1 or 2 vs 1 game; ``reachavoid bench`` plays many seeded
random starts and prints capture rates with confidence intervals; ``reachavoid paper``
reproduces the paper's table, videos and tube figure. This is the one module of
``reachavoid_env`` that imports ``policies`` (and, through them, solvers).
Bad arguments or scenario files end with a one-line message and exit status 2.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from collections.abc import Sequence
from typing import NoReturn

from policies import HJDefenderPolicy, MatchingDefenderPolicy, Policy, ShortestPathAttacker
from policies.registry import ATTACKERS, DEFENDERS, NamedPolicy, accepted_options, make_policy
from reachavoid_env.evaluation import run_episodes, summarize, write_csv
from reachavoid_env.files import atomic_write
from reachavoid_env.rollout import EpisodeResult, run_episode
from reachavoid_env.scenario import Scenario, ScenarioError, load_scenario
from reachavoid_env.video import check_video_path

EXIT_USAGE = 2


PAPER_TABLE = {"paper_2v1": (2, 1), "paper_6v2": (6, 4), "paper_8v4": (8, 6)}


class UsageError(Exception):
    """A bad argument or input file: reported in one line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _choices_help(table: dict[str, NamedPolicy]) -> str:
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
    play.add_argument("--attackers", choices=ATTACKERS, default="shortest-path",
                      help=f"attacker policy (default: %(default)s). "
                           f"{_choices_help(ATTACKERS)}")
    play.add_argument("--defenders", choices=DEFENDERS, default="hj",
                      help=f"defender policy (default: %(default)s). "
                           f"{_choices_help(DEFENDERS)}")
    _add_grid_options(play)
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
    solve.add_argument("--plot", metavar="OUT.png",
                       help="draw the value's slices at the scenario's starts (paper Fig. 2)")
    solve.set_defaults(run=_solve)

    bench = commands.add_parser(
        "bench", help="play many seeded random starts and compare capture rates",
        description="Play seeded random starts on a scenario's map with each defender method "
                    "and print capture rates with 95%% confidence intervals.")
    bench.add_argument("--scenario", default="paper_2v1", metavar="NAME|FILE.toml",
                       help="the map, speeds and settings to use (default: %(default)s)")
    bench.add_argument("--config", default="6v2", metavar="MvN",
                       help="attackers v defenders, drawn at random each episode "
                            "(default: %(default)s)")
    bench.add_argument("--defenders", default="hj,matching", metavar="A,B",
                       help=f"comma-separated defender methods (default: %(default)s); "
                            f"from {', '.join(DEFENDERS)}")
    bench.add_argument("--attackers", choices=ATTACKERS, default="shortest-path",
                       help="attacker policy (default: %(default)s)")
    bench.add_argument("--episodes", type=int, default=200,
                       help="episodes per method (default: %(default)s)")
    bench.add_argument("--seed", type=int, default=0,
                       help="episode k uses seed SEED + k (default: %(default)s)")
    bench.add_argument("--csv", metavar="FILE.csv", help="write one row per episode")
    bench.add_argument("--json", action="store_true",
                       help="print one JSON object instead of a table")
    _add_grid_options(bench)
    bench.set_defaults(run=_bench)

    paper = commands.add_parser(
        "paper", help="reproduce the paper's table, videos and tube figure",
        description="Play paper_2v1, paper_6v2 and paper_8v4 with the HJ + MIP defenders "
                    "and the matching baseline against shortest-path attackers (unassigned "
                    "defenders stand still, as in the paper), print the table next to the "
                    "paper's, and write six videos and the tube-slice figure.")
    paper.add_argument("--out", default="paper_results", metavar="DIR",
                       help="where the videos, figure and table go (default: %(default)s)")
    paper.add_argument("--no-video", action="store_true", help="skip the six videos")
    _add_grid_options(paper)
    paper.set_defaults(run=_paper, seed=0)
    return parser


def _add_grid_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--grid1", type=int, default=45, metavar="N",
                        help="1 vs 1 tube nodes per axis (default: %(default)s, the paper's)")
    parser.add_argument("--grid2", type=int, default=30, metavar="N",
                        help="2 vs 1 tube nodes per axis (default: %(default)s, the paper's)")


def _check_grids(args: argparse.Namespace) -> None:
    for name in ("grid1", "grid2"):
        if getattr(args, name) < 5:
            raise UsageError(f"--{name}: need at least 5 nodes per axis, got "
                             f"{getattr(args, name)}")
    args.progress = sys.stderr.isatty()


def _policy(side: str, name: str, scenario: Scenario, args: argparse.Namespace) -> Policy:
    """The named policy, given whichever of --seed, --grid1, --grid2 it takes."""
    options = accepted_options(side, name, seed=args.seed, grid1=args.grid1, grid2=args.grid2,
                               progress=args.progress)
    return make_policy(side, name, scenario, **options)


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
    _check_grids(args)
    scenario = _load(args.scenario)
    attackers = _policy("attackers", args.attackers, scenario, args)
    defenders = _policy("defenders", args.defenders, scenario, args)
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
                            plot=args.plot, progress=sys.stderr.isatty())
    except (ValueError, MemoryError) as err:
        raise UsageError(str(err)) from None
    print(report.summary())
    return 0


def _json_report(result: EpisodeResult, args: argparse.Namespace) -> dict[str, object]:
    report = result.to_dict()
    report.update(defenders=args.defenders, attackers=args.attackers, video=args.video)
    order = ("scenario", "defenders", "attackers", "seed", "steps", "captured", "arrived",
             "captured_count", "arrived_count", "seconds", "game_time", "video",
             "guaranteed_captures_initial", "guaranteed_captures_final",
             "guarantee_violations")
    return {key: report[key] for key in order if key in report}


def _summary(result: EpisodeResult, args: argparse.Namespace) -> str:
    lines = [f"{result.scenario} (seed {result.seed}): {args.defenders} defenders vs "
             f"{args.attackers} attackers"]
    for word, names in (("captured", result.captured), ("arrived ", result.arrived)):
        lines.append(f"  {word} {len(names)}" + (f": {', '.join(names)}" if names else ""))
    lines.append(f"  {result.steps} steps, {result.game_time:.3f} s of game time, "
                 f"{result.seconds:.2f} s wall clock")
    if result.guarantees:
        lines.append(f"  guaranteed captures: {result.guarantees[0]} at the start, "
                     f"{result.guarantees[-1]} at the end")
    if args.video is not None:
        lines.append(f"  video: {args.video} ({result.frames} frames)")
    return "\n".join(lines)


def _bench(args: argparse.Namespace) -> int:
    import reachavoid_env

    _check_grids(args)
    match = re.fullmatch(r"(\d+)v(\d+)", args.config)
    if match is None:
        raise UsageError(f"--config: expected MvN such as 6v2, got {args.config!r}")
    if args.episodes < 1:
        raise UsageError(f"--episodes: must be a positive integer, got {args.episodes}")
    methods = [m.strip() for m in args.defenders.split(",") if m.strip()]
    unknown = [m for m in methods if m not in DEFENDERS]
    if unknown or not methods:
        raise UsageError(f"--defenders: unknown method(s) {unknown or args.defenders!r} "
                         f"(choose from {', '.join(DEFENDERS)})")
    num_attackers, num_defenders = int(match[1]), int(match[2])
    scenario = _load(args.scenario).with_players(num_attackers, num_defenders)
    env = reachavoid_env.parallel_env(scenario=scenario)
    summaries, rows = [], []
    for method in methods:
        attackers = _policy("attackers", args.attackers, scenario, args)
        defenders = _policy("defenders", method, scenario, args)
        results = run_episodes(env, attackers, defenders, args.episodes, seed=args.seed,
                               progress=args.progress, description=method)
        summaries.append(summarize(method, results, num_attackers))
        rows.extend({"defenders": method, "attackers": args.attackers, **r.to_dict()}
                    for r in results)
    env.close()
    if args.csv:
        write_csv(args.csv, [{k: (";".join(v) if isinstance(v, list) else v)
                              for k, v in row.items()} for row in rows])
    if args.json:
        print(json.dumps({"scenario": scenario.name, "config": args.config,
                          "attackers": args.attackers, "seed": args.seed,
                          "episodes": args.episodes,
                          "methods": [s.to_dict() for s in summaries]}))
        return 0
    print(f"{scenario.name}: {args.episodes} seeded random starts (seeds {args.seed}.."
          f"{args.seed + args.episodes - 1}), {args.attackers} attackers")
    print(f"  {'defenders':<10} {'capture rate [95% CI]':<26} {'all captured [95% CI]':<26}"
          f" {'guaranteed':>10} {'violations':>10}")
    for s in summaries:
        guaranteed = "-" if s.guaranteed_initial is None else f"{s.guaranteed_initial:.2f}"
        print(f"  {s.label:<10} {s.capture_rate:6.1%} [{s.capture_rate_ci[0]:.1%}, "
              f"{s.capture_rate_ci[1]:.1%}]{'':<4} {s.all_captured_rate:6.1%} "
              f"[{s.all_captured_ci[0]:.1%}, {s.all_captured_ci[1]:.1%}]{'':<4}"
              f" {guaranteed:>10} {s.guarantee_violations:>10}")
    if args.csv:
        print(f"  per-episode rows: {args.csv}")
    return 0


def _paper(args: argparse.Namespace) -> int:
    from pathlib import Path

    import reachavoid_env
    from solvers.hj.plot import tube_figure

    _check_grids(args)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    reference = HJDefenderPolicy.for_scenario(
        reachavoid_env.builtin_scenario("paper_2v1"), grid1=args.grid1, grid2=args.grid2,
        idle="stand", progress=args.progress)
    methods = {"hj": reference, "matching": MatchingDefenderPolicy(reference.vf11)}
    table = {}
    for name, paper_counts in PAPER_TABLE.items():
        scenario = reachavoid_env.builtin_scenario(name)
        row = {}
        for method, defenders in methods.items():
            env = reachavoid_env.parallel_env(
                scenario=scenario, render_mode=None if args.no_video else "rgb_array")
            video = None if args.no_video else out / f"{name}_{method}.mp4"
            result = run_episode(env, ShortestPathAttacker(), defenders, seed=0,
                                 video=video, progress=args.progress)
            env.close()
            row[method] = result.to_dict() | {"video": None if video is None else str(video)}
        table[name] = {"paper": {"hj": paper_counts[0], "matching": paper_counts[1]}, **row}
    defender, first, second = (0.3, -0.3), (-0.5, 0.0), (0.0, 0.8)
    figure = out / "tubes.png"
    tube_figure([(reference.vf11, "A", {"D": defender}),
                 (reference.vf21, "A2", {"A1": first, "D": defender}),
                 (reference.vf21, "D", {"A1": first, "A2": second})], figure)
    with atomic_write(out / "table.json") as handle:
        json.dump(table, handle, indent=2)
    print(f"Attackers captured (grids {args.grid1}^4 and {args.grid2}^6; "
          f"shortest-path attackers)")
    print(f"  {'game':<10} {'ours':>6} {'paper':>6} {'baseline':>9} {'paper':>6}")
    for name, row in table.items():
        print(f"  {name[6:]:<10} {row['hj']['captured_count']:>6} {row['paper']['hj']:>6} "
              f"{row['matching']['captured_count']:>9} {row['paper']['matching']:>6}")
    print(f"  videos, table.json and {figure.name} in {out}/")
    return 0


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

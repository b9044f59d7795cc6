"""The ``reachavoid`` command (design.md, "Command line"): argument parsing and printing.

``play`` runs one episode (``rollout``), ``solve`` one game (``solve``), ``bench`` many
seeded starts (``evaluation``), ``paper`` the paper's table (``paper``). Every argument and
output path is checked before any work starts. Bad arguments or input files end with a
one-line message and exit status 2; a failed write with one line naming the path and
status 1; Ctrl-C (130) and SIGTERM (143) stop the work and leave no partial file.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

import reachavoid_env
from policies.registry import ATTACKERS, DEFENDERS, NamedPolicy, accepted_options, make_policy
from reachavoid.solve import GAMES
from reachavoid.sweep import BACKENDS
from reachavoid_env import checks
from solvers.hj.settings import PAPER_GRIDS

if TYPE_CHECKING:
    from reachavoid.rollout import EpisodeResult
    from reachavoid_env import Scenario

# The commands import what they run (the solver, OR-Tools, matplotlib, the env) when they
# run it, so that ``--help`` and bad arguments answer at once.

EXIT_USAGE, EXIT_WRITE, EXIT_INTERRUPTED, EXIT_TERMINATED = 2, 1, 130, 143
MAX_SEED = 2**63 - 1
GRID_RANGE = {"grid1": (5, 201), "grid2": (5, 101)}
"""Nodes per axis accepted for the 1 vs 1 and 2 vs 1 tubes (the memory guard still
refuses what this machine cannot hold)."""
MAX_MARGIN_CELLS = 10.0
"""The largest certificate margin accepted (grid cells)."""


class UsageError(ValueError):
    """A bad argument or input file: reported in one line, exit status 2."""


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the program is so that it unwinds as on Ctrl-C."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _choices_help(table: dict[str, NamedPolicy]) -> str:
    return "; ".join(f"{name}: {choice.help}" for name, choice in table.items())


def _scenario_option(parser: argparse.ArgumentParser, default: str, what: str) -> None:
    parser.add_argument("--scenario", default=default, metavar="NAME|FILE.toml",
                        help=f"{what} (default: %(default)s)")


def _grid_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--grid1", type=int, default=PAPER_GRIDS.grid1, metavar="N",
                        help="1 vs 1 tube nodes per axis (default: %(default)s, the paper's)")
    parser.add_argument("--grid2", type=int, default=PAPER_GRIDS.grid2, metavar="N",
                        help="2 vs 1 tube nodes per axis (default: %(default)s, the paper's)")


def _margin_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--margin-cells", type=float, default=None, metavar="C",
                        help="certificate margin of the hj, hj-pairs and matching defenders in "
                             "grid cells of each tube: a game counts as a defender win where "
                             "its value exceeds C cells, or stays > 0 once taken (default: "
                             "the defenders' CERTIFICATE_CELLS; 0 reads the tubes as the "
                             "paper does)")


def _seed_option(parser: argparse.ArgumentParser, help_text: str) -> None:
    parser.add_argument("--seed", type=int, default=0, help=f"{help_text} (default: %(default)s)")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="reachavoid",
                     description="Multi-agent reach-avoid games: play, record, solve.")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    play = commands.add_parser("play", help="play one episode and print the outcome",
                               description="Play one episode of a scenario.")
    _scenario_option(play, "paper_6v2", "a built-in scenario name or a TOML scenario file")
    play.add_argument("--attackers", choices=ATTACKERS, default="shortest-path",
                      help=f"attacker policy (default: %(default)s). {_choices_help(ATTACKERS)}")
    play.add_argument("--defenders", choices=DEFENDERS, default="hj",
                      help=f"defender policy (default: %(default)s). {_choices_help(DEFENDERS)}")
    _grid_options(play)
    _margin_option(play)
    _seed_option(play, "seed of the env (random starts) and random policies")
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

    solve = commands.add_parser("solve",
                                help="solve a 1 vs 1, 2 vs 1 or 1 vs 2 HJ reach-avoid game",
                                description="Solve a scenario's 1 vs 1, 2 vs 1 or 1 vs 2 game to "
                                            "convergence (cached in $REACHAVOID_CACHE_DIR).")
    _scenario_option(solve, "paper_2v1", "a built-in scenario name or a TOML scenario file")
    solve.add_argument("--game", choices=GAMES, default="1v1",
                       help="which game (default: %(default)s)")
    solve.add_argument("--grid", type=int, default=None, metavar="N",
                       help=f"the game's grid nodes per axis (default: the paper's, "
                            f"{PAPER_GRIDS.grid1} for 1v1, {PAPER_GRIDS.grid2} for 2v1 and 1v2)")
    solve.add_argument("--grid1", type=int, default=PAPER_GRIDS.grid1, metavar="N",
                       help="nodes per axis of the 1 vs 1 tube: the tube under a 2v1 or 1v2 "
                            "game, the game itself for 1v1 without --grid (default: "
                            "%(default)s; as --grid1 of play, bench and paper)")
    solve.add_argument("--out", metavar="DIR", help="also save the value function here")
    solve.add_argument("--plot", metavar="OUT.png",
                       help="draw the value's slices at the scenario's starts (paper Fig. 2)")
    solve.set_defaults(run=_solve)

    bench = commands.add_parser(
        "bench", help="play many seeded random starts and compare capture rates",
        description="Play seeded random starts on a scenario's map with each defender method "
                    "and print capture rates with 95% confidence intervals.")
    _scenario_option(bench, "paper_2v1", "the map, speeds and settings to use")
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
    _seed_option(bench, "episode k uses seed SEED + k")
    bench.add_argument("--backend", choices=BACKENDS, default="serial",
                       help="where episodes run: here, on a process pool, or as Ray tasks "
                            "(same results for the same seeds; default: %(default)s)")
    bench.add_argument("--workers", type=int, default=None, metavar="N",
                       help="processes of the pool, or CPUs of a local Ray instance "
                            "(default: all cores)")
    bench.add_argument("--address", default=None, metavar="ADDR",
                       help="an existing Ray cluster (default: start a local one)")
    bench.add_argument("--csv", metavar="FILE.csv", help="write one row per episode")
    bench.add_argument("--json", action="store_true",
                       help="print one JSON object instead of a table")
    _grid_options(bench)
    _margin_option(bench)
    bench.set_defaults(run=_bench)

    paper = commands.add_parser(
        "paper", help="reproduce the paper's table, videos and tube figure",
        description="Play the paper's games (the built-ins with a [paper] table) with the HJ + "
                    "MIP defenders and the matching baseline against shortest-path attackers "
                    "(unassigned defenders stand still, as in the paper), print the table "
                    "next to the paper's, and write the videos and the tube-slice figure.")
    paper.add_argument("--out", default="paper_results", metavar="DIR",
                       help="where the videos, figure and table go (default: %(default)s)")
    paper.add_argument("--no-video", action="store_true", help="skip the videos")
    _grid_options(paper)
    paper.set_defaults(run=_paper)
    return parser


# -- checks made before any work -----------------------------------------------------------

def _check(check: Any, value: Any, field: str, *bounds: Any) -> Any:
    try:
        return check(value, field, *bounds)
    except ValueError as err:
        raise UsageError(str(err)) from None


def _check_common(args: argparse.Namespace) -> None:
    for name in ("grid1", "grid2"):
        if hasattr(args, name):
            _check(checks.integer, getattr(args, name), f"--{name}", *GRID_RANGE[name])
    if hasattr(args, "seed"):
        _check(checks.integer, args.seed, "--seed", 0, MAX_SEED)
    if getattr(args, "margin_cells", None) is not None:
        _check(checks.real, args.margin_cells, "--margin-cells", 0.0, MAX_MARGIN_CELLS)
    from solvers.hj.cache import cache_dir

    location = cache_dir()
    if location.exists() and not location.is_dir():
        raise UsageError(f"cache: {str(location)!r} ($REACHAVOID_CACHE_DIR) is not a folder")
    args.progress = sys.stderr.isatty()


def writable_file(path: str, field: str) -> Path:
    """``path`` if a file can be created or replaced there, else ``UsageError`` naming
    ``field``."""
    target = Path(path)
    if target.is_dir():
        raise UsageError(f"{field}: {path!r} is a folder")
    folder = target.parent
    if not folder.is_dir():
        raise UsageError(f"{field}: folder {str(folder)!r} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UsageError(f"{field}: folder {str(folder)!r} is not writable")
    return target


def writable_folder(path: str, field: str) -> Path:
    """``path`` if it is a writable folder or can be created as one, else ``UsageError``."""
    target = Path(path)
    if target.exists() and not target.is_dir():
        raise UsageError(f"{field}: {path!r} exists and is not a folder")
    existing = target if target.exists() else next(p for p in target.absolute().parents
                                                   if p.exists())
    if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
        raise UsageError(f"{field}: {str(existing)!r} is not a writable folder")
    return target


def _load(source: str) -> Scenario:
    try:
        return reachavoid_env.load_scenario(source)
    except OSError as err:
        raise UsageError(f"scenario: cannot read {source!r}: {err.strerror}") from None


def _margin(args: argparse.Namespace) -> dict[str, float]:
    """``--margin-cells`` as a policy option, absent when not given (the policy's default)."""
    return {} if args.margin_cells is None else {"margin_cells": args.margin_cells}


def _policy(side: str, name: str, scenario: Scenario, args: argparse.Namespace) -> Any:
    """The named policy, given whichever of --seed, --grid1, --grid2 it takes."""
    options = accepted_options(side, name, seed=args.seed, grid1=args.grid1, grid2=args.grid2,
                               progress=args.progress, **_margin(args))
    return make_policy(side, name, scenario, **options)


# -- commands -------------------------------------------------------------------------------

def _play(args: argparse.Namespace) -> int:
    from reachavoid.rollout import run_episode

    if args.video is not None:
        from reachavoid_env.video import check_video_path

        try:
            check_video_path(args.video)
        except ValueError as err:
            raise UsageError(str(err)) from None
        writable_file(args.video, "--video")
        if args.fps is not None:
            _check(checks.positive, args.fps, "--fps", 240.0)
        _check(checks.integer, args.every, "--every", 1, 1_000_000)
        _check(checks.integer, args.width, "--width", 16, 4096)
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
                             and args.progress)
    finally:
        env.close()
    if args.json:
        print(json.dumps(_json_report(result, args)))
    else:
        print(_summary(result, args))
    return 0


def _json_report(result: EpisodeResult, args: argparse.Namespace) -> dict[str, object]:
    report = result.to_dict()
    report.update(defenders=args.defenders, attackers=args.attackers, video=args.video)
    order = ("scenario", "defenders", "attackers", "seed", "steps", "captured", "arrived",
             "captured_count", "arrived_count", "seconds", "game_time", "video",
             "guaranteed_captures_initial", "guaranteed_captures_final",
             "guarantee_violations", "guarantee_falls", "arrivals_beyond_promise",
             "nominal_captures_initial")
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


def _solve(args: argparse.Namespace) -> int:
    if args.grid is not None:
        _check(checks.integer, args.grid, "--grid",
               *GRID_RANGE["grid1" if args.game == "1v1" else "grid2"])
    if args.out is not None:
        writable_folder(args.out, "--out")
    if args.plot is not None:
        writable_file(args.plot, "--plot")
    from reachavoid.solve import solve_scenario

    scenario = _load(args.scenario)
    try:
        grid = args.grid1 if args.game == "1v1" and args.grid is None else args.grid
        report = solve_scenario(scenario, args.game, grid, out=args.out,
                                grid_points_1v1=args.grid1,
                                plot=args.plot, progress=args.progress)
    except (ValueError, MemoryError) as err:
        raise UsageError(str(err)) from None
    print(report.summary())
    return 0


def _bench(args: argparse.Namespace) -> int:
    from reachavoid.evaluation import compare_defenders, write_csv

    match = re.fullmatch(r"(\d+)v(\d+)", args.config)
    if match is None:
        raise UsageError(f"--config: expected MvN such as 6v2, got {args.config!r}")
    _check(checks.integer, int(match[1]), "--config attackers", 1, 64)
    _check(checks.integer, int(match[2]), "--config defenders", 1, 64)
    _check(checks.integer, args.episodes, "--episodes", 1, 10_000_000)
    methods = [m.strip() for m in args.defenders.split(",") if m.strip()]
    unknown = [m for m in methods if m not in DEFENDERS]
    if unknown or not methods:
        raise UsageError(f"--defenders: unknown method(s) {unknown or args.defenders!r} "
                         f"(choose from {', '.join(DEFENDERS)})")
    if args.workers is not None:
        _check(checks.integer, args.workers, "--workers", 1, 4096)
    if args.address is not None and args.backend != "ray":
        raise UsageError("--address: only with --backend ray")
    if args.csv:
        writable_file(args.csv, "--csv")
    scenario = _load(args.scenario).with_players(int(match[1]), int(match[2]))
    comparison = compare_defenders(scenario, methods, args.attackers, args.episodes,
                                   seed=args.seed, backend=args.backend, workers=args.workers,
                                   address=args.address, progress=args.progress,
                                   grid1=args.grid1, grid2=args.grid2, **_margin(args))
    if args.csv:
        write_csv(args.csv, [{k: (";".join(v) if isinstance(v, list) else v)
                              for k, v in row.items()} for row in comparison.rows])
    if args.json:
        print(json.dumps({"scenario": scenario.name, "config": args.config,
                          "attackers": args.attackers, "seed": args.seed,
                          "episodes": args.episodes,
                          "methods": [s.to_dict() for s in comparison.summaries]}))
        return 0
    print(f"{scenario.name}: {args.episodes} seeded random starts (seeds {args.seed}.."
          f"{args.seed + args.episodes - 1}), {args.attackers} attackers")
    print(f"  {'defenders':<10} {'capture rate [95% CI]':<26} {'all captured [95% CI]':<26}"
          f" {'guaranteed':>10} {'nominal':>8} {'violations':>10}")
    for s in comparison.summaries:
        guaranteed, nominal = ("-" if x is None else f"{x:.2f}"
                               for x in (s.guaranteed_initial, s.nominal_initial))
        print(f"  {s.label:<10} {s.capture_rate:6.1%} [{s.capture_rate_ci[0]:.1%}, "
              f"{s.capture_rate_ci[1]:.1%}]{'':<4} {s.all_captured_rate:6.1%} "
              f"[{s.all_captured_ci[0]:.1%}, {s.all_captured_ci[1]:.1%}]{'':<4}"
              f" {guaranteed:>10} {nominal:>8} {s.guarantee_violations:>10}")
    if args.csv:
        print(f"  per-episode rows: {args.csv}")
    return 0


def _paper(args: argparse.Namespace) -> int:
    from reachavoid import paper as paper_table

    out = writable_folder(args.out, "--out")
    out.mkdir(parents=True, exist_ok=True)
    rows = paper_table.reproduce(out, args.grid1, args.grid2, videos=not args.no_video,
                                 progress=args.progress)
    print(f"Attackers captured (grids {args.grid1}^4 and {args.grid2}^6; "
          f"{paper_table.ATTACKERS} attackers)")
    print(f"  {'game':<10} {'ours':>6} {'paper':>6} {'baseline':>9} {'paper':>6}")
    for row in rows:
        ours, baseline = row.measured["hj"], row.measured["matching"]
        print(f"  {row.scenario.split('_')[-1]:<10} {ours['captured_count']:>6} "
              f"{row.reported['hj']:>6} {baseline['captured_count']:>9} "
              f"{row.reported['matching']:>6}")
    print(f"  videos, table.json and tubes.png in {out}/")
    return 0


def _terminate(signum: int, frame: object) -> None:
    raise Terminated


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``reachavoid`` console script; returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    previous = signal.signal(signal.SIGTERM, _terminate)
    try:
        _check_common(args)
        return args.run(args)
    except (UsageError, reachavoid_env.ScenarioError) as err:
        print(f"reachavoid {args.command}: error: {err}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as err:
        where = f"{err.filename}: " if err.filename else ""
        print(f"reachavoid {args.command}: error: {where}{err.strerror or err}",
              file=sys.stderr)
        return EXIT_WRITE
    except Terminated:
        print(f"reachavoid {args.command}: terminated", file=sys.stderr)
        return EXIT_TERMINATED
    except KeyboardInterrupt:
        print(f"reachavoid {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())

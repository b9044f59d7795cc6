"""The ``reachavoid`` command (design.md, "Command line"): argument parsing, the checks made
before any work and the commands (output paths: ``paths``; the tables printed: ``tables``).

``play`` runs one episode (``rollout``), ``solve`` one game (``solve``), ``bench`` many
seeded starts of a suite (``suite``, ``evaluation``), ``maps`` a map library
(``reachavoid_env.maps``), ``paper`` the paper's table (``paper``). Every argument, output
path and the cache are checked before any work starts. Bad arguments or input files end
with a one-line message and exit status 2; a failed write with one line naming the path and
status 1, as a worker that died; Ctrl-C (130), SIGTERM (143) and SIGHUP (129) stop the work
and leave no partial file; a closed standard output (``| head``) ends quietly (141).
Outputs follow one rule (README "Files and failures"): an existing file is replaced only
with ``--force``, and a file that appears meanwhile is kept.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import functools
import json
import os
import signal
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

import reachavoid_env
import solvers.hj
from policies.registry import TABLES, PolicySpec, names_help, policy_specs
from reachavoid.evaluation import one_start, write_csv
from reachavoid.paths import (
    UsageError,
    check_replace,
    distinct_outputs,
    reported,
    writable_file,
    writable_folder,
)
from reachavoid.rollout import EpisodeResult, episode_title, first_frame, run_episode
from reachavoid.solve import DEFAULT_GRID, GAMES, solve_library, solve_scenario
from reachavoid.suite import (
    Cell,
    Suite,
    SuiteResult,
    library_suite,
    load_suite,
    parse_players,
    plot_suite,
    run_suite,
    suite_names,
)
from reachavoid.sweep import BACKENDS, WorkerDied, check_backend
from reachavoid.tables import bench_tables, paper_lines
from reachavoid_env import PolicyMismatch, Scenario, ScenarioError, checks, load_scenario
from reachavoid_env.files import (
    STDOUT,
    atomic_write,
    destination,
    forget_expected,
    write_json,
)
from reachavoid_env.maps import (
    MAX_MAPS,
    MapError,
    MapOptions,
    load_library,
    options_from_text,
    write_library,
)
from solvers.hj.cache import CacheLocationError, cache_dir, check_cache

# The policies (OR-Tools, numba), the env and the paper's figures (matplotlib) are imported by
# the commands that use them, when they run, so that ``--help`` and bad arguments answer at
# once.

EXIT_USAGE, EXIT_FAILED, EXIT_INTERRUPTED, EXIT_PIPE = 2, 1, 130, 141
"""Exit statuses: bad input; a failed write or a dead worker; Ctrl-C; a closed pipe."""
MAX_SEED = 2**63 - 1
GRID_RANGE = {"grid1": (5, 201), "grid2": (5, 101)}
"""Nodes per axis accepted for the 1 vs 1 and 2 vs 1 tubes (the memory guard still
refuses what this machine cannot hold)."""
OPTION_FLAGS = {"grid1": "--grid1", "grid2": "--grid2", "margin_cells": "--margin-cells"}
"""The policy options the command line takes (each goes to the chosen policies that take
it; one that none takes is an error)."""
GIF_MAX_FPS = 50.0
"""The highest video rates accepted (frames per second); a GIF's frame delay is counted in
hundredths of a second and players slow down delays under two."""


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised where the program is so that it unwinds as on Ctrl-C."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


STOP_SIGNALS = {signal.SIGTERM: "terminated", signal.SIGHUP: "hung up"}


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


SPEC = "NAME|pkg.module:factory|sb3:MODEL.zip"
ONE_CELL = {"scenario": "paper_2v1", "config": "6v2", "attackers": "shortest-path"}
"""``bench``'s single cell without ``--suite`` (defaults of the flags that make it)."""


def _scenario_option(parser: argparse.ArgumentParser, default: str, what: str) -> None:
    parser.add_argument("--scenario", default=default, metavar="NAME|FILE.toml",
                        help=f"{what} (default: %(default)s)")


def _grid_options(parser: argparse.ArgumentParser, for_policies: bool = True) -> None:
    """``--grid1`` / ``--grid2``: policy options (given only when set: each policy that
    takes them gets them, its own default is the paper's), or the grids of a command."""
    whose = " of the policies that take it" if for_policies else ""
    for name, game in (("grid1", "1v1"), ("grid2", "2v1")):
        parser.add_argument(f"--{name}", type=int, metavar="N",
                            default=None if for_policies else DEFAULT_GRID[game],
                            help=f"{game[0]} vs {game[2]} tube nodes per axis{whose} "
                                 f"(default: {DEFAULT_GRID[game]}, the paper's)")


def _backend_options(parser: argparse.ArgumentParser, where: str, workers: str) -> None:
    """``--backend``, ``--workers`` and ``--address`` (``_check_backend_options`` checks
    them)."""
    parser.add_argument("--backend", choices=BACKENDS, default="serial",
                        help=f"{where}: here, on a process pool, or as Ray tasks "
                             "(default: %(default)s)")
    parser.add_argument("--workers", type=int, default=None, metavar="N", help=workers)
    parser.add_argument("--address", default=None, metavar="ADDR",
                        help="with --backend ray, an existing Ray cluster (default: start a "
                             "local one)")


def _check_backend_options(args: argparse.Namespace) -> None:
    try:
        check_backend(args.backend)   # Ray importable, before any tube is solved
    except ValueError as err:
        raise UsageError(f"--{err}") from None
    if args.workers is not None:
        _check(checks.integer, args.workers, "--workers", 1, 4096)
    if args.address is not None and args.backend != "ray":
        raise UsageError("--address: only with --backend ray", field="--address")


def _margin_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--margin-cells", type=float, default=None, metavar="C",
                        help="certificate margin of the hj, hj-pairs and matching defenders in "
                             "grid cells of each tube: a game counts as a defender win where "
                             "its value exceeds C cells, or stays > 0 once taken (default: "
                             "the defenders' CERTIFICATE_CELLS; 0 reads the tubes as the paper "
                             "does)")


def _force_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--force", action="store_true",
                        help="replace existing output files (default: refuse, before any work)")


def _seed_option(parser: argparse.ArgumentParser, help_text: str) -> None:
    parser.add_argument("--seed", type=int, default=0, help=f"{help_text} (default: %(default)s)")


def _policy_option(parser: argparse.ArgumentParser, side: str, default: str, what: str,
                   metavar: str = SPEC) -> None:
    """``--attackers`` or ``--defenders`` (``side``), with the names the registry knows."""
    parser.add_argument(f"--{side}", default=default, metavar=metavar,
                        help=f"{what} (default: %(default)s). {names_help(side)}")


def _plot_option(parser: argparse.ArgumentParser, what: str) -> None:
    parser.add_argument("--plot", metavar="OUT.png", help=what)


COMMANDS = {
    "play": ("play one episode and print the outcome", "Play one episode of a scenario."),
    "solve": ("solve a 1 vs 1, 2 vs 1 or 1 vs 2 HJ reach-avoid game",
              "Solve a scenario's 1 vs 1, 2 vs 1 or 1 vs 2 game to convergence (cached in "
              "$REACHAVOID_CACHE_DIR)."),
    "bench": ("compare defender methods on the same seeded starts",
              "Play seeded starts with each defender method (built-in names, installed names, "
              "or pkg.module:factory of your own), on one scenario's map (--config) or on "
              "every cell of a suite (--suite), and print capture rates with 95% intervals "
              "and each method's paired difference from the baseline."),
    "maps": ("generate a library of random, validated maps",
             "Write COUNT generated scenarios (obstacles of the registered shapes, a target, "
             "every free region connected to the target, random starts) and an index.toml to "
             "a folder; the same arguments always write the same files. Load the folder "
             "wherever a scenario is accepted."),
    "paper": ("reproduce the paper's table, videos and tube figure",
              "Play the paper's games (the built-ins with a [paper] table) with the HJ + MIP "
              "defenders and the matching baseline against shortest-path attackers "
              "(unassigned defenders stand still, as in the paper), print the table next to "
              "the paper's, and write the videos and the tube-slice figure."),
    "validate": ("check scenario files without playing them",
                 "Load each scenario (a TOML file or a built-in name) and reset an env on it; "
                 "print one line per file. Exit status 0 when all are valid, 2 when any is not "
                 "(its error on stderr)."),
}
"""Each subcommand's line in ``reachavoid --help`` and the description atop its own
``--help``."""


def _command(commands: Any, name: str,
             run: Callable[[argparse.Namespace], int]) -> argparse.ArgumentParser:
    """The subcommand ``name`` (its texts in ``COMMANDS``), carried out by ``run``."""
    summary, description = COMMANDS[name]
    command = commands.add_parser(name, help=summary, description=description)
    command.set_defaults(run=run)
    return command


def build_parser() -> argparse.ArgumentParser:
    """The ``reachavoid`` parser: each ``_*_command`` adds a subcommand, in this order."""
    parser = _Parser(prog="reachavoid",
                     description="Multi-agent reach-avoid games: play, record, solve.")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in (_play_command, _solve_command, _bench_command, _maps_command, _paper_command,
                _validate_command):
        add(commands)
    return parser


def _play_command(commands: Any) -> None:
    play = _command(commands, "play", _play)
    _scenario_option(play, "paper_6v2", "a built-in scenario name, a TOML scenario file, or a "
                                        "map library folder or index (the seed draws the map)")
    _policy_option(play, "attackers", "shortest-path", "attacker policy")
    _policy_option(play, "defenders", "hj", "defender policy")
    _grid_options(play)
    _margin_option(play)
    _seed_option(play, "seed of the env (random starts) and random policies")
    _video_options(play)
    play.add_argument("--json", action="store_true",
                      help="print one JSON object instead of a summary")
    _force_option(play)


def _video_options(play: argparse.ArgumentParser) -> None:
    """``play``'s ``--video`` and how it is made, and ``--preview``."""
    play.add_argument("--video", metavar="OUT.mp4|OUT.gif",
                      help="write the episode to an MP4 (H.264) or GIF video")
    play.add_argument("--fps", type=float, default=None,
                      help="video frames per second (default: the env's render_fps, 50: with "
                           "5 ms steps and --every 1 the video is 4x slow motion; it shows "
                           "fps x every x dt seconds of game time per second)")
    play.add_argument("--every", type=int, default=None, metavar="N",
                      help="put every N-th step in the video (default: 1, or with --realtime "
                           "the smallest N that keeps the rate at most 50 fps)")
    play.add_argument("--realtime", action="store_true",
                      help="play the video in game time: fps = 1 / (every x dt)")
    play.add_argument("--preview", metavar="OUT.png",
                      help="write the episode's first frame (with the first decision's overlay) "
                           "as a PNG and stop, without playing")
    play.add_argument("--width", type=int, default=640,
                      help="video width in pixels, rounded up to a multiple of 16 "
                           "(default: %(default)s)")


def _solve_command(commands: Any) -> None:
    solve = _command(commands, "solve", _solve)
    solve.add_argument("--scenario", nargs="+", default=["paper_2v1"],
                       metavar="NAME|FILE.toml|DIR",
                       help="a built-in scenario name or a TOML scenario file; with "
                            "--defenders also several, or map library folders or index files "
                            "(default: %(default)s)")
    solve.add_argument("--game", choices=GAMES, default="1v1",
                       help="which game (default: %(default)s)")
    solve.add_argument("--grid", type=int, default=None, metavar="N",
                       help=f"grid nodes per axis (default: {DEFAULT_GRID['1v1']} for 1v1, "
                            f"{DEFAULT_GRID['2v1']} for 2v1 and 1v2)")
    solve.add_argument("--defenders", metavar="A,B",
                       help="instead of --game: every tube these defender methods need, on "
                            "every map of --scenario, at --grid1/--grid2; what the cache holds "
                            "is skipped")
    _grid_options(solve, for_policies=False)
    _backend_options(solve, "with --defenders, where the maps are solved",
                     "with --defenders, concurrent solves (default: all cores; refused when "
                     "they would not fit in memory)")
    solve.add_argument("--out", metavar="DIR", help="also save the value function here")
    _plot_option(solve, "draw the value's slices at the scenario's starts (paper Fig. 2)")
    _force_option(solve)


def _bench_command(commands: Any) -> None:
    bench = _command(commands, "bench", _bench)
    bench.add_argument("--suite", default=None, metavar="NAME|FILE.toml",
                       help=f"play a suite of cells instead of one --config (built-ins: "
                            f"{', '.join(suite_names())})")
    _scenario_option(bench, ONE_CELL["scenario"],
                     "without --suite: the map, speeds and settings; a map library (a folder "
                     "of `reachavoid maps`, its index.toml) plays a cell per map and pools them")
    bench.add_argument("--config", default=None, metavar="MvN",
                       help=f"without --suite: attackers v defenders, drawn at random each "
                            f"episode (default: {ONE_CELL['config']}; over a map library, its "
                            f"maps' own)")
    _policy_option(bench, "defenders", "hj,matching",
                   f"comma-separated defender methods, each {SPEC}", metavar="A,B")
    _policy_option(bench, "attackers", ONE_CELL["attackers"],
                   "without --suite: the attacker policy")
    bench.add_argument("--baseline", default=None, metavar="METHOD",
                       help="the method every other is compared with, seed by seed "
                            "(default: hj when chosen, else the first method)")
    bench.add_argument("--episodes", type=int, default=200,
                       help="episodes per method and cell (default: %(default)s; a suite's "
                            "cell may fix its own)")
    bench.add_argument("--seed", type=int, default=None,
                       help="episode k uses seed SEED + k (default: the suite's, or 0)")
    _backend_options(bench, "where episodes run (same results for the same seeds)",
                     "processes of the pool, or CPUs of a local Ray instance (default: all "
                     "cores)")
    _bench_outputs(bench)
    _grid_options(bench)
    _margin_option(bench)
    _force_option(bench)


def _bench_outputs(bench: argparse.ArgumentParser) -> None:
    """``bench``'s ``--csv``, ``--json`` and ``--plot``."""
    bench.add_argument("--csv", metavar="FILE.csv",
                       help="write one row per episode ('-': standard output, the tables then "
                            "go to standard error)")
    bench.add_argument("--json", nargs="?", const="-", default=None, metavar="FILE.json",
                       help="one JSON object: per cell the summaries and paired differences, "
                            "and one row per episode; printed instead of the tables, or "
                            "written to FILE.json")
    _plot_option(bench, "draw the capture rate per cell and method with its interval")


def _maps_command(commands: Any) -> None:
    maps = _command(commands, "maps", _maps)
    maps.add_argument("--count", type=int, default=32, help="maps (default: %(default)s)")
    _seed_option(maps, "seed of the library; map k depends only on it and k")
    maps.add_argument("--out", required=True, metavar="DIR", help="the library folder")
    for option in dataclasses.fields(MapOptions):
        default = option.default
        shown = ",".join(map(str, default)) if isinstance(default, tuple) else default
        maps.add_argument(f"--{option.name.replace('_', '-')}", dest=f"map_{option.name}",
                          metavar="V", help=f"{option.metadata['help']} (default: {shown})")


def _paper_command(commands: Any) -> None:
    paper = _command(commands, "paper", _paper)
    paper.add_argument("--out", default="paper_results", metavar="DIR",
                       help="where the videos, figure and table go (default: %(default)s)")
    paper.add_argument("--no-video", action="store_true", help="skip the videos")
    _grid_options(paper, for_policies=False)
    _force_option(paper)


def _validate_command(commands: Any) -> None:
    validate = _command(commands, "validate", _validate)
    validate.add_argument("files", nargs="+", metavar="FILE",
                          help="TOML scenario files (or built-in names)")


# -- checks made before any work -----------------------------------------------------------

def _check(check: Any, value: Any, field: str, *bounds: Any) -> Any:
    try:
        return check(value, field, *bounds)
    except ValueError as err:
        raise reported(err) from None


def _check_common(args: argparse.Namespace) -> None:
    for name in ("grid1", "grid2"):
        if getattr(args, name, None) is not None:
            _check(checks.integer, getattr(args, name), f"--{name}", *GRID_RANGE[name])
    if getattr(args, "seed", None) is not None:
        _check(checks.integer, args.seed, "--seed", 0, MAX_SEED)
    if getattr(args, "margin_cells", None) is not None:
        from policies.defenders import check_margin_cells

        _check(check_margin_cells, args.margin_cells, "--margin-cells")
    if not check_cache():
        print(f"reachavoid {args.command}: warning: the cache ($REACHAVOID_CACHE_DIR) is "
              "not writable; what is solved now is not kept", file=sys.stderr)
    args.progress = sys.stderr.isatty()


def _load(source: str) -> Scenario:
    try:
        return load_scenario(source)
    except OSError as err:
        raise UsageError(f"scenario: cannot read {source!r}: {err.strerror}",
                         field="scenario") from None


def _specs(choices: list[tuple[str, str]], args: argparse.Namespace) -> list[PolicySpec]:
    """The chosen policies, each with the options given on the command line that it takes
    (``OPTION_FLAGS``); a policy that cannot be found, or an option none takes, is a
    ``UsageError`` naming the flag."""
    options = {name: getattr(args, name) for name in OPTION_FLAGS
               if getattr(args, name, None) is not None}
    try:
        return policy_specs(choices, options, OPTION_FLAGS)
    except ValueError as err:
        side = getattr(err, "field", None)
        if side in TABLES:   # a choice on a side: name its flag
            raise UsageError(f"--{err}", f"--{side}") from None
        raise reported(err) from None


# -- commands -------------------------------------------------------------------------------

def _check_video_options(args: argparse.Namespace, scenario: Scenario) -> None:
    """Check --video, --fps, --every, --realtime and --width; settle ``args.every`` and
    ``args.fps`` (--realtime: the rate at which video time is game time)."""
    from reachavoid_env.video import FPS_RANGE, check_video_path, realtime_every, realtime_fps

    if args.video is not None:
        try:
            check_video_path(args.video)
        except ValueError as err:
            raise reported(err) from None
        writable_file(args.video, "--video", args.force)
    if args.realtime and args.fps is not None:
        raise UsageError("--realtime: sets the fps itself; drop --fps", field="--realtime")
    if args.fps is not None:
        _check(checks.real, args.fps, "--fps", *FPS_RANGE)
    if args.every is not None:
        _check(checks.integer, args.every, "--every", 1, 1_000_000)
    _check(checks.integer, args.width, "--width", 16, 4096)
    rate = reachavoid_env.ReachAvoidEnv.metadata["render_fps"]
    if args.realtime:
        args.every = args.every or realtime_every(scenario.dt, rate)
        args.fps = realtime_fps(scenario.dt, args.every)
        most = GIF_MAX_FPS if str(args.video).lower().endswith(".gif") else FPS_RANGE[1]
        if args.fps > most:
            raise UsageError(f"--realtime: --every {args.every} with {scenario.dt * 1e3:g} ms "
                             f"steps needs {args.fps:g} fps, above this format's {most:g}; use "
                             f"--every {realtime_every(scenario.dt, most)} or more",
                             field="--realtime")
    args.every = args.every or 1
    args.fps = args.fps or rate


def _play(args: argparse.Namespace) -> int:
    if args.preview is not None:
        if args.video is not None:
            raise UsageError("--preview: draws the first frame without playing; drop --video",
                             field="--preview")
        if Path(args.preview).suffix.lower() != ".png":
            raise UsageError(f"--preview: {args.preview!r} must end in .png", field="--preview")
        writable_file(args.preview, "--preview", args.force)
    scenarios = _library(args.scenario)
    scenario = _drawn_map(scenarios, args.seed)
    _check_video_options(args, scenario)
    attacker_spec, defender_spec = _specs([("attackers", args.attackers),
                                           ("defenders", args.defenders)], args)
    try:
        if len(scenarios) == 1:
            attackers = attacker_spec(scenario, seed=args.seed, progress=args.progress)
            defenders = defender_spec(scenario, seed=args.seed, progress=args.progress)
        else:   # a library: the seed draws the map; the policies are built for it
            from reachavoid_env.wrappers import PerMapPolicy

            attackers, defenders = (
                PerMapPolicy(functools.partial(spec, seed=args.seed, progress=args.progress),
                             side)
                for spec, side in ((attacker_spec, "attackers"), (defender_spec, "defenders")))
    except ValueError as err:   # a policy that does not fit the scenario (a model's players)
        raise reported(err) from None
    drawn = args.video is not None or args.preview is not None
    env = reachavoid_env.parallel_env(
        scenario=scenarios, render_mode="rgb_array" if drawn else None,
        render_width=args.width)
    title = episode_title(scenario.name, args.defenders, args.attackers, args.seed)
    try:
        if args.preview is not None:
            return _preview(env, attackers, defenders, title, args)
        result = run_episode(env, attackers, defenders, seed=args.seed, video=args.video,
                             fps=args.fps, every=args.every, title=title,
                             progress=args.video is not None and not args.json
                             and args.progress)
    finally:
        env.close()
    if args.json:
        print(json.dumps(_json_report(result, args)))
    else:
        print(_summary(result, args))
    return 0


def _drawn_map(scenarios: tuple[Scenario, ...], seed: int) -> Scenario:
    """The map an env over ``scenarios`` plays after ``reset(seed=seed)``: the first draw
    of the env's generator seeded with ``seed`` (``ReachAvoidEnv.reset``)."""
    if len(scenarios) == 1:
        return scenarios[0]
    from gymnasium.utils import seeding

    generator, _ = seeding.np_random(seed)
    return scenarios[int(generator.integers(len(scenarios)))]


def _preview(env: Any, attackers: Any, defenders: Any, title: str,
             args: argparse.Namespace) -> int:
    """``play --preview``: the first frame as a PNG, written atomically."""
    import imageio.v3 as iio

    frame = first_frame(env, attackers, defenders, seed=args.seed, title=title)
    with atomic_write(args.preview, "wb") as handle:
        iio.imwrite(handle, frame, extension=".png")
    if args.json:
        print(json.dumps({"preview": args.preview, "width": frame.shape[1],
                          "height": frame.shape[0]}))
    else:
        print(f"{title}\n  first frame: {args.preview} ({frame.shape[1]}x{frame.shape[0]})")
    return 0


def _validate(args: argparse.Namespace) -> int:
    """``validate``: each file loaded and an env reset on it; one line per file."""
    bad = 0
    for source in args.files:
        try:
            scenario = load_scenario(source)
            reachavoid_env.parallel_env(scenario=scenario).reset(seed=0)
            _playable(scenario)
        except (ScenarioError, ValueError, OSError) as err:
            bad += 1
            words = getattr(err, "strerror", None) or str(err)
            if getattr(err, "field", None) != source:   # the message names the file
                words = f"{source}: {words}"
            print(f"reachavoid validate: error: {words}", file=sys.stderr)
            continue
        starts = "given starts" if scenario.attackers is not None else "random starts"
        print(f"{source}: ok ({scenario.name}: {scenario.num_attackers} attackers, "
              f"{scenario.num_defenders} defenders, {starts})")
    return EXIT_USAGE if bad else 0


def _playable(scenario: Scenario) -> None:
    """What ``play`` with its default policies would find wrong with ``scenario`` before
    playing: the shortest-path field's grid and the tubes' grids must see the target."""
    from policies.geodesic import distance_field
    from solvers.hj.games import check_tube_grids

    distance_field(scenario.map, scenario.player_radius)
    check_tube_grids(scenario.map, DEFAULT_GRID["1v1"], DEFAULT_GRID["2v1"])


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
    """What the episode came to, in the words its frames showed."""
    lines = [episode_title(result.scenario, args.defenders, args.attackers, result.seed)]
    for word, names in (("captured", result.captured), ("arrived ", result.arrived)):
        lines.append(f"  {word} {len(names)}" + (f": {', '.join(names)}" if names else ""))
    lines.append(f"  {result.steps} steps, {result.game_time:.3f} s of game time, "
                 f"{result.seconds:.2f} s wall clock")
    lines.append(f"  outcome: {result.outcome}")
    for when, shown in (("start", result.first_lines), ("end", result.last_lines)):
        if shown:
            lines.append(f"  overlay at the {when}: {'; '.join(shown)}")
    if result.guarantees:
        lines.append(f"  captured so far + guaranteed: {result.guarantees[0]} at the first "
                     f"decision, {result.guarantees[-1]} at the last")
    if args.video is not None:
        speed = args.fps * args.every * result.game_time / max(result.steps, 1)
        lines.append(f"  video: {args.video} ({result.frames} frames at {args.fps:g} fps, "
                     f"{_speed_words(speed)})")
    return "\n".join(lines)


def _speed_words(speed: float) -> str:
    """A playback ``speed`` (game seconds per video second) in words."""
    if abs(speed - 1.0) < 1e-6:
        return "real time"
    return f"{1 / speed:.3g}x slow motion" if speed < 1 else f"{speed:.3g}x fast"


def _solve(args: argparse.Namespace) -> int:
    if args.defenders is not None:
        return _solve_library(args)
    if len(args.scenario) != 1:
        raise UsageError("--scenario: several scenarios need --defenders (which tubes to solve)",
                         field="--scenario")
    args.scenario = args.scenario[0]
    if args.grid is not None:
        _check(checks.integer, args.grid, "--grid",
               *GRID_RANGE["grid1" if args.game == "1v1" else "grid2"])
    if args.out is not None:
        writable_folder(args.out, "--out")
    if args.plot is not None:
        writable_file(args.plot, "--plot", args.force)
    scenario = _load(args.scenario)
    grid1 = args.grid1 if args.grid1 is not None else DEFAULT_GRID["1v1"]
    try:
        grid = grid1 if args.game == "1v1" and args.grid is None else args.grid
        report = solve_scenario(scenario, args.game, grid, out=args.out, grid_points_1v1=grid1,
                                plot=args.plot, progress=args.progress)
    except (ValueError, MemoryError) as err:
        raise reported(err) from None
    print(report.summary())
    return 0


def _bench_suite(args: argparse.Namespace) -> Suite:
    """The suite to play: ``--suite``, or one cell of ``--scenario`` and ``--config``."""
    if args.suite is not None:
        given = [f"--{key}" for key, default in ONE_CELL.items()
                 if getattr(args, key) not in (None, default)]
        if given:
            raise UsageError(f"{given[0]}: not with --suite (the suite names its cells)",
                             field=given[0])
        try:
            suite = load_suite(args.suite)
        except OSError as err:
            raise UsageError(f"--suite: cannot read {args.suite!r}: {err.strerror}",
                             field="--suite") from None
        except ValueError as err:
            raise reported(err) from None
        return suite if args.seed is None else Suite(suite.name, suite.version, args.seed,
                                                      suite.cells)
    players = (None if args.config is None
               else _check(parse_players, args.config, "--config"))
    scenarios = _library(args.scenario)
    if len(scenarios) > 1:
        return library_suite(args.scenario, scenarios, args.attackers, args.seed or 0, players)
    scenario = scenarios[0].with_players(*(players or parse_players(ONE_CELL["config"],
                                                                    "--config")))
    cell = Cell(scenario.name, scenario, args.attackers)
    return Suite(scenario.name, 0, args.seed or 0, (cell,))


def _solve_library(args: argparse.Namespace) -> int:
    for flag, value in (("--out", args.out), ("--plot", args.plot), ("--grid", args.grid)):
        if value is not None:
            raise UsageError(f"{flag}: not with --defenders (a library goes to the cache)",
                             field=flag)
    methods = _methods(args.defenders)
    _check_backend_options(args)
    scenarios = _library(args.scenario)
    try:
        rows = solve_library(scenarios, methods, args.grid1, args.grid2, backend=args.backend,
                             workers=args.workers, address=args.address,
                             progress=args.progress)
    except (ValueError, MemoryError) as err:
        if getattr(err, "field", None) == "workers":
            raise UsageError(f"--{err}", "--workers") from None
        raise reported(err) from None
    print(f"{'map':<24} {'game':<5} {'grid':>5} {'seconds':>9} {'peak MiB':>9}")
    for row in rows:
        seconds = "cached" if row.seconds is None else f"{row.seconds:.1f}"
        print(f"{row.map:<24} {row.game:<5} {row.grid:>5} {seconds:>9} "
              f"{row.peak_bytes / 2**20:>9.0f}")
    solved = sum(row.seconds is not None for row in rows)
    print(f"{len(rows)} tubes on {len({row.map for row in rows})} maps: {solved} solved, "
          f"{len(rows) - solved} from the cache ({cache_dir()})")
    return 0


def _methods(text: str) -> list[str]:
    """Comma-separated defender methods (specs), each once, in order."""
    methods = list(dict.fromkeys(m.strip() for m in text.split(",") if m.strip()))
    if not methods:
        raise UsageError(f"--defenders: expected comma-separated methods, got {text!r}",
                         field="--defenders")
    return methods


def _library(source: str | list[str]) -> tuple[Scenario, ...]:
    try:
        return load_library(source)
    except OSError as err:
        raise UsageError(f"scenario: cannot read {err.filename or source!r}: "
                         f"{err.strerror}", field="scenario") from None


def _bench(args: argparse.Namespace) -> int:
    _check(checks.integer, args.episodes, "--episodes", 1, 10_000_000)
    methods = _methods(args.defenders)
    baseline = args.baseline or ("hj" if "hj" in methods else methods[0])
    if baseline not in methods:
        raise UsageError(f"--baseline: {baseline!r} is not among --defenders "
                         f"({', '.join(methods)})", field="--baseline")
    _check_backend_options(args)
    outputs = (("--csv", args.csv), ("--plot", args.plot), ("--json", args.json))
    for flag, path in outputs:
        if path not in (None, "-"):
            writable_file(path, flag, args.force, text=flag != "--plot")
    distinct_outputs(outputs)
    suite = _bench_suite(args)
    attackers = dict.fromkeys(cell.attackers for cell in suite.cells)
    _specs([*(("defenders", m) for m in methods), *(("attackers", a) for a in attackers)],
           args)
    repeated = [cell.label for cell in suite.cells
                if (cell.episodes or args.episodes) > 1 and one_start(cell.scenario)]
    if repeated:
        print(f"reachavoid bench: warning: {len(repeated)} cell(s) play every episode from "
              f"the same start (fixed starts), so their intervals cover the policies' "
              f"randomness only: {', '.join(repeated)}", file=sys.stderr)
    options = {name: getattr(args, name) for name in OPTION_FLAGS
               if getattr(args, name) is not None}
    started = time.perf_counter()
    try:
        result = run_suite(suite, methods, args.episodes, baseline, options, OPTION_FLAGS,
                           backend=args.backend, workers=args.workers, address=args.address,
                           progress=args.progress)
    except PolicyMismatch as err:   # a policy that cannot play a cell (a model's players)
        raise reported(err) from None
    seconds = time.perf_counter() - started
    report = result.to_dict() | {"episodes": args.episodes, "wall_seconds": seconds}
    if args.csv:
        write_csv(args.csv, [{k: (";".join(v) if isinstance(v, list) else v)
                              for k, v in row.items()} for row in report["rows"]])
    if args.plot:
        plot_suite(result, args.plot)
    if args.csv == STDOUT:   # the rows went to standard output: the tables go beside them
        with contextlib.redirect_stdout(sys.stderr):
            return _print_bench(args, result, report, seconds)
    return _print_bench(args, result, report, seconds)


def _print_bench(args: argparse.Namespace, result: SuiteResult, report: dict[str, Any],
                 seconds: float) -> int:
    if args.json == "-":
        print(json.dumps(report))
        return 0
    if args.json:
        write_json(args.json, report, indent=1)
    print(bench_tables(result, seconds))
    for flag, path in (("per-episode rows", args.csv), ("JSON", args.json), ("plot", args.plot)):
        if path:
            print(f"{flag}: {path}")
    return 0


def _maps(args: argparse.Namespace) -> int:
    _check(checks.integer, args.count, "--count", 1, MAX_MAPS)
    out = writable_folder(args.out, "--out")
    try:
        options = options_from_text({option.name: getattr(args, f"map_{option.name}")
                                     for option in dataclasses.fields(MapOptions)})
        written = write_library(out, options, args.seed, args.count)
    except MapError as err:
        flag = f"--{(err.field or '').replace('_', '-')}"
        raise UsageError(err.renamed(flag), flag) from None
    print(f"{args.count} maps and {written[-1].name} -> {out}/")
    return 0


def _paper(args: argparse.Namespace) -> int:
    from reachavoid import paper as paper_table

    out = writable_folder(args.out, "--out")
    for path in paper_table.outputs(out, videos=not args.no_video):
        check_replace(destination(path), "--out", args.force, str(path))
    out.mkdir(parents=True, exist_ok=True)
    rows = paper_table.reproduce(out, args.grid1, args.grid2, videos=not args.no_video,
                                 progress=args.progress)
    print(paper_lines(rows, args.grid1, args.grid2, paper_table.ATTACKERS, out))
    return 0


def _terminate(signum: int, frame: object) -> None:
    raise Terminated(signum)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``reachavoid`` console script; returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    previous = {signum: signal.signal(signum, _terminate) for signum in STOP_SIGNALS}
    try:
        _check_common(args)
        return args.run(args)
    except (UsageError, ScenarioError, CacheLocationError,
            solvers.hj.InsufficientMemoryError) as err:
        print(f"reachavoid {args.command}: error: {err}", file=sys.stderr)
        return EXIT_USAGE
    except BrokenPipeError:
        # standard output closed early (``| head``): end quietly, as a killed writer would
        with contextlib.suppress(OSError, ValueError):   # no file descriptor (captured)
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_PIPE
    except WorkerDied as err:
        print(f"reachavoid {args.command}: error: {err}", file=sys.stderr)
        return EXIT_FAILED
    except OSError as err:
        where = f"{err.filename}: " if err.filename else ""
        print(f"reachavoid {args.command}: error: {where}{err.strerror or err}",
              file=sys.stderr)
        return EXIT_FAILED
    except Terminated as stop:
        print(f"reachavoid {args.command}: {STOP_SIGNALS[stop.signum]}", file=sys.stderr)
        return 128 + stop.signum
    except KeyboardInterrupt:
        print(f"reachavoid {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        forget_expected()
        for signum, handler in previous.items():
            signal.signal(signum, handler)


if __name__ == "__main__":
    sys.exit(main())

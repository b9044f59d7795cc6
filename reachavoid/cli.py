"""The ``reachavoid`` command (design.md, "Command line"): its argument parsers and the
dispatch: exit statuses, signals and the one-line errors. The commands' bodies are
``play`` (``play``, ``validate``) and ``commands`` (``solve``, ``bench``, ``maps``,
``paper``); what they check of their arguments is ``arguments`` and ``paths``; the tables
they print, ``tables``.

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
import os
import signal
import sys
from collections.abc import Callable, Sequence
from typing import Any, NoReturn

import solvers.hj
from policies.registry import names_help
from reachavoid import commands, play
from reachavoid.arguments import (
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_PIPE,
    EXIT_USAGE,
    check_common,
)
from reachavoid.commands import ONE_CELL
from reachavoid.paths import UsageError
from reachavoid.solve import DEFAULT_GRID, GAMES
from reachavoid.suite import suite_names
from reachavoid.sweep import BACKENDS, WorkerDied
from reachavoid.training.budget import Budget
from reachavoid_env import ScenarioError
from reachavoid_env.files import forget_expected
from reachavoid_env.maps import MapOptions
from solvers.hj.cache import CacheLocationError

# The policies (OR-Tools, numba), the env and the paper's figures (matplotlib) are imported by
# the commands that use them, when they run, so that ``--help`` and bad arguments answer at
# once.


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP (its number the argument), raised where the program is so that it
    unwinds as on Ctrl-C; the command reports the signal ``_RECEIVED``."""


STOP_SIGNALS = {signal.SIGTERM: "terminated", signal.SIGHUP: "hung up"}


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


SPEC = "NAME|pkg.module:factory|sb3:MODEL.zip"


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
    """``--backend``, ``--workers`` and ``--address`` (``arguments.check_backend_options``
    checks them)."""
    parser.add_argument("--backend", choices=BACKENDS, default="serial",
                        help=f"{where}: here, on a process pool, or as Ray tasks "
                             "(default: %(default)s)")
    parser.add_argument("--workers", type=int, default=None, metavar="N", help=workers)
    parser.add_argument("--address", default=None, metavar="ADDR",
                        help="with --backend ray, an existing Ray cluster (default: start a "
                             "local one)")


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
    "exploit": ("train a best response to each defender and report its exploitability",
                "For each defender and training seed, train an attacker team against the "
                "defender as bench plays it (clone the best scripted team with DAgger and "
                "full-speed actions, then PPO), evaluate it on fresh starts against that "
                "scripted team, and report the exploitability: the best response's arrival "
                "rate minus the script's, paired, beside the captures the defender's tubes "
                "promise and deliver. Each run keeps its own folder under --out; a rerun "
                "skips the runs that finished."),
    "validate": ("check scenario files without playing them",
                 "Load each scenario (a TOML file or a built-in name) and reset an env on it; "
                 "print one line per file. Exit status 0 when all are valid, 2 when any is not "
                 "(its error on stderr)."),
}
"""Each subcommand's line in ``reachavoid --help`` and the description atop its own
``--help``."""


def _command(subparsers: Any, name: str,
             run: Callable[[argparse.Namespace], int]) -> argparse.ArgumentParser:
    """The subcommand ``name`` (its texts in ``COMMANDS``), carried out by ``run``."""
    summary, description = COMMANDS[name]
    command = subparsers.add_parser(name, help=summary, description=description)
    command.set_defaults(run=run)
    return command


def build_parser() -> argparse.ArgumentParser:
    """The ``reachavoid`` parser: each ``_*_command`` adds a subcommand, in this order."""
    parser = _Parser(prog="reachavoid",
                     description="Multi-agent reach-avoid games: play, record, solve.")
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in (_play_command, _solve_command, _bench_command, _maps_command, _paper_command,
                _exploit_command, _validate_command):
        add(subparsers)
    return parser


def _play_command(subparsers: Any) -> None:
    parser = _command(subparsers, "play", play.play)
    _scenario_option(parser, "paper_6v2",
                     "a built-in scenario name, a TOML scenario file, or a map library folder "
                     "or index (the seed draws the map)")
    _policy_option(parser, "attackers", "shortest-path", "attacker policy")
    _policy_option(parser, "defenders", "hj", "defender policy")
    _grid_options(parser)
    _margin_option(parser)
    _seed_option(parser, "seed of the env (random starts) and random policies")
    _video_options(parser)
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object instead of a summary")
    _force_option(parser)


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


def _solve_command(subparsers: Any) -> None:
    parser = _command(subparsers, "solve", commands.solve)
    parser.add_argument("--scenario", nargs="+", default=["paper_2v1"],
                        metavar="NAME|FILE.toml|DIR",
                        help="a built-in scenario name or a TOML scenario file; with "
                             "--defenders also several, or map library folders or index files "
                             "(default: %(default)s)")
    parser.add_argument("--game", choices=GAMES, default="1v1",
                        help="which game (default: %(default)s)")
    parser.add_argument("--grid", type=int, default=None, metavar="N",
                        help=f"grid nodes per axis (default: {DEFAULT_GRID['1v1']} for 1v1, "
                             f"{DEFAULT_GRID['2v1']} for 2v1 and 1v2)")
    parser.add_argument("--defenders", metavar="A,B",
                        help="instead of --game: every tube these defender methods need, on "
                             "every map of --scenario, at --grid1/--grid2; what the cache holds "
                             "is skipped")
    _grid_options(parser, for_policies=False)
    _backend_options(parser, "with --defenders, where the maps are solved",
                     "with --defenders, concurrent solves (default: all cores; refused when "
                     "they would not fit in memory)")
    parser.add_argument("--out", metavar="DIR", help="also save the value function here")
    _plot_option(parser, "draw the value's slices at the scenario's starts (paper Fig. 2)")
    _force_option(parser)


def _bench_command(subparsers: Any) -> None:
    parser = _command(subparsers, "bench", commands.bench)
    parser.add_argument("--suite", default=None, metavar="NAME|FILE.toml",
                        help=f"play a suite of cells instead of one --config (built-ins: "
                             f"{', '.join(suite_names())})")
    _scenario_option(parser, ONE_CELL["scenario"],
                     "without --suite: the map, speeds and settings; a map library (a folder "
                     "of `reachavoid maps`, its index.toml) plays a cell per map and pools them")
    parser.add_argument("--config", default=None, metavar="MvN",
                        help=f"without --suite: attackers v defenders, drawn at random each "
                             f"episode (default: {ONE_CELL['config']}; over a map library, its "
                             f"maps' own)")
    _policy_option(parser, "defenders", "hj,matching",
                   f"comma-separated defender methods, each {SPEC}", metavar="A,B")
    _policy_option(parser, "attackers", ONE_CELL["attackers"],
                   "without --suite: the attacker policy")
    parser.add_argument("--baseline", default=None, metavar="METHOD",
                        help="the method every other is compared with, seed by seed "
                             "(default: hj when chosen, else the first method)")
    parser.add_argument("--episodes", type=int, default=200,
                        help="episodes per method and cell (default: %(default)s; a suite's "
                             "cell may fix its own)")
    parser.add_argument("--seed", type=int, default=None,
                        help="episode k uses seed SEED + k (default: the suite's, or 0)")
    _backend_options(parser, "where episodes run (same results for the same seeds)",
                     "processes of the pool, or CPUs of a local Ray instance (default: all "
                     "cores)")
    _bench_outputs(parser)
    _grid_options(parser)
    _margin_option(parser)
    _force_option(parser)


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


def _maps_command(subparsers: Any) -> None:
    parser = _command(subparsers, "maps", commands.maps)
    parser.add_argument("--count", type=int, default=32, help="maps (default: %(default)s)")
    _seed_option(parser, "seed of the library; map k depends only on it and k")
    parser.add_argument("--out", required=True, metavar="DIR", help="the library folder")
    for option in dataclasses.fields(MapOptions):
        default = option.default
        shown = ",".join(map(str, default)) if isinstance(default, tuple) else default
        parser.add_argument(f"--{option.name.replace('_', '-')}", dest=f"map_{option.name}",
                            metavar="V", help=f"{option.metadata['help']} (default: {shown})")


def _paper_command(subparsers: Any) -> None:
    parser = _command(subparsers, "paper", commands.paper)
    parser.add_argument("--out", default="paper_results", metavar="DIR",
                        help="where the videos, figure and table go (default: %(default)s)")
    parser.add_argument("--no-video", action="store_true", help="skip the videos")
    _grid_options(parser, for_policies=False)
    _force_option(parser)


def _exploit_command(subparsers: Any) -> None:
    parser = _command(subparsers, "exploit", commands.exploit)
    _policy_option(parser, "defenders", "hj", "comma-separated built-in defender methods, "
                   "each trained against", metavar="A,B")
    _scenario_option(parser, "paper_2v1", "the map, speeds and settings")
    parser.add_argument("--config", default="2v1", metavar="MvN",
                        help="attackers v defenders, random starts (default: %(default)s)")
    _grid_options(parser, for_policies=False)
    parser.add_argument("--seeds", type=int, default=1, metavar="N",
                        help="training seeds 0..N-1 per defender (default: %(default)s)")
    for item in dataclasses.fields(Budget):
        parser.add_argument(f"--{item.name.replace('_', '-')}", type=type(item.default),
                            default=item.default, metavar=item.metadata["metavar"],
                            help=f"{item.metadata['help']} (default: %(default)s)")
    _backend_options(parser, "where the runs go", "processes of the pool, or CPUs of a local "
                     "Ray instance (default: all cores)")
    parser.add_argument("--transfer", action="store_true",
                        help="after the runs, play every trained team in --out against "
                        "every named defender it was not trained against, and the "
                        "defender's best scripted team, on the same fresh starts (each "
                        "cell kept in --out)")
    parser.add_argument("--out", required=True, metavar="DIR",
                        help="a folder per run, and exploitability.json")
    _plot_option(parser, "draw the exploitability per defender with its intervals")
    _force_option(parser)


def _validate_command(subparsers: Any) -> None:
    parser = _command(subparsers, "validate", play.validate)
    parser.add_argument("files", nargs="+", metavar="FILE",
                        help="TOML scenario files, built-in names or map library folders "
                             "(every map checked)")


_RECEIVED: list[int] = []
"""The stop signals (``STOP_SIGNALS``) received while the command runs: what it reports,
even where a library catches ``Terminated`` and raises a plain ``KeyboardInterrupt``."""


def _terminate(signum: int, frame: object) -> None:
    _RECEIVED.append(signum)
    raise Terminated(signum)


def _names_as_given() -> None:
    """Standard output and error print a file name that is not valid in the locale's
    encoding (the bytes ``b'\\xff'`` under UTF-8) as the bytes it was given, not a
    ``UnicodeEncodeError``."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(AttributeError, ValueError):   # no text wrapper, or closed
            stream.reconfigure(errors="surrogateescape")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``reachavoid`` console script; returns the exit status."""
    _names_as_given()
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    _RECEIVED.clear()
    previous = {signum: signal.signal(signum, _terminate) for signum in STOP_SIGNALS}
    try:
        check_common(args)
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
        print(f"reachavoid {args.command}: error: {err}; no output was written (tubes solved "
              "before stay in the cache)", file=sys.stderr)
        return EXIT_FAILED
    except OSError as err:
        where = f"{err.filename}: " if err.filename else ""
        print(f"reachavoid {args.command}: error: {where}{err.strerror or err}",
              file=sys.stderr)
        return EXIT_FAILED
    except KeyboardInterrupt:   # Terminated too, or what a library made of it (Ray's wait)
        if not _RECEIVED:
            print(f"reachavoid {args.command}: interrupted", file=sys.stderr)
            return EXIT_INTERRUPTED
        print(f"reachavoid {args.command}: {STOP_SIGNALS[_RECEIVED[0]]}", file=sys.stderr)
        return 128 + _RECEIVED[0]
    finally:
        forget_expected()
        for signum, handler in previous.items():
            signal.signal(signum, handler)


if __name__ == "__main__":
    sys.exit(main())

"""The training scripts' shared flags: the scripted defenders (``add_defender_arguments``,
``defender_options``), the rewards (``add_reward_arguments``, ``reward_options``), the
attacker-only env they make (``attackers_from_args``), and every number of a script checked
before any work (``check_ranges``); each bad value is argparse's one-line error naming the
flag, exit status 2."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Mapping
from typing import Any

from policies.registry import DEFENDERS
from reachavoid.training.views import make_attackers_parallel_env
from reachavoid_env import checks
from reachavoid_env.maps import load_library
from reachavoid_env.scenario import load_scenario
from reachavoid_env.wrappers import AttackerParallelEnv
from solvers.hj.settings import TRAINING_GRIDS


def scenario_argument(library: bool = False) -> Callable[[str], str]:
    """An argparse ``type`` that checks a scenario (with ``library``, a map library too)
    loads and keeps its name: a bad one is argparse's one-line error, exit status 2."""
    def checked(source: str) -> str:
        try:
            (load_library if library else load_scenario)(source)
        except (checks.FieldError, OSError, ValueError) as err:
            raise argparse.ArgumentTypeError(str(err)) from None
        return source
    checked.__name__ = "scenario"
    return checked


Bounds = tuple[float | None, float | None] | tuple[float | None, float | None, bool]
"""A flag's range for ``check_ranges``: ``(low, high)`` (``None``: open), and optionally
whether ``low`` itself is excluded."""


def check_ranges(parser: argparse.ArgumentParser, args: argparse.Namespace,
                 ranges: Mapping[str, Bounds]) -> None:
    """Each value of ``args`` named in ``ranges`` within its bounds (``Bounds``; an int flag
    an integer, a float flag finite: no NaN), checked before any work by the one set of
    validators (``reachavoid_env.checks``); else argparse's one-line error naming the
    flag, exit status 2. ``None`` (a flag left unset) is not checked."""
    for name, (low, high, *low_open) in ranges.items():
        value, flag = getattr(args, name), f"--{name.replace('_', '-')}"
        try:
            if isinstance(value, int):
                checks.integer(value, flag, low, high)
            elif value is not None:
                checks.real(value, flag, low, high, low_open=bool(low_open and low_open[0]))
        except checks.FieldError as err:
            parser.error(str(err))


def add_defender_arguments(parser: argparse.ArgumentParser, scenario: str = "paper_6v2",
                           defenders: str = "hj", library: bool = False) -> None:
    """The training scripts' ``--scenario`` (a map library too when the script takes one:
    ``library``; checked to load), ``--defenders``, ``--grid1`` and ``--grid2`` (coarse tubes
    by default, so a run starts in seconds; ``defender_options`` reads them)."""
    parser.add_argument("--scenario", default=scenario, type=scenario_argument(library),
                        help="built-in name, TOML file or map library (folder or index.toml)"
                        if library else "built-in name or TOML file")
    parser.add_argument("--defenders", default=defenders, choices=DEFENDERS,
                        help="scripted defenders (default: %(default)s)")
    parser.add_argument("--grid1", type=int, default=TRAINING_GRIDS.grid1,
                        help="hj defenders' 1v1 grid")
    parser.add_argument("--grid2", type=int, default=TRAINING_GRIDS.grid2,
                        help="hj defenders' 2v1 grid")


def defender_options(args: argparse.Namespace) -> dict[str, Any] | None:
    """``defender_options`` of the training envs from ``add_defender_arguments``' values."""
    if args.defenders != "hj":
        return None
    return {"grid1": args.grid1, "grid2": args.grid2, "progress": False}


def add_reward_arguments(parser: argparse.ArgumentParser, team: bool = False) -> None:
    """The training scripts' ``--action-repeat`` (10 game steps per agent step),
    ``--shaping`` (1) and ``--timeout-reward`` (-1: in the game only arrival wins, so hiding
    until the time limit scores as a loss), and with ``team`` (scripts where several
    attackers learn) ``--team-reward`` (0: the views' ``team_reward``, each attacker's
    share of its teammates' arrivals and captures); ``reward_options`` reads them."""
    parser.add_argument("--action-repeat", type=int, default=10,
                        help="game steps per agent step (default: %(default)s)")
    parser.add_argument("--shaping", type=float, default=1.0,
                        help="weight of the progress reward (default: %(default)s)")
    parser.add_argument("--timeout-reward", type=float, default=-1.0,
                        help="reward for still being in play at the time limit "
                             "(default: %(default)s)")
    if team:
        parser.add_argument("--team-reward", type=float, default=0.0,
                            help="weight of the teammates' arrivals (+1) and captures (-1) "
                                 "in each attacker's reward (default: %(default)s)")


def reward_options(args: argparse.Namespace) -> dict[str, Any]:
    """The training envs' keywords from ``add_reward_arguments``' values."""
    team = {"team_reward": args.team_reward} if "team_reward" in vars(args) else {}
    return {"action_repeat": args.action_repeat, "shaping": args.shaping,
            "timeout_reward": args.timeout_reward, **team}


def attackers_from_args(args: argparse.Namespace) -> AttackerParallelEnv:
    """The attacker-only env of ``add_defender_arguments`` and ``add_reward_arguments``."""
    return make_attackers_parallel_env(args.scenario, defenders=args.defenders,
                                       defender_options=defender_options(args),
                                       **reward_options(args))

"""The training scripts' shared flags: the scripted defenders (``DefenderFields``,
``add_defender_arguments``, ``defender_options``), the rewards (``RewardFields``,
``add_reward_arguments``, ``reward_options``), the attacker-only env they make
(``attackers_from_args``), a script's config dataclass as its flags (``config_parser``),
and every number of a script checked before any work (``check_ranges``); each bad value is
argparse's one-line error naming the flag, exit status 2."""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
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


def scenario_field(default: str) -> Any:
    """The config field ``--scenario`` (checked to load) with this default."""
    return field(default=default, metadata={"type": scenario_argument(),
                                            "help": "built-in name or TOML file"})


@dataclass
class DefenderFields:
    """The scripted defenders a training script plays against, as fields of its config
    dataclass (a subclass may give other defaults): ``--scenario`` (checked to load),
    ``--defenders``, ``--grid1`` and ``--grid2`` (coarse tubes by default, so a run starts
    in seconds; ``defender_options`` reads them)."""

    scenario: str = scenario_field("paper_6v2")
    defenders: str = field(default="hj", metadata={
        "choices": DEFENDERS, "help": "scripted defenders"})
    grid1: int = field(default=TRAINING_GRIDS.grid1, metadata={"help": "hj defenders' 1v1 grid"})
    grid2: int = field(default=TRAINING_GRIDS.grid2, metadata={"help": "hj defenders' 2v1 grid"})


@dataclass
class RewardFields:
    """The attackers' rewards, as fields of a training script's config dataclass:
    ``--action-repeat`` (10 game steps per agent step), ``--shaping`` (1),
    ``--timeout-reward`` (-1: in the game only arrival wins, so hiding until the time limit
    scores as a loss) and ``--team-reward`` (0: the views' ``team_reward``, each attacker's
    share of its teammates' arrivals and captures); ``reward_options`` reads them."""

    action_repeat: int = field(default=10, metadata={"help": "game steps per agent step"})
    shaping: float = field(default=1.0, metadata={"help": "weight of the progress reward"})
    timeout_reward: float = field(default=-1.0, metadata={
        "help": "reward for still being in play at the time limit"})
    team_reward: float = field(default=0.0, metadata={
        "help": "weight of the teammates' arrivals (+1) and captures (-1) in each attacker's "
                "reward"})


def _add_field(parser: argparse.ArgumentParser, option: dataclasses.Field, default: Any,
               **changes: Any) -> None:
    """``option`` as a ``--flag`` (``_`` as ``-``) with ``default``: its metadata (help,
    choices, type...) over ``type(default)`` (``str`` where the default is ``None``)."""
    kwargs = {"default": default, **option.metadata, **changes}
    kwargs.setdefault("type", str if default is None else type(default))
    parser.add_argument(f"--{option.name.replace('_', '-')}", **kwargs)


def config_parser(config: type, description: str) -> argparse.ArgumentParser:
    """The parser of a script's config dataclass ``config``: one ``--flag`` per field, its
    default shown in the help; ``config(**vars(parser.parse_args()))`` is the config."""
    parser = argparse.ArgumentParser(description=description,
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    for option in dataclasses.fields(config):
        _add_field(parser, option, option.default)
    return parser


def add_defender_arguments(parser: argparse.ArgumentParser, scenario: str = "paper_6v2",
                           defenders: str = "hj", library: bool = False) -> None:
    """``DefenderFields``' flags with these defaults (a map library too where the script
    takes one: ``library``)."""
    defaults = {"scenario": scenario, "defenders": defenders}
    for option in dataclasses.fields(DefenderFields):
        changes = {"help": option.metadata["help"] + " (default: %(default)s)"}
        if option.name == "scenario" and library:
            changes = {"type": scenario_argument(library),
                       "help": "built-in name, TOML file or map library (folder or index.toml)"}
        _add_field(parser, option, defaults.get(option.name, option.default), **changes)


def defender_options(args: argparse.Namespace) -> dict[str, Any] | None:
    """``defender_options`` of the training envs from ``add_defender_arguments``' values."""
    if args.defenders != "hj":
        return None
    return {"grid1": args.grid1, "grid2": args.grid2, "progress": False}


def add_reward_arguments(parser: argparse.ArgumentParser, team: bool = False) -> None:
    """``RewardFields``' flags, ``--team-reward`` only with ``team`` (scripts where several
    attackers learn)."""
    for option in dataclasses.fields(RewardFields):
        if option.name != "team_reward" or team:
            _add_field(parser, option, option.default,
                       help=option.metadata["help"] + " (default: %(default)s)")


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

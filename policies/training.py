"""Training envs with named scripted policies: the factories of the Gymnasium / PettingZoo
ids (``reachavoid_env.training_ids`` registers them; ``GYM_ID``, ``PETTINGZOO_ID``,
``gym_id`` and ``pettingzoo_id`` are re-exported here).

``reachavoid_env.wrappers`` takes policy objects; this module names them, so an env can be
made from strings (on the command line, in a registry id, in a subprocess):

    from policies.training import make_attacker_env
    env = make_attacker_env("paper_2v1", defenders="hj",
                            defender_options={"grid1": 31, "grid2": 15})

Importing ``reachavoid_env`` (which ``policies`` does) registers, once Gymnasium is imported
(``make_attacker_env``, one learning attacker):

- ``reachavoid/Attacker-v1`` (``scenario=`` keyword, default ``paper_2v1``; a map library
  folder or index trains across its maps, one drawn per reset, with the defenders built
  per map);
- ``reachavoid/Attacker-<builtin>-v1`` for every built-in scenario, e.g.
  ``reachavoid/Attacker-paper_2v1-v1`` (the scenario's starts);
- ``reachavoid/Attacker-<builtin>-random-v1``: the same map and player counts with
  random starts at every reset (``starts="random"``), e.g.
  ``reachavoid/Attacker-paper_6v2-random-v1`` for 6 vs 2;

and for PettingZoo (``pettingzoo.make("parallel", ...)``, ``make_attackers_parallel_env``,
every attacker learning; PettingZoo 1.27 on) ``reachavoid/Attackers-v1`` (``scenario=`` keyword) and
``reachavoid/Attackers-<builtin>-v1`` / ``reachavoid/Attackers-<builtin>-random-v1``
likewise. Every id takes ``starts="random"`` as a keyword too. Without importing anything
first, Gymnasium's ``"module:id"`` form loads them:
``gymnasium.make("policies:reachavoid/Attacker-paper_2v1-random-v1")``.

Version history: ``-v1`` observe the egocentric observation (``ReachAvoid-v1``: target,
lidar, the others relative to the agent); the same ids ending ``-v0`` remain, with v0's
global observation (``observation={"egocentric": False}``). Keyword arguments of
``gymnasium.make`` / ``make_vec`` / ``pettingzoo.make`` go to the factory.

Defenders default to ``"hj"``, the paper's HJ + MIP defenders
(``HJDefenderPolicy.for_scenario``): the first env of a game solves its HJ tubes and
caches them on disk (design.md section 4); later envs, subprocesses included, load them.
"""

from __future__ import annotations

import argparse
import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from policies.registry import DEFENDERS, PolicySpec, make_batch_policy
from reachavoid_env import checks
from reachavoid_env.game_state import BatchPolicy, PerCopy, PerMap
from reachavoid_env.maps import ScenarioSource, load_library
from reachavoid_env.scenario import load_scenario
from reachavoid_env.training_ids import GYM_ID as GYM_ID
from reachavoid_env.training_ids import PETTINGZOO_ID as PETTINGZOO_ID
from reachavoid_env.training_ids import gym_id as gym_id
from reachavoid_env.training_ids import pettingzoo_id as pettingzoo_id
from reachavoid_env.vector import ReachAvoidVectorEnv
from reachavoid_env.vector_views import LearnerVectorEnv
from reachavoid_env.wrappers import AttackerParallelEnv, SingleAttackerEnv
from solvers.hj.settings import TRAINING_GRIDS


def defender_factory(name: str = "hj", **options: Any) -> PolicySpec:
    """Factory of the defender policy ``name`` (a spec of ``policies.registry``) with
    ``options``."""
    return PolicySpec.of("defenders", name, **options)


def attacker_factory(name: str = "shortest-path", **options: Any) -> PolicySpec:
    """Factory of the attacker policy ``name`` (a spec of ``policies.registry``) with
    ``options``."""
    return PolicySpec.of("attackers", name, **options)


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


@dataclass(frozen=True)
class StartCurriculum:
    """Easy starts first: random attackers start within ``first`` map units of the target
    (the vector env's ``start_reach``), a reach that grows linearly to the map's diagonal
    over the first ``fraction`` of training; after that, anywhere."""

    first: float
    fraction: float = 0.5

    def __post_init__(self) -> None:
        checks.positive(self.first, "easy_starts")
        checks.positive(self.fraction, "easy_fraction", 1.0)

    def reach(self, progress: float, diagonal: float) -> float | None:
        """The start reach (map units; ``None``: anywhere) when ``progress`` (0 to 1) of
        the training is done, on a map whose domain's diagonal is ``diagonal``."""
        if progress >= self.fraction:
            return None
        return self.first + max(diagonal - self.first, 0.0) * progress / self.fraction


def add_curriculum_arguments(parser: argparse.ArgumentParser) -> None:
    """``--easy-starts D`` and ``--easy-fraction F`` (``StartCurriculum``'s ``first`` and
    ``fraction``); ``start_curriculum`` reads them."""
    parser.add_argument("--easy-starts", type=float, default=None, metavar="D",
                        help="curriculum: attackers start within D map units of the target "
                             "at first (default: anywhere from the start)")
    parser.add_argument("--easy-fraction", type=float, default=0.5, metavar="F",
                        help="the share of training over which the start reach grows to the "
                             "whole map (default: %(default)s)")


def start_curriculum(args: argparse.Namespace) -> StartCurriculum | None:
    """The curriculum of ``add_curriculum_arguments``' values (``None`` without
    ``--easy-starts``); ``ValueError`` naming the option if a value is out of range."""
    if args.easy_starts is None:
        return None
    return StartCurriculum(args.easy_starts, args.easy_fraction)


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


def _source(value: Any, options: Mapping[str, Any] | None, side: str, field: str) -> Any:
    """A name becomes its factory; a policy or factory passes through."""
    if isinstance(value, str):
        return PolicySpec.of(side, value, **(options or {}))
    if options:
        raise ValueError(f"{field}_options: only used with a policy name, got a "
                         f"{type(value).__name__} for {field}")
    return value


def make_attacker_env(scenario: ScenarioSource = "paper_2v1", defenders: Any = "hj",
                      teammates: Any = "shortest-path",
                      defender_options: Mapping[str, Any] | None = None,
                      teammate_options: Mapping[str, Any] | None = None,
                      **env_kwargs: Any) -> SingleAttackerEnv:
    """A ``SingleAttackerEnv``: one learning attacker against scripted defenders.

    ``defenders`` / ``teammates``: a policy name (``DEFENDERS`` / ``ATTACKERS``, built with
    ``defender_options`` / ``teammate_options``), a policy object or a factory
    ``scenario -> policy``. Teammates play only where the scenario has more than one
    attacker. ``env_kwargs``: ``starts`` (``"random"``: new starts at every reset),
    ``attacker``, ``max_cycles``, ``render_mode``, ``shaping``, ``timeout_reward``,
    ``action_repeat``, ``scripted_every``, ``render_width``, ``info_format``
    (``SingleAttackerEnv``).
    """
    return SingleAttackerEnv(
        _source(defenders, defender_options, "defenders", "defender"), scenario=scenario,
        teammates=_source(teammates, teammate_options, "attackers", "teammate"), **env_kwargs)


def make_attackers_parallel_env(scenario: ScenarioSource = "paper_2v1", defenders: Any = "hj",
                                defender_options: Mapping[str, Any] | None = None,
                                **env_kwargs: Any) -> AttackerParallelEnv:
    """An ``AttackerParallelEnv``: every attacker learns, ``defenders`` (a name, a policy or
    a factory, as in ``make_attacker_env``) moves the defenders. ``env_kwargs``:
    ``starts`` (``"random"``: new starts at every reset), ``max_cycles``, ``render_mode``,
    ``shaping``, ``timeout_reward``, ``team_reward``, ``action_repeat``, ``scripted_every``,
    ``render_width``, ``info_format`` (``AttackerParallelEnv``)."""
    return AttackerParallelEnv(_source(defenders, defender_options, "defenders", "defender"),
                               scenario=scenario, **env_kwargs)


def batch_policy(source: Any, options: Mapping[str, Any] | None, side: str, field: str,
                 vec: ReachAvoidVectorEnv) -> BatchPolicy:
    """A ``BatchPolicy`` for the scripted ``side`` of ``vec``'s copies: a ``BatchPolicy``
    as it is; a name through ``make_batch_policy`` (its batched class where it has one: all
    copies of a map in one call), one per map over several maps (``PerMap``); otherwise a
    factory ``scenario -> policy`` asked copy by copy (``PerCopy``)."""
    if isinstance(source, BatchPolicy):
        return source
    if isinstance(source, str):
        options = dict(options or {})
        if len(vec.scenarios) == 1:
            return make_batch_policy(side, source, vec.base_scenario, **options)
        PolicySpec.of(side, source, **options)   # a wrong name or option fails here, once
        return PerMap(functools.partial(make_batch_policy, side, source, **options))
    built = _source(source, options, side, field)
    if not callable(built) or isinstance(built, type):
        raise TypeError(f"{field}s: the vector env needs a name, a factory scenario -> policy "
                        f"or a BatchPolicy, got {type(source).__name__}")
    return PerCopy(built, side)


def make_attackers_vector_env(scenario: ScenarioSource = "paper_2v1", defenders: Any = "hj",
                              num_envs: int = 16,
                              defender_options: Mapping[str, Any] | None = None,
                              action_repeat: int = 1, timeout_reward: float = 0.0,
                              autoreset: bool = True, team_reward: float = 0.0,
                              **env_kwargs: Any) -> LearnerVectorEnv:
    """Every attacker of ``num_envs`` copies learns (``LearnerVectorEnv``, arrays
    ``(K, M, ...)``, ``team_reward`` as there); ``defenders`` (a name, a factory or a
    ``BatchPolicy``) move the defenders of every copy. ``autoreset=False`` for TorchRL
    (``integrations.torchrl.VectorGroupEnv``). ``env_kwargs``: ``starts``
    (``"random"`` by default), ``max_cycles``, ``shaping``, ``observation``,
    ``copies_per_map`` (``ReachAvoidVectorEnv``)."""
    vec = ReachAvoidVectorEnv(scenario, num_envs=num_envs, autoreset=False, **env_kwargs)
    base = vec.base_scenario
    return LearnerVectorEnv(
        vec, base.attacker_names,
        [(batch_policy(defenders, defender_options, "defenders", "defender", vec),
          base.defender_names)], action_repeat=action_repeat, timeout_reward=timeout_reward,
        autoreset=autoreset, team_reward=team_reward)


def make_defenders_vector_env(scenario: ScenarioSource = "paper_2v1",
                              attackers: Any = "shortest-path", num_envs: int = 16,
                              attacker_options: Mapping[str, Any] | None = None,
                              action_repeat: int = 1, autoreset: bool = True,
                              **env_kwargs: Any) -> LearnerVectorEnv:
    """Every defender of ``num_envs`` copies learns (arrays ``(K, N, ...)``); ``attackers``
    (a name, a factory or a ``BatchPolicy``) move the attackers of every copy: the view a
    learned defender trains on. ``env_kwargs`` as ``make_attackers_vector_env``."""
    vec = ReachAvoidVectorEnv(scenario, num_envs=num_envs, autoreset=False, **env_kwargs)
    base = vec.base_scenario
    return LearnerVectorEnv(
        vec, base.defender_names,
        [(batch_policy(attackers, attacker_options, "attackers", "attacker", vec),
          base.attacker_names)], action_repeat=action_repeat, autoreset=autoreset)


def make_attacker_vector_env(scenario: ScenarioSource = "paper_2v1", defenders: Any = "hj",
                             teammates: Any = "shortest-path", num_envs: int = 16,
                             attacker: int = 0,
                             defender_options: Mapping[str, Any] | None = None,
                             teammate_options: Mapping[str, Any] | None = None,
                             action_repeat: int = 1, timeout_reward: float = 0.0,
                             **env_kwargs: Any) -> LearnerVectorEnv:
    """One learning attacker (``attacker_{attacker}``) in each of ``num_envs`` copies, as
    ``make_attacker_env`` has it (its episode ends when it leaves), against scripted
    defenders and teammates (names, factories or ``BatchPolicy`` objects). Wrap it in
    ``integrations.vector.GymVectorEnv`` for Gymnasium's vector API."""
    vec = ReachAvoidVectorEnv(scenario, num_envs=num_envs, autoreset=False, **env_kwargs)
    base = vec.base_scenario
    checks.integer(attacker, "attacker", 0, base.num_attackers - 1)
    learner = base.attacker_names[attacker]
    scripted = [(batch_policy(defenders, defender_options, "defenders", "defender", vec),
                 base.defender_names)]
    others = [name for name in base.attacker_names if name != learner]
    if others:
        scripted.append((batch_policy(teammates, teammate_options, "attackers", "teammate", vec),
                         others))
    return LearnerVectorEnv(vec, [learner], scripted, action_repeat=action_repeat,
                            timeout_reward=timeout_reward)

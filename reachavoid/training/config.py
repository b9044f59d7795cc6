"""The team recipe's flags and what they name: ``parse_args`` (every check before any work),
the files a run writes, its maps and its attacker-only game, and the saved models it reads.

The recipe itself (what each flag does) is described in ``reachavoid.training.recipe``.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from policies.learned import DEFAULT_OBSERVATION, check_model_file, read_sb3
from policies.registry import ATTACKERS
from reachavoid.paths import UsageError, check_outputs, writable_folder
from reachavoid.training.curriculum import add_curriculum_arguments, start_curriculum
from reachavoid.training.flags import (
    Bounds,
    add_defender_arguments,
    add_reward_arguments,
    check_ranges,
    defender_options,
    scenario_argument,
)
from reachavoid.training.self_play import MAX_POOL
from reachavoid.training.views import make_attackers_parallel_env
from reachavoid_env import Scenario
from reachavoid_env.checks import FieldError
from reachavoid_env.maps import load_library
from reachavoid_env.observations import ObservationConfig
from reachavoid_env.vector import MAX_COPIES
from reachavoid_env.wrappers import AttackerParallelEnv

if TYPE_CHECKING:
    from stable_baselines3 import PPO

DESCRIPTION = ("Train a team of attackers that share one Stable-Baselines3 PPO policy "
               "(parameter sharing) against the HJ defenders, and compare it with the "
               "scripted and random teams on the same seeded starts.")
"""The recipe's one-line description (its ``--help``)."""
RANGES: dict[str, Bounds] = {
    "copies": (1, MAX_COPIES), "copies_per_map": (1, MAX_COPIES), "n_steps": (1, 10**7),
    "batch_size": (2, 10**9), "action_repeat": (1, 1_000_000), "episodes": (1, 10**7),
    "first_seed": (0, 2**32 - 1), "seed": (0, 2**32 - 1), "timesteps": (0, 10**13),
    "imitate_steps": (0, 10**13), "imitate_epochs": (1, 10**6), "dagger_rounds": (0, 10**6),
    "dagger_steps": (1, 10**13), "dagger_epochs": (1, 10**6), "past_selves": (0, MAX_POOL),
    "video_every": (1, 10**6), "video_width": (16, 4096), "max_minutes": (0.0, None, True),
    "learning_rate": (0.0, None, True), "clip_range": (0.0, None, True),
    "ent_coef": (0.0, None), "imitate_learning_rate": (0.0, None, True),
    "imitate_log_std": (None, None), "shaping": (None, None), "timeout_reward": (None, None),
    "team_reward": (None, None)}
"""Every number's range (``check_ranges``: NaN, zero or negatives where they make no
sense, and sizes the envs refuse, are argparse's one-line error before any work)."""
TEAMS = ("learned", *ATTACKERS)
"""``learned`` and every scripted attacker team of ``policies.registry.ATTACKERS``."""
DEFAULT_TEAMS = ("learned", "shortest-path", "random")


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The recipe's flags from ``argv`` (default: the command line), every one checked and
    the outputs with them, before any work: a bad one is argparse's one-line error (exit
    status 2)."""
    parser = argparse.ArgumentParser(description=DESCRIPTION,
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    add_defender_arguments(parser, scenario="paper_6v2", library=True)
    parser.add_argument("--timesteps", type=int, default=1_000_000,
                        help="PPO agent steps, one per attacker slot and env step; 0: no PPO "
                             "(default: %(default)s)")
    parser.add_argument("--max-minutes", type=float, default=None,
                        help="stop training after this much wall time (None: no limit)")
    parser.add_argument("--copies", type=int, default=16,
                        help="game copies in the vector env (default: %(default)s)")
    parser.add_argument("--copies-per-map", type=int, default=1,
                        help="over a map library, copies that take their maps together: each "
                             "map drawn serves this many episodes of a group of as many "
                             "copies, so the defenders act on a map's copies in one call "
                             "(ReachAvoidVectorEnv's copies_per_map; default: %(default)s)")
    parser.add_argument("--supersuit", action="store_true",
                        help="train through SuperSuit's chain over the attacker-only env "
                             "(one game per copy) instead of the vector env")
    parser.add_argument("--n-steps", type=int, default=256,
                        help="PPO rollout length per slot (default: %(default)s)")
    parser.add_argument("--batch-size", type=int, default=512,
                        help="PPO minibatch (default: %(default)s)")
    parser.add_argument("--learning-rate", type=float, default=3e-4,
                        help="PPO learning rate (default: %(default)s)")
    parser.add_argument("--clip-range", type=float, default=0.2,
                        help="PPO clip range (default: %(default)s)")
    parser.add_argument("--ent-coef", type=float, default=0.0,
                        help="PPO entropy coefficient (default: %(default)s)")
    parser.add_argument("--imitate-steps", type=int, default=0,
                        help="agent steps of the --imitate-from team to clone before PPO; "
                             "0: none (default: %(default)s)")
    parser.add_argument("--imitate-from", default="shortest-path", choices=ATTACKERS,
                        help="the scripted team to clone (default: %(default)s)")
    parser.add_argument("--imitate-epochs", type=int, default=20,
                        help="passes over the cloned steps (default: %(default)s)")
    parser.add_argument("--imitate-learning-rate", type=float, default=1e-3,
                        help="Adam learning rate of the cloning (default: %(default)s)")
    parser.add_argument("--dagger-rounds", type=int, default=0,
                        help="DAgger rounds after the cloning (default: %(default)s)")
    parser.add_argument("--dagger-steps", type=int, default=50_000,
                        help="agent steps the policy plays per DAgger round "
                             "(default: %(default)s)")
    parser.add_argument("--dagger-epochs", type=int, default=None,
                        help="passes over all the labelled steps after each DAgger round "
                             "(None: --imitate-epochs)")
    parser.add_argument("--net-arch", default=None,
                        help="hidden layer sizes of the policy and value networks, "
                             "comma-separated, e.g. 256,256 (None: SB3's 64,64)")
    parser.add_argument("--imitate-log-std", type=float, default=-1.0,
                        help="log std of the actions after cloning (default: %(default)s)")
    parser.add_argument("--teammates", type=int, default=None, metavar="T",
                        help="observe the T nearest teammates (with --opponents; default: "
                             "every player): one observation size for any team size, so a "
                             "2 vs 1 policy (--teammates 1 --opponents 1) plays 6 vs 2")
    parser.add_argument("--opponents", type=int, default=None, metavar="O",
                        help="observe the O nearest opponents (with --teammates)")
    parser.add_argument("--past-selves", type=int, default=0, metavar="POOL",
                        help="self-play with past policies: one attacker per copy learns, its "
                             "teammates play snapshots of the learner (one taken after every "
                             "rollout; each episode draws one of the newest POOL); 0: every "
                             "attacker learns (default: %(default)s)")
    parser.add_argument("--full-speed", action="store_true",
                        help="the policy's actions are headings: each is scaled to length 1, "
                             "in training and in play")
    add_reward_arguments(parser, team=True)
    add_curriculum_arguments(parser)
    parser.add_argument("--episodes", type=int, default=200,
                        help="evaluation starts, seeds F..F+N-1 (default: %(default)s)")
    parser.add_argument("--first-seed", type=int, default=0, metavar="F",
                        help="the first evaluation start's seed (default: %(default)s)")
    parser.add_argument("--teams", default=None,
                        help=f"teams to evaluate, comma-separated from {', '.join(TEAMS)} "
                             f"(None: {','.join(DEFAULT_TEAMS)}, and the --imitate-from "
                             "team when it is another)")
    parser.add_argument("--seed", type=int, default=0, help="seed (default: %(default)s)")
    parser.add_argument("--out", type=Path, default=Path("runs/attacker_team"),
                        help="output folder (default: %(default)s)")
    parser.add_argument("--plot", type=Path, default=None,
                        help="training curve PNG (None: OUT/curve.png)")
    parser.add_argument("--video", type=Path, default=None,
                        help="video of a learned episode (None: OUT/learned.mp4)")
    parser.add_argument("--video-every", type=int, default=4,
                        help="record every k-th game step (default: %(default)s)")
    parser.add_argument("--video-width", type=int, default=320,
                        help="video width in pixels (default: %(default)s)")
    parser.add_argument("--no-video", action="store_true", help="skip the video")
    parser.add_argument("--force", action="store_true",
                        help="replace output files that exist (default: refuse, before any work)")
    parser.add_argument("--evaluate-on", default=None, metavar="SCENARIO|LIBRARY",
                        type=scenario_argument(library=True),
                        help="evaluate on these maps (held-out ones: a map library) instead "
                             "of --scenario's")
    parser.add_argument("--init", type=Path, default=None, metavar="MODEL",
                        help="start PPO from this saved policy (an earlier run's cloned.zip "
                             "or model.zip, with its network) instead of a fresh or cloned one")
    parser.add_argument("--evaluate-only", type=Path, default=None, metavar="MODEL",
                        help="skip training: evaluate (and record) this saved model; without "
                             "it and without 'learned' in --teams nothing is trained")
    args = parser.parse_args(argv)
    check_ranges(parser, args, RANGES)
    try:
        args.curriculum = start_curriculum(args)
    except FieldError as err:
        parser.error(f"--{err.field.replace('_', '-')}: {str(err).split(': ', 1)[1]}")
    try:
        args.observation = (DEFAULT_OBSERVATION if args.teammates is None and
                            args.opponents is None else ObservationConfig(
                                teammates=args.teammates, opponents=args.opponents))
    except ValueError as err:
        field, reason = str(err).split(": ", 1)
        parser.error(f"--{field.removeprefix('observation.')}: {reason}")
    if args.copies_per_map > 1 and args.supersuit:
        parser.error("--copies-per-map: needs the vector env (drop --supersuit)")
    if args.curriculum is not None and args.supersuit:
        parser.error("--easy-starts: needs the vector env (drop --supersuit)")
    if args.past_selves and args.supersuit:
        parser.error("--past-selves: needs the vector env (drop --supersuit)")
    attackers = load_library(args.scenario)[0].num_attackers
    if args.past_selves and attackers < 2:
        parser.error("--past-selves: needs teammates (a game of two or more attackers)")
    if args.n_steps * args.copies * (1 if args.past_selves else attackers) < 2:
        parser.error("--n-steps: a rollout of one agent step (n_steps x copies x learning "
                     "attackers) has no advantage to normalise; make it at least 2")
    if args.past_selves and args.team_reward:
        parser.error("--past-selves: one attacker per copy learns, so there is no team "
                     "reward among learners (drop --team-reward)")
    if args.dagger_epochs is None:
        args.dagger_epochs = args.imitate_epochs
    if args.teams is None:
        args.teams = DEFAULT_TEAMS + ((args.imitate_from,) if args.imitate_from
                                      not in DEFAULT_TEAMS else ())
    else:
        args.teams = tuple(args.teams.split(","))
    unknown = [team for team in args.teams if team not in TEAMS]
    if unknown:
        parser.error(f"--teams: unknown team {unknown[0]!r} (choose from {', '.join(TEAMS)})")
    if args.dagger_rounds and not args.imitate_steps:
        parser.error("--dagger-rounds: needs --imitate-steps")
    if args.net_arch is not None:
        try:
            args.net_arch = net_arch_sizes(args.net_arch, "--net-arch")
        except FieldError as err:
            parser.error(str(err))
    for name in ("init", "evaluate_only"):
        path = getattr(args, name)
        if path is not None and not path.is_file():
            parser.error(f"--{name.replace('_', '-')}: no such file {str(path)!r}")
        if path is not None:
            try:
                check_model_file(path, f"--{name.replace('_', '-')}")
            except ValueError as err:
                parser.error(str(err))
    if args.init is not None and (args.imitate_steps or args.net_arch is not None):
        parser.error("--init: the saved policy is the start (its network included); "
                     "drop --imitate-steps and --net-arch")
    args.plot = args.plot or args.out / "curve.png"
    args.video = args.video or args.out / "learned.mp4"
    try:
        check_outputs(outputs(args), args.force, writable_folder(str(args.out), "--out"))
    except UsageError as err:
        parser.error(str(err))
    return args


def net_arch_sizes(text: str, flag: str) -> list[int]:
    """``--net-arch``'s hidden layer sizes from ``256,256``; ``FieldError`` naming ``flag``
    unless they are positive integers separated by commas."""
    try:
        sizes = [int(size) for size in text.split(",")]
    except ValueError:
        sizes = []
    if not sizes or min(sizes) < 1:
        raise FieldError(f"{flag}: positive integers separated by commas, got {text!r}", flag)
    return sizes


def outputs(args: argparse.Namespace) -> list[tuple[str, Path]]:
    """The files this run writes (flag, path): checked before any work, under the
    command's one output rule (``reachavoid.paths.check_outputs``: new, or replaced with
    ``--force``)."""
    trains = args.evaluate_only is None and "learned" in args.teams
    written = [("--out", args.out / "report.json")]
    if trains:
        written += [("--out", args.out / "model.zip"), ("--out", args.out / "curve.csv"),
                    ("--plot", args.plot)]
    if trains and args.imitate_steps:
        written.append(("--out", args.out / "cloned.zip"))
    if (trains or args.evaluate_only is not None) and not args.no_video:
        written.append(("--video", args.video))
    return written


Maps = tuple[Scenario, ...]
"""The maps a run plays: one scenario, or a map library (each reset draws one)."""


def team_maps(source: str) -> Maps:
    """The maps of ``source`` (a scenario or a map library, ``maps.load_library``), each
    with its players and random starts every episode."""
    return tuple(s.with_players(s.num_attackers, s.num_defenders)
                 for s in load_library(source))


def game(args: argparse.Namespace, maps: Maps, **env_kwargs: Any) -> AttackerParallelEnv:
    """The attacker-only game of ``maps`` against ``args``' defenders, with ``args``'
    observation and the env's ``env_kwargs``."""
    return make_attackers_parallel_env(maps, defenders=args.defenders,
                                       defender_options=defender_options(args),
                                       observation=args.observation, **env_kwargs)


class ModelError(ValueError):
    """A saved model (``--init``, ``--evaluate-only``) this run cannot play; the command
    prints it in one line and exits with status 2."""


def load_model(path: Path, flag: str, maps: Maps, observation: ObservationConfig,
               **options: Any) -> PPO:
    """``PPO.load(path, **options)`` of a policy for ``observation`` of ``maps``
    (``read_sb3``: a model file is code, checked before it is read); ``ModelError`` naming
    ``flag`` if the file is not one (another game, not SB3's, weights not finite)."""
    size = observation.size(maps[0].num_attackers, maps[0].num_defenders)
    try:
        model = read_sb3(path, flag, "PPO", **options)
    except ValueError as err:   # not SB3's, damaged, weights not finite, or open to others
        raise ModelError(f"{err} (this run needs a PPO attacker of {maps[0].name}, "
                         f"{size} observation entries)") from None
    shape = model.observation_space.shape
    if shape != (size,) or model.action_space.shape != (2,):
        raise ModelError(f"{flag}: {str(path)!r} observes {shape} and acts "
                         f"{model.action_space.shape}; this run needs ({size},) and (2,)")
    return model


"""Train a team of attackers that share one Stable-Baselines3 PPO policy (parameter
sharing) against the HJ defenders, and compare it with the scripted and random teams on
the same seeded starts.

Needs the ``rl`` extra (torch, stable-baselines3, supersuit).

    python examples/train_attacker_team.py --scenario paper_2v1 --imitate-from hj \\
        --imitate-steps 40000 --imitate-epochs 40 --net-arch 256,256 --dagger-rounds 3 \\
        --dagger-steps 20000 --dagger-epochs 20 --timesteps 3000000 --max-minutes 25 \\
        --learning-rate 1e-4 --clip-range 0.1 --out runs/team_2v1
    python examples/train_attacker_team.py --scenario paper_2v1 --imitate-from hj \\
        --evaluate-only runs/team_2v1/model.zip

The game is ``--scenario`` (default ``paper_6v2``) with random starts every episode; a map
library (a folder of ``reachavoid maps``, its ``index.toml``) draws one of its maps per
episode, and ``--evaluate-on LIBRARY`` evaluates on other maps (held-out ones) than those
trained on. Each attacker sees the env's default observation (``reachavoid_env.observations``,
v1: egocentric, with the target, lidar rays to the walls and the other players relative
to it), so a policy can carry over to maps it was not trained on; with ``--teammates T
--opponents O`` it sees the T nearest teammates and O nearest defenders instead of every
player, one observation size for any team sizes, so it can carry over to another game
(a 2 vs 1 team trained with ``--teammates 1 --opponents 1`` plays 6 vs 2). Training runs
on the vector env (``policies.training.make_attackers_vector_env``, ``--copies`` games
stepped together, the defenders acting on every copy in one call; over a map library with
``--copies-per-map G`` the copies take their maps G at a time, so each map's defenders act
on its copies in one call; ``--supersuit``: the
attacker-only env through SuperSuit's chain, ``reachavoid_env.integrations.supersuit``):
one vector slot per attacker and game copy, all slots one policy: 16 copies by default
(the measured runs of ``BENCHMARKS.md``); fewer leave the vector env little to batch.
As in ``train_attacker_sb3.py`` (the one-attacker recipe), one agent step holds the
action for ``--action-repeat 10`` game steps (0.05 s), the reward has the potential-based
progress term (``--shaping 1``) and still being in play at the time limit scores
``--timeout-reward -1`` like a capture. The defenders'
HJ tubes are solved once at ``--grid1``/``--grid2`` nodes per axis (coarse by default:
31/15) and cached on disk.

**Behaviour-cloning warm start** (``--imitate-steps N``, default 0: PPO from scratch): before
PPO, the scripted team ``--imitate-from`` (default ``shortest-path``; ``hj``: the 1 vs 1
HJ-optimal control against the most dangerous defender, on the defenders' ``--grid1``
tube; ``hj-pairs``: the attackers that lose alone play the 2 vs 1 game in pairs, on the
defenders' ``--grid1``/``--grid2`` tubes) plays the training env (same observations,
same ``--action-repeat`` hold, the same shaped reward) until N agent steps are recorded,
one per live attacker and env step, starting from seed ``--seed`` + 1,000,000 (far from the
evaluation seeds); the script is asked at each decision step, as the learner is. The PPO
policy's action mean is then fitted to the script's actions and its value head to the
discounted (``gamma`` of PPO) shaped returns, by mean-squared error, for
``--imitate-epochs`` passes of Adam (``--imitate-learning-rate``); the log standard
deviation of the actions is then set to ``--imitate-log-std`` (-1: std 0.37, against SB3's
initial 1, so that PPO's exploration does not drown the cloned paths). ``--timesteps 0``
skips PPO and evaluates the cloned policy alone.

**DAgger** (``--dagger-rounds K``, default 0): after that cloning, K rounds in which the
cloned policy (its deterministic action mean, held ``--action-repeat`` game steps as in
training) plays ``--dagger-steps`` agent steps of the training env (round k from seed
``--seed`` + 1,000,000 + k) while the teacher is asked for its action in every state the
policy visits; those rows (the teacher's action as label, the discounted shaped return of
the game the policy played as value target) join the demonstrations, and the policy is
fitted again on all of them for ``--dagger-epochs`` (default ``--imitate-epochs``) passes.
Each round reports the steps collected, the policy's arrival rate in them, its action MSE
against the teacher's labels there before the refit and the fit's MSE after.
**Full-speed actions** (``--full-speed``): the policy's actions are headings, each scaled
to length 1 before the game sees it, in PPO's rollouts (``FullSpeed``), in the DAgger
rollouts and in play (``ObservationPolicy(full_speed=True)``, stored with the model, so
``load_sb3`` and ``sb3:PATH`` play it so). Where the teacher switches between headings (the
``hj-pairs`` attackers between running alone and splitting as a pair), the fitted mean
averages them into a shorter vector, and a short action is a slow attacker.
**Curriculum from easy starts** (``--easy-starts D``, vector env only): PPO's first
episodes start every attacker within D map units of the target, and the reach grows
linearly to the map's diagonal over the first ``--easy-fraction`` (default 0.5) of the
training (of ``--timesteps``, or of ``--max-minutes`` when that share is larger); then
anywhere (``policies.training.StartCurriculum``, set before every rollout).
**Self-play with past policies** (``--past-selves POOL``, vector env only): one attacker
per copy learns and its teammates play frozen snapshots of the learner
(``policies.self_play.PastSelves``): the policy PPO starts from, then one taken after every
rollout; each episode draws one of the newest POOL for all the teammates of its copy
(deterministic actions, held ``--action-repeat`` steps, headings with ``--full-speed``).
An agent step is then one game decision of the learner, not one per attacker.
``--init MODEL`` starts PPO from a saved policy instead (an earlier run's ``cloned.zip``,
say, to compare fine-tuning settings from one clone; its network is kept).
``--net-arch 256,256`` sets the hidden layers of the policy and value networks (SB3's
64,64 by default). For the fine-tuning, ``--learning-rate``,
``--clip-range`` and ``--ent-coef`` are PPO's (defaults: SB3's 3e-4, 0.2, 0).

**Evaluation** (``evaluate``; alone with ``--evaluate-only MODEL``): every team plays the
``--episodes`` starts ``reset(seed=k)``, k = F, F + 1, ... (F: ``--first-seed``, default 0;
a later F gives fresh starts to confirm a result), of the attacker-only env against
the same defenders, without shaping; each team decides at its own rate (the learned one
every ``--action-repeat`` game steps, its actions scaled with ``--full-speed``, seeing the
players ``--teammates`` / ``--opponents`` name: give ``--evaluate-only`` the flags the
model was trained with; the scripted ``shortest-path`` and
``random`` teams of ``policies.registry``, and the ``--imitate-from`` team, every game
step; ``--teams`` takes any of ``policies.registry.ATTACKERS``). Per team: the arrival rate
(the mean over episodes of the fraction of attackers that arrive) and the mean number
captured, each with a 95% bootstrap interval over episodes (the episodes are the
independent units; the attackers of one episode are not), and the paired differences over
the same starts learned - shortest-path, and with another teacher learned - teacher and
teacher - shortest-path. ``--teams shortest-path,random`` without
``--evaluate-only`` evaluates the scripted teams only, with nothing trained.

Writes into ``--out``: ``model.zip``, ``cloned.zip`` (the policy after the cloning and the DAgger
rounds, before PPO; with ``--imitate-steps``), ``curve.csv`` (one row per PPO rollout: agent
steps, wall seconds, attacker episodes ended, their arrival/capture/time-out rates and
mean return), ``report.json`` (settings, throughput, evaluation, and the wall and CPU
seconds (this process's, ``time.process_time``) of the cloning, PPO, the evaluation and
the whole run); ``--plot`` (default
``OUT/curve.png``) and ``--video`` (default ``OUT/learned.mp4``, the learned team on the
first evaluation start). Ctrl-C stops cleanly and leaves no half-written file.
"""

from __future__ import annotations

import argparse
import copy
import functools
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import torch
from matplotlib.figure import Figure
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.vec_env import VecEnvWrapper, VecMonitor
from tqdm import tqdm

from policies.learned import (
    DEFAULT_OBSERVATION,
    TRAINING_ATTRIBUTE,
    ObservationPolicy,
    Predict,
    check_model_file,
    read_sb3,
    training_record,
)
from policies.registry import ATTACKERS, PolicySpec
from policies.self_play import MAX_POOL, PastSelves
from policies.training import (
    Bounds,
    StartCurriculum,
    add_curriculum_arguments,
    add_defender_arguments,
    add_reward_arguments,
    check_ranges,
    defender_factory,
    defender_options,
    make_attacker_vector_env,
    make_attackers_parallel_env,
    make_attackers_vector_env,
    reward_options,
    scenario_argument,
    start_curriculum,
)
from reachavoid.evaluation import bootstrap_interval, write_csv
from reachavoid.paths import UsageError, check_outputs, writable_folder
from reachavoid_env import AttackerStatus, Policy, Scenario
from reachavoid_env.checks import FieldError
from reachavoid_env.files import atomic_write, forget_expected, write_json
from reachavoid_env.integrations.supersuit import sb3_vec_env as supersuit_vec_env
from reachavoid_env.integrations.vector import sb3_vec_env
from reachavoid_env.maps import load_library
from reachavoid_env.observations import ObservationConfig
from reachavoid_env.rules import unit_vectors
from reachavoid_env.vector import MAX_COPIES
from reachavoid_env.video import RecordEpisode
from reachavoid_env.wrappers import AttackerParallelEnv, PerMapPolicy

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
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
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
            args.net_arch = [int(size) for size in args.net_arch.split(",")]
        except ValueError:
            args.net_arch = []
        if not args.net_arch or min(args.net_arch) < 1:
            parser.error("--net-arch: positive integers separated by commas")
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


class EasyStarts(BaseCallback):
    """Sets the training envs' ``start_reach`` from ``curriculum`` before every rollout;
    the progress is the larger of the agent steps done over ``total_steps`` and the wall
    time over ``max_seconds``. ``reach``: the current one (map units; ``None``: anywhere)."""

    def __init__(self, curriculum: StartCurriculum, diagonal: float, total_steps: int,
                 max_seconds: float | None) -> None:
        super().__init__()
        self.curriculum, self.diagonal = curriculum, diagonal
        self.total_steps, self.max_seconds = total_steps, max_seconds
        self.reach: float | None = None

    def _on_training_start(self) -> None:
        self.start = time.perf_counter()
        self._on_rollout_start()

    def _on_rollout_start(self) -> None:
        progress = self.num_timesteps / self.total_steps
        if self.max_seconds is not None:
            progress = max(progress, (time.perf_counter() - self.start) / self.max_seconds)
        self.reach = self.curriculum.reach(progress, self.diagonal)
        self.training_env.set_attr("start_reach", self.reach)

    def _on_step(self) -> bool:
        return True


# ---- the training curve -------------------------------------------------------------------

class TrainingCurve(BaseCallback):
    """One row per PPO rollout: agent steps so far, wall seconds, and over the attacker
    episodes (slots) that ended in the rollout, how they ended and their mean return.
    Prints the latest row every ``print_seconds``; stops training after ``max_seconds`` of
    wall time. With ``easy_starts`` (the curriculum's callback) each row also has the
    rollout's ``start_reach`` (map units; empty: anywhere)."""

    def __init__(self, max_seconds: float | None = None, print_seconds: float = 30.0,
                 easy_starts: EasyStarts | None = None) -> None:
        super().__init__()
        self.max_seconds = max_seconds
        self.easy_starts = easy_starts
        self.print_seconds = print_seconds
        self._printed = 0.0
        self.rows: list[dict[str, float | None]] = []
        self.start: float | None = None
        self.cpu_seconds = 0.0      # this process's CPU seconds in training, set at its end
        self._cpu_start = 0.0

    def _on_training_start(self) -> None:
        self.start = time.perf_counter()
        self._cpu_start = time.process_time()
        self.status = np.zeros(self.training_env.num_envs, dtype=np.int64)
        self._ended: list[int] = []
        self._returns: list[float] = []

    def _on_training_end(self) -> None:
        self.cpu_seconds = time.process_time() - self._cpu_start

    def _on_step(self) -> bool:
        steps = zip(self.locals["infos"], self.locals["dones"], self.locals["rewards"],
                    strict=True)
        for slot, (info, done, reward) in enumerate(steps):
            if done:
                self._ended.append(self._final_status(slot, info, reward))
                self._returns.append(float(info["episode"]["r"]))
                self.status[slot] = AttackerStatus.ACTIVE.code
            elif "status" in info:          # an attacker's last step carries its status
                self.status[slot] = info["status"]
        return self.max_seconds is None or self.seconds < self.max_seconds

    def _final_status(self, slot: int, info: dict[str, Any], reward: float) -> int:
        """How the attacker of ``slot`` ended, on the step that ends its game. SuperSuit's
        vector env overwrites that step's infos with the next episode's reset infos, but
        keeps ``TimeLimit.truncated`` for the attackers still in play: for them a time-out
        is read from it, an arrival or a capture from the sign of the step's reward (+1 or
        -1; the progress term of one step is far smaller)."""
        if self.status[slot] != AttackerStatus.ACTIVE.code or "TimeLimit.truncated" not in info:
            return int(self.status[slot])
        if info["TimeLimit.truncated"]:
            return AttackerStatus.ACTIVE.code
        return (AttackerStatus.ARRIVED if reward > 0 else AttackerStatus.CAPTURED).code

    @property
    def seconds(self) -> float:
        """Wall seconds since training started (0 before)."""
        return 0.0 if self.start is None else time.perf_counter() - self.start

    def _on_rollout_end(self) -> None:
        ended = np.asarray(self._ended)
        rates = {f"{status.value if status is not AttackerStatus.ACTIVE else 'timeout'}_rate":
                 float(np.mean(ended == status.code)) if len(ended) else float("nan")
                 for status in (AttackerStatus.ARRIVED, AttackerStatus.CAPTURED,
                                AttackerStatus.ACTIVE)}
        self.rows.append({"timesteps": self.num_timesteps, "seconds": round(self.seconds, 2),
                          "attacker_episodes": len(ended), **rates,
                          "mean_return": float(np.mean(self._returns)) if self._returns
                          else float("nan")})
        if self.easy_starts is not None:
            self.rows[-1]["start_reach"] = self.easy_starts.reach
        self._ended, self._returns = [], []
        if self.seconds - self._printed >= self.print_seconds:
            self._printed = self.seconds
            print(row_text(self.rows[-1]), flush=True)


def row_text(row: dict[str, float | None]) -> str:
    """A curve row as the line the recipe prints (a ``None`` reach reads "anywhere")."""
    return "PPO: " + ", ".join(f"{key} {'anywhere' if value is None else f'{value:.4g}'}"
                               for key, value in row.items())


# ---- behaviour cloning ------------------------------------------------------------------

IMITATION_SEED_OFFSET = 1_000_000
"""The cloned games start from seed ``--seed`` + this (the evaluation uses 0, 1, ...)."""


@dataclass(frozen=True)
class Demonstrations:
    """The scripted team in the training env: one row per live attacker and env step."""

    observations: np.ndarray    # (K, observation size) float32, what the learner would see
    actions: np.ndarray         # (K, 2) float32, the script's action, held for the env step
    returns: np.ndarray         # (K,) float32, discounted shaped return from that step
    episodes: int
    arrival_rate: float         # fraction of the attackers of those episodes that arrived

    def __add__(self, other: Demonstrations) -> Demonstrations:
        """Both sets' rows (the aggregate DAgger fits); the arrival rate over both."""
        episodes = self.episodes + other.episodes
        return Demonstrations(
            *(np.concatenate([getattr(self, key), getattr(other, key)])
              for key in ("observations", "actions", "returns")), episodes,
            (self.arrival_rate * self.episodes + other.arrival_rate * other.episodes)
            / episodes)


def discounted(rewards: Sequence[float], gamma: float) -> list[float]:
    """Returns-to-go ``G_t = r_t + gamma G_{t+1}`` of one attacker's rewards."""
    returns, total = [], 0.0
    for reward in reversed(rewards):
        total = reward + gamma * total
        returns.append(total)
    return returns[::-1]


def collect_demonstrations(args: argparse.Namespace, maps: Maps, gamma: float,
                           player: Team | None = None, steps: int | None = None,
                           seed: int | None = None, desc: str = "cloning") -> Demonstrations:
    """``steps`` (default ``args.imitate_steps``) rows of ``player`` (default: the
    ``--imitate-from`` team itself) playing whole episodes of the training env, from
    ``reset(seed=seed)`` (default ``--seed`` + ``IMITATION_SEED_OFFSET``) and then the env's
    random stream; the last episode is finished and its rows cut at the count. Each row is
    labelled with the ``--imitate-from`` team's action in that state, whoever plays, and
    with the discounted return of the rewards that followed it in the game played."""
    steps = args.imitate_steps if steps is None else steps
    env = game(args, maps, **reward_options(args))
    teacher = scripted_team(args.imitate_from, args, maps)
    observations: list[np.ndarray] = []
    actions: list[np.ndarray] = []
    returns: list[float] = []
    arrived = episodes = 0
    progress = tqdm(total=steps, desc=desc, unit="step", disable=not sys.stderr.isatty())
    next_seed: int | None = args.seed + IMITATION_SEED_OFFSET if seed is None else seed
    while len(actions) < steps:
        seen, _ = env.reset(seed=next_seed)
        next_seed = None        # later episodes continue the env's random stream
        teacher.reset(env)
        if player is not None:
            player.reset(env)
        played: dict[str, list[tuple[np.ndarray, np.ndarray, float]]] = {
            name: [] for name in env.agents}
        while env.agents:
            labels = teacher.act(seen, env)
            after, rewards, *_ = env.step(labels if player is None else player.act(seen, env))
            for name, label in labels.items():
                played[name].append((seen[name], label, rewards[name]))
            progress.update(len(labels))
            seen = after
        for steps_of_one in played.values():
            seen_by_step, chosen_by_step, rewards_by_step = zip(*steps_of_one, strict=True)
            observations.extend(seen_by_step)
            actions.extend(chosen_by_step)
            returns.extend(discounted(rewards_by_step, gamma))
        arrived += env.game_state().attacker_status.count(AttackerStatus.ARRIVED)
        episodes += 1
    progress.close()
    env.close()
    return Demonstrations(np.asarray(observations[:steps], dtype=np.float32),
                          np.asarray(actions[:steps], dtype=np.float32),
                          np.asarray(returns, dtype=np.float32)[:steps], episodes,
                          arrived / (episodes * maps[0].num_attackers))


def imitate(model: PPO, demonstrations: Demonstrations, epochs: int, batch_size: int,
            learning_rate: float, log_std: float) -> dict[str, float]:
    """Fit ``model``'s action mean to the script's actions and its value to the returns
    (mean-squared error, Adam, minibatches of ``batch_size``), then set the log std of its
    actions to ``log_std``. Returns the last epoch's mean losses."""
    policy = model.policy
    observations = torch.as_tensor(demonstrations.observations)
    actions = torch.as_tensor(demonstrations.actions)
    returns = torch.as_tensor(demonstrations.returns)
    optimiser = torch.optim.Adam(policy.parameters(), lr=learning_rate)
    generator = torch.Generator().manual_seed(model.seed or 0)
    policy.set_training_mode(True)
    for _ in range(epochs):
        action_losses, value_losses = [], []
        for rows in torch.randperm(len(actions), generator=generator).split(batch_size):
            means = policy.get_distribution(observations[rows]).distribution.mean
            values = policy.predict_values(observations[rows]).squeeze(-1)
            action_loss = torch.nn.functional.mse_loss(means, actions[rows])
            value_loss = torch.nn.functional.mse_loss(values, returns[rows])
            optimiser.zero_grad()
            (action_loss + value_loss).backward()
            optimiser.step()
            action_losses.append(action_loss.item())
            value_losses.append(value_loss.item())
    policy.set_training_mode(False)
    with torch.no_grad():
        policy.log_std.fill_(log_std)
    return {"action_mse": float(np.mean(action_losses)),
            "value_mse": float(np.mean(value_losses))}


def action_error(model: PPO, demonstrations: Demonstrations) -> float:
    """Mean-squared error of ``model``'s action mean against the recorded actions."""
    with torch.no_grad():
        means = model.policy.get_distribution(
            torch.as_tensor(demonstrations.observations)).distribution.mean
        return float(torch.nn.functional.mse_loss(
            means, torch.as_tensor(demonstrations.actions)))


def clone(args: argparse.Namespace, maps: Maps, model: PPO) -> dict[str, Any]:
    """Fit ``model`` to ``--imitate-steps`` of the ``--imitate-from`` team, then run
    ``--dagger-rounds`` of DAgger: the fitted policy (deterministic, as ``learned_team``)
    plays ``--dagger-steps`` in the training env, the teacher labels every state it
    visits, and the policy is fitted again (``--dagger-epochs``) on all the labelled rows
    so far. Returns what was done, per round."""
    start, cpu_start = time.perf_counter(), time.process_time()
    demonstrations = collect_demonstrations(args, maps, model.gamma)
    collected = time.perf_counter()
    losses = imitate(model, demonstrations, args.imitate_epochs, args.batch_size,
                     args.imitate_learning_rate, args.imitate_log_std)
    cloning: dict[str, Any] = {
        "teacher": args.imitate_from, "agent_steps": len(demonstrations.actions),
        "episodes": demonstrations.episodes,
        "scripted_arrival_rate": round(demonstrations.arrival_rate, 4),
        "epochs": args.imitate_epochs, "learning_rate": args.imitate_learning_rate,
        "log_std": args.imitate_log_std, **losses,
        "collect_seconds": round(collected - start, 1),
        "fit_seconds": round(time.perf_counter() - collected, 1)}
    print("cloning: " + ", ".join(f"{k} {v}" for k, v in cloning.items()), flush=True)
    rounds = []
    for number in range(1, args.dagger_rounds + 1):
        start = time.perf_counter()
        visited = collect_demonstrations(
            args, maps, model.gamma,
            player=learned_team(model, 1, args.full_speed, args.observation),
            steps=args.dagger_steps, seed=args.seed + IMITATION_SEED_OFFSET + number,
            desc=f"DAgger {number}")
        collected = time.perf_counter()
        demonstrations = demonstrations + visited
        learner_error = action_error(model, visited)
        losses = imitate(model, demonstrations, args.dagger_epochs, args.batch_size,
                         args.imitate_learning_rate, args.imitate_log_std)
        rounds.append({"round": number, "agent_steps": len(visited.actions),
                       "episodes": visited.episodes,
                       "learner_arrival_rate": round(visited.arrival_rate, 4),
                       "learner_action_mse": round(learner_error, 5),
                       "aggregate_steps": len(demonstrations.actions), **losses,
                       "collect_seconds": round(collected - start, 1),
                       "fit_seconds": round(time.perf_counter() - collected, 1)})
        print("DAgger: " + ", ".join(f"{k} {v}" for k, v in rounds[-1].items()), flush=True)
    if rounds:
        cloning["dagger"] = {"epochs": args.dagger_epochs, "rounds": rounds}
    cloning["cpu_seconds"] = round(time.process_time() - cpu_start, 1)
    return cloning


# ---- training ---------------------------------------------------------------------------

def training_envs(args: argparse.Namespace, maps: Maps,
                  past_selves: PastSelves | None = None) -> Any:
    """The SB3 ``VecEnv`` of ``--copies`` games: the vector env (one slot per attacker and
    copy, the defenders acting on every copy in one call; with ``past_selves``, one slot
    per copy, its teammates played by them), or SuperSuit's chain over the attacker-only
    env with ``--supersuit``."""
    if args.supersuit:
        envs = supersuit_vec_env(game(args, maps, **reward_options(args)), copies=args.copies)
    elif past_selves is not None:
        envs = VecMonitor(sb3_vec_env(make_attacker_vector_env(
            maps, defenders=args.defenders, teammates=past_selves, num_envs=args.copies,
            copies_per_map=args.copies_per_map, defender_options=defender_options(args),
            observation=args.observation,
            **{k: v for k, v in reward_options(args).items() if k != "team_reward"})))
    else:
        envs = VecMonitor(sb3_vec_env(make_attackers_vector_env(
            maps, defenders=args.defenders, num_envs=args.copies,
            copies_per_map=args.copies_per_map, defender_options=defender_options(args),
            observation=args.observation, **reward_options(args))))
    return FullSpeed(envs) if args.full_speed else envs


class FullSpeed(VecEnvWrapper):
    """``--full-speed``: every action is scaled to length 1 before the games see it."""

    def step_async(self, actions: np.ndarray) -> None:
        self.venv.step_async(unit_vectors(np.asarray(actions, dtype=np.float64)))

    def step_wait(self) -> Any:
        return self.venv.step_wait()

    def reset(self) -> Any:
        return self.venv.reset()


def train(args: argparse.Namespace, maps: Maps,
          ) -> tuple[PPO, TrainingCurve, dict[str, Any] | None]:
    """PPO on the training env, from the cloned script with ``--imitate-steps``; returns the
    model, its curve and what the cloning did (None without it)."""
    past_selves = None if not args.past_selves else PastSelves(
        args.observation, args.past_selves, args.action_repeat, args.full_speed, args.seed)
    envs = training_envs(args, maps, past_selves)
    settings = {"n_steps": args.n_steps, "batch_size": args.batch_size,
                "learning_rate": args.learning_rate, "clip_range": args.clip_range,
                "ent_coef": args.ent_coef, "seed": args.seed}
    max_seconds = None if args.max_minutes is None else 60.0 * args.max_minutes
    easy_starts = None if args.curriculum is None else EasyStarts(
        args.curriculum, max(math.hypot(*s.map.size) for s in maps), args.timesteps,
        max_seconds)
    curve = TrainingCurve(max_seconds, easy_starts=easy_starts)
    cloning: dict[str, Any] | None = None
    try:
        if args.init is not None:
            model = load_model(args.init, "--init", maps, args.observation, env=envs,
                               custom_objects=settings)
        else:
            model = PPO("MlpPolicy", envs, device="cpu", verbose=0, **settings, policy_kwargs=None
                        if args.net_arch is None else {"net_arch": args.net_arch})
        if args.imitate_steps:
            cloning = clone(args, maps, model)
            with atomic_write(args.out / "cloned.zip", "wb") as handle:
                model.save(handle)
        snapshots = None
        if past_selves is not None:
            snapshots = PastSelfSnapshots(past_selves)
            past_selves.add(frozen(model))
        if args.timesteps:
            model.learn(args.timesteps, callback=CallbackList(
                [c for c in (easy_starts, curve, snapshots) if c is not None]),
                progress_bar=sys.stderr.isatty())
    finally:
        envs.close()
    return model, curve, cloning


def frozen(model: PPO) -> Predict:
    """A snapshot of ``model``'s policy now: its deterministic action of observations."""
    policy = copy.deepcopy(model.policy)
    policy.set_training_mode(False)
    return lambda batch: policy.predict(batch, deterministic=True)[0]


class PastSelfSnapshots(BaseCallback):
    """``--past-selves``: a snapshot of the learner into the pool after every rollout."""

    def __init__(self, past_selves: PastSelves) -> None:
        super().__init__()
        self.past_selves = past_selves

    def _on_rollout_end(self) -> None:
        self.past_selves.add(frozen(self.model))

    def _on_step(self) -> bool:
        return True


def plot_curve(rows: list[dict[str, float]], path: Path, title: str) -> None:
    """Arrival rate and mean return per rollout (dots) and over the last 10 (line)."""
    steps = np.array([row["timesteps"] for row in rows], dtype=np.float64)
    figure = Figure(figsize=(7, 5), layout="constrained")
    arrival_axes, return_axes = figure.subplots(2, 1, sharex=True)
    for axes, key, label in ((arrival_axes, "arrived_rate", "arrival rate"),
                             (return_axes, "mean_return", "mean return")):
        values = np.array([row[key] for row in rows], dtype=np.float64)
        window = min(10, len(values))
        smooth = np.convolve(np.nan_to_num(values), np.ones(window) / window, mode="valid")
        axes.plot(steps, values, ".", alpha=0.3, label="per rollout")
        axes.plot(steps[window - 1:], smooth, label=f"mean of {window}")
        axes.set_ylabel(label)
        axes.grid(alpha=0.3)
    arrival_axes.legend()
    arrival_axes.set_title(title)
    return_axes.set_xlabel("agent steps (one per attacker per env step)")
    with atomic_write(path, "wb") as handle:
        figure.savefig(handle, format="png", dpi=100)


# ---- evaluation -------------------------------------------------------------------------

class Team(Protocol):
    """Moves the live attackers of an ``AttackerParallelEnv``, one game step at a time."""

    def reset(self, env: AttackerParallelEnv) -> None: ...

    def act(self, observations: dict[str, np.ndarray],
            env: AttackerParallelEnv) -> dict[str, np.ndarray]: ...


class ScriptedTeam:
    """A scripted attacker policy (``reachavoid_env.Policy``), asked every game step."""

    def __init__(self, policy: Policy) -> None:
        self.policy = policy

    def reset(self, env: AttackerParallelEnv) -> None:
        self.policy.reset(env.game.scenario)

    def act(self, observations: dict[str, np.ndarray],
            env: AttackerParallelEnv) -> dict[str, np.ndarray]:
        chosen = self.policy.act(env.game_state())
        return {name: chosen[name] for name in env.agents}


def learned_team(model: PPO, hold: int, full_speed: bool,
                 observation: ObservationConfig) -> ScriptedTeam:
    """The shared policy as a ``reachavoid_env.Policy`` (``policies.learned``): every live
    attacker decides every ``hold`` game steps from its own ``observation``, and holds its
    action in between (``action_repeat`` in training); with ``full_speed`` (as trained)
    its actions are headings."""
    return ScriptedTeam(ObservationPolicy(
        lambda batch: model.predict(batch, deterministic=True)[0], action_repeat=hold,
        full_speed=full_speed, observation=observation))


def play(env: AttackerParallelEnv, team: Team, seed: int) -> tuple[int, int]:
    """One episode from ``reset(seed=seed)``; returns (attackers arrived, captured)."""
    observations, _ = env.reset(seed=seed)
    team.reset(env)
    while env.agents:
        observations, *_ = env.step(team.act(observations, env))
    status = env.game_state().attacker_status
    return status.count(AttackerStatus.ARRIVED), status.count(AttackerStatus.CAPTURED)


@dataclass(frozen=True)
class TeamResult:
    """A team over the evaluation starts: per-episode counts and their summaries."""

    team: str
    arrived: tuple[int, ...]
    captured: tuple[int, ...]
    attackers: int

    @property
    def arrival_fractions(self) -> np.ndarray:
        return np.asarray(self.arrived, dtype=np.float64) / self.attackers

    def summary(self) -> dict[str, Any]:
        return {"episodes": len(self.arrived),
                "arrival_rate": float(self.arrival_fractions.mean()),
                "arrival_rate_ci95": bootstrap_interval(self.arrival_fractions),
                "mean_captured": float(np.mean(self.captured)),
                "mean_captured_ci95": bootstrap_interval(np.asarray(self.captured, float)),
                "mean_arrived": float(np.mean(self.arrived))}


def scripted_team(name: str, args: argparse.Namespace, maps: Maps) -> ScriptedTeam:
    """The scripted attackers ``name`` (``policies.registry.ATTACKERS``): ``random`` seeded
    with ``--seed``, ``hj`` and ``hj-pairs`` on the defenders' tubes (``--grid1``,
    ``--grid2``)."""
    choice = PolicySpec("attackers", name).choice
    grids = {flag: getattr(args, flag) for flag in ("grid1", "grid2") if choice.takes(flag)}
    spec = PolicySpec.of("attackers", name, **grids)
    return ScriptedTeam(PerMapPolicy(functools.partial(spec, seed=args.seed, progress=False),
                                     "attackers", first=maps[0]))


def make_team(name: str, model: PPO | None, args: argparse.Namespace,
              maps: Maps) -> Team:
    if name == "learned":
        return learned_team(model, args.action_repeat, args.full_speed, args.observation)
    return scripted_team(name, args, maps)


def evaluate(args: argparse.Namespace, maps: Maps, model: PPO | None,
             teams: Sequence[str]) -> dict[str, TeamResult]:
    """Every team in ``teams`` on the starts ``reset(seed=k)``, ``args.first_seed`` <= k <
    ``args.first_seed + args.episodes``, of one attacker-only env (no shaping; the defenders
    of ``args``)."""
    env = game(args, maps)
    results = {}
    for name in teams:
        team = make_team(name, model, args, maps)
        seeds = range(args.first_seed, args.first_seed + args.episodes)
        outcomes = [play(env, team, seed) for seed in tqdm(
            seeds, desc=name, unit="episode", disable=not sys.stderr.isatty())]
        results[name] = TeamResult(name, *map(tuple, zip(*outcomes, strict=True)),
                                   attackers=maps[0].num_attackers)
    env.close()
    return results


def paired_difference(first: TeamResult, second: TeamResult) -> dict[str, Any]:
    """Arrival rate of ``first`` minus ``second`` over the same starts, 95% bootstrap."""
    difference = first.arrival_fractions - second.arrival_fractions
    return {"teams": [first.team, second.team], "arrival_rate": float(difference.mean()),
            "arrival_rate_ci95": bootstrap_interval(difference)}


def record(args: argparse.Namespace, maps: Maps, model: PPO, seed: int) -> int:
    """The learned team on start ``seed`` to ``args.video`` in real time; returns frames."""
    env = game(args, maps, render_mode="rgb_array", render_width=args.video_width)
    fps = 1.0 / (maps[0].dt * args.video_every)
    with RecordEpisode(env, args.video, fps=fps, every=args.video_every) as recorded:
        play(recorded, learned_team(model, args.action_repeat, args.full_speed,
                                    args.observation), seed)
    return recorded.frames


# ---- the recipe -------------------------------------------------------------------------

def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    args = parse_args(argv)
    try:
        return run(args)
    finally:
        forget_expected()


def run(args: argparse.Namespace) -> dict[str, Any]:
    """The recipe of ``args`` (checked by ``parse_args``): train, evaluate, record, write."""
    start, cpu_start = time.perf_counter(), time.process_time()
    args.out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(1)    # small networks: more threads only contend for the cores
    maps = team_maps(args.scenario)
    held_out = maps if args.evaluate_on is None else team_maps(args.evaluate_on)
    if args.defenders == "hj":
        print(f"loading (or solving and caching) the HJ tubes at grids {args.grid1}/"
              f"{args.grid2} of {len(set(maps + held_out))} map(s) ...", flush=True)
        for scenario in dict.fromkeys(maps + held_out):
            defender_factory("hj", **defender_options(args))(scenario)
    report: dict[str, Any] = {
        "scenario": args.scenario, "maps": [s.name for s in maps],
        "evaluated_on": [s.name for s in held_out], "attackers": maps[0].num_attackers,
        "defenders": args.defenders,
        "grids": [args.grid1, args.grid2] if args.defenders == "hj" else None,
        **reward_options(args), "full_speed": args.full_speed, "seed": args.seed,
        "teammates": args.teammates, "opponents": args.opponents,
    }
    model: PPO | None = None
    if args.evaluate_only is not None:
        model = load_model(args.evaluate_only, "--evaluate-only", maps, args.observation)
        report["model"] = str(args.evaluate_only)
    elif "learned" in args.teams:
        model, curve, cloning = train(args, maps)
        setattr(model, TRAINING_ATTRIBUTE, training_record(
            args.observation, action_repeat=args.action_repeat, full_speed=args.full_speed,
            scenario=args.scenario))
        with atomic_write(args.out / "model.zip", "wb") as handle:
            model.save(handle)
        learners = 1 if args.past_selves else maps[0].num_attackers
        game_steps = model.num_timesteps // learners * args.action_repeat
        seconds = curve.seconds
        report["training"] = {
            "agent_steps": model.num_timesteps, "game_steps": game_steps,
            "seconds": round(seconds, 1), "cpu_seconds": round(curve.cpu_seconds, 1),
            "agent_steps_per_s": round(model.num_timesteps / seconds, 1) if seconds else None,
            "game_steps_per_s": round(game_steps / seconds, 1) if seconds else None,
            "copies": args.copies, "copies_per_map": args.copies_per_map,
            "n_steps": args.n_steps, "batch_size": args.batch_size,
            "learning_rate": args.learning_rate, "clip_range": args.clip_range,
            "ent_coef": args.ent_coef, "net_arch": model.policy_kwargs.get("net_arch"),
            "init": None if args.init is None else str(args.init),
            "easy_starts": args.easy_starts, "easy_fraction": args.easy_fraction,
            "past_selves": args.past_selves,
            "stopped_by_time": model.num_timesteps < args.timesteps}
        if cloning is not None:
            report["imitation"] = cloning
        print("training: " + ", ".join(f"{k} {v}" for k, v in report["training"].items()),
              flush=True)
        if curve.rows:
            write_csv(args.out / "curve.csv", curve.rows)
            plot_curve(curve.rows, args.plot, f"{args.scenario}, shared PPO attackers vs "
                       f"{args.defenders}" + (f" {args.grid1}/{args.grid2}"
                                              if args.defenders == "hj" else ""))
            report["curve"] = {"csv": str(args.out / "curve.csv"), "plot": str(args.plot)}
    evaluation_start, evaluation_cpu = time.perf_counter(), time.process_time()
    results = evaluate(args, held_out, model, args.teams)
    evaluation_seconds = (time.perf_counter() - evaluation_start,
                          time.process_time() - evaluation_cpu)
    report["evaluation"] = {"seeds": [args.first_seed, args.first_seed + args.episodes - 1],
                            **{name: result.summary() for name, result in results.items()}}
    for first, second in (("learned", "shortest-path"), ("learned", args.imitate_from),
                          (args.imitate_from, "shortest-path")):
        if first != second and {first, second} <= results.keys():
            key = f"{first}_minus_{second}".replace("-", "_")
            report["evaluation"][key] = paired_difference(results[first], results[second])
    for name, result in results.items():
        summary = result.summary()
        low, high = summary["arrival_rate_ci95"]
        print(f"{name:>13}: arrival {summary['arrival_rate']:.3f} [{low:.3f}, {high:.3f}], "
              f"mean captured {summary['mean_captured']:.2f}", flush=True)
    for key, difference in report["evaluation"].items():
        if "_minus_" in key:
            low, high = difference["arrival_rate_ci95"]
            print(f"{key}: arrival {difference['arrival_rate']:+.4f} [{low:+.4f}, "
                  f"{high:+.4f}]", flush=True)
    if model is not None and not args.no_video:
        report["video"] = {"path": str(args.video), "seed": args.first_seed,
                           "frames": record(args, held_out, model, seed=args.first_seed)}
    report["per_episode"] = {name: asdict(result) for name, result in results.items()}
    report["run"] = {"seconds": round(time.perf_counter() - start, 1),
                     "cpu_seconds": round(time.process_time() - cpu_start, 1),
                     "evaluation_seconds": round(evaluation_seconds[0], 1),
                     "evaluation_cpu_seconds": round(evaluation_seconds[1], 1)}
    write_json(args.out / "report.json", report)
    print(f"wrote {args.out / 'report.json'}", flush=True)
    return report


if __name__ == "__main__":
    try:
        main()
    except ModelError as err:
        print(f"{Path(sys.argv[0]).name}: error: {err}", file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt:
        sys.exit(130)

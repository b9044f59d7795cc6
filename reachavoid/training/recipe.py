"""The team recipe: train a team of attackers that share one Stable-Baselines3 PPO
policy (parameter sharing) against the HJ defenders, and compare it with the scripted and
random teams on the same seeded starts (``examples/train_attacker_team.py`` runs it).

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
on the vector env (``views.make_attackers_vector_env``, ``--copies`` games
stepped together, the defenders acting on every copy in one call; over a map library with
``--copies-per-map G`` the copies take their maps G at a time, so each map's defenders act
on its copies in one call; ``--supersuit``: the
attacker-only env through SuperSuit's chain, ``reachavoid_env.integrations.supersuit``):
one vector slot per attacker and game copy, all slots one policy: 16 copies by default
(the measured runs of ``BENCHMARKS.md``); fewer leave the vector env little to batch.
As in ``single`` (the one-attacker recipe), one agent step holds the
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
anywhere (``curriculum.StartCurriculum``, set before every rollout).
**Self-play with past policies** (``--past-selves POOL``, vector env only): one attacker
per copy learns and its teammates play frozen snapshots of the learner
(``self_play.PastSelves``): the policy PPO starts from, then one taken after every
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
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict
from typing import Any

import torch
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import CallbackList
from stable_baselines3.common.vec_env import VecMonitor

from policies.learned import TRAINING_ATTRIBUTE, training_record
from reachavoid.evaluation import write_csv
from reachavoid.training.callbacks import (
    EasyStarts,
    FullSpeed,
    PastSelfSnapshots,
    TrainingCurve,
    frozen,
    plot_curve,
)
from reachavoid.training.cloning import clone
from reachavoid.training.config import Maps, game, load_model, parse_args, team_maps
from reachavoid.training.flags import defender_options, reward_options
from reachavoid.training.self_play import PastSelves
from reachavoid.training.teams import evaluate, paired_difference, record
from reachavoid.training.views import (
    defender_factory,
    make_attacker_vector_env,
    make_attackers_vector_env,
)
from reachavoid_env.files import atomic_write, one_command, write_json
from reachavoid_env.integrations.supersuit import sb3_vec_env as supersuit_vec_env
from reachavoid_env.integrations.vector import sb3_vec_env


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



def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    """The recipe on ``argv`` (default: the command line's arguments); returns its report
    (report.json's content)."""
    with one_command():
        return run(parse_args(argv))


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


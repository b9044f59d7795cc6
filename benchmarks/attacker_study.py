"""Which training option pays: the team recipe's PPO variants, side by side.

    python benchmarks/attacker_study.py --scenario paper_2v1 \\
        --init runs/team_2v1/cloned.zip --runs runs/study_2v1 --cores 0,1 --confirm 1000 \\
        --json benchmarks/results/attacker_study_2v1.json
    python benchmarks/attacker_study.py --scenario paper_1v1 --variants base,easy-starts \\
        --runs runs/study_1v1 --cores 0,1 --confirm 1000 \\
        --json benchmarks/results/attacker_study_1v1.json

Every variant of ``VARIANTS`` (the recipe's reward and curriculum options) runs
``examples/train_attacker_team.py`` in its own process, pinned to one of ``--cores`` (as
many at once as cores): ``--minutes`` of PPO (``RECIPE``: 16 copies), then the learned team
plays the first ``--episodes`` starts against the ``hj`` defenders; the scripted
``shortest-path``, ``hj`` and ``hj-pairs`` teams play the same starts once, in their own run
(``RUNS/scripted``: the same for every variant, so played once). With ``--init CLONE``
every variant fine-tunes the same cloned policy (an earlier run's ``cloned.zip``) at the
measured fine-tuning settings (``FINE_TUNING``: learning rate 1e-4, clip 0.1); without it
every variant trains from scratch at SB3's defaults. Only the option differs between
variants, so ``variant - base`` paired over the starts is what the option bought. A variant
whose ``RUNS/NAME/report.json`` exists is read, not run again: stop with Ctrl-C and run the
same command to go on.

Figures per variant: the learned team's arrival rate, learned minus each scripted team and
variant - base (points, paired, 95% bootstrap over the starts), PPO agent steps and CPU
minutes. With ``--confirm N`` every variant's model then plays N fresh starts
(``--evaluate-only --first-seed EPISODES``, into ``RUNS/NAME/confirm``; the scripted teams
into ``RUNS/scripted/confirm``): a difference found on the first starts and chosen among
variants is confirmed, or not, on starts no choice has seen (``confirm_*`` figures).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from result_file import write_result

from reachavoid.evaluation import bootstrap_interval

RECIPE = ["--timesteps", "3000000", "--copies", "16", "--teams", "learned", "--no-video"]
"""The recipe's run (BENCHMARKS "Learned attackers"); ``--minutes`` ends PPO first on this
machine."""
SCRIPTED_TEAMS = ("shortest-path", "hj", "hj-pairs")
"""The scripted teams every variant is compared with, played once in ``RUNS/scripted``."""
FINE_TUNING = ["--learning-rate", "1e-4", "--clip-range", "0.1"]
"""PPO's settings from a clone (``--init``)."""

VARIANTS = {
    "base": [],
    "base-seed-1": ["--seed", "1"],
    "no-shaping": ["--shaping", "0"],
    "team-reward": ["--team-reward", "1"],
    "easy-starts": ["--easy-starts", "0.3"],
    "easy-starts-seed-1": ["--easy-starts", "0.3", "--seed", "1"],
    "easy-starts-seed-2": ["--easy-starts", "0.3", "--seed", "2"],
}
"""Variant name -> the recipe's options that make it (``base``: the recipe's rewards:
progress shaping 1, timeout -1, no team reward; ``base-seed-1``: the same with PPO seeded
otherwise, the spread of PPO alone against which the other variants are read;
``easy-starts``: the curriculum, attackers first within 0.3 map units of the target, the
whole map from half-way; ``easy-starts-seed-1``, ``easy-starts-seed-2``: the same with PPO
seeded otherwise)."""

ROOT = str(Path(__file__).resolve().parent.parent)
RECIPE_SCRIPT = Path(ROOT) / "examples" / "train_attacker_team.py"


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenario", default="paper_2v1")
    parser.add_argument("--init", type=Path, default=None, metavar="CLONE",
                        help="the policy every variant starts from (a cloned.zip; "
                             "default: PPO from scratch)")
    parser.add_argument("--runs", type=Path, required=True,
                        help="folder of the variants' runs (RUNS/NAME)")
    parser.add_argument("--variants", default=",".join(VARIANTS),
                        help="comma-separated from %(default)s")
    parser.add_argument("--minutes", type=float, default=15.0, help="PPO minutes per variant")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--confirm", type=int, default=0, metavar="N",
                        help="then play every variant's model on N fresh starts (default: 0)")
    parser.add_argument("--cores", default="0", help="cores to pin the runs to, e.g. 0,1")
    parser.add_argument("--json", default=None, help="write the result record here")
    args = parser.parse_args()
    args.variants = args.variants.split(",")
    unknown = [name for name in args.variants if name not in VARIANTS]
    if unknown:
        parser.error(f"--variants: unknown variant {unknown[0]!r} (choose from "
                     f"{', '.join(VARIANTS)})")
    if args.json and "base" not in args.variants:
        parser.error("--variants: needs base for --json (every variant is compared with it)")
    if args.init is not None and not args.init.is_file():
        parser.error(f"--init: no such file {str(args.init)!r}")
    try:
        args.cores = [int(core) for core in args.cores.split(",")]
    except ValueError:
        parser.error("--cores: core numbers separated by commas")
    if not args.minutes > 0 or args.episodes < 1:
        parser.error("--minutes and --episodes: must be positive")
    if args.confirm < 0:
        parser.error(f"--confirm: must be >= 0, got {args.confirm}")
    return args


def command(args: argparse.Namespace, name: str) -> list[str]:
    """The recipe's command line of variant ``name``."""
    start = [] if args.init is None else ["--init", str(args.init), *FINE_TUNING]
    return [sys.executable, str(RECIPE_SCRIPT), "--scenario", args.scenario, *start,
            "--max-minutes", str(args.minutes), "--episodes", str(args.episodes), *RECIPE,
            *VARIANTS[name], "--out", str(args.runs / name)]


def scripted_command(args: argparse.Namespace, episodes: int, first_seed: int,
                     out: Path) -> list[str]:
    """The recipe's command line that plays the scripted teams (nothing trained) on the
    starts ``first_seed`` <= k < ``first_seed + episodes``."""
    return [sys.executable, str(RECIPE_SCRIPT), "--scenario", args.scenario, "--teams",
            ",".join(SCRIPTED_TEAMS), "--no-video", "--episodes", str(episodes),
            "--first-seed", str(first_seed), "--out", str(out)]


def confirm_command(args: argparse.Namespace, name: str) -> list[str]:
    """The recipe's ``--evaluate-only`` command line of variant ``name``'s model on the
    ``--confirm`` fresh starts."""
    return [sys.executable, str(RECIPE_SCRIPT), "--scenario", args.scenario,
            "--evaluate-only", str(args.runs / name / "model.zip"),
            "--teams", "learned", "--no-video", "--episodes",
            str(args.confirm), "--first-seed", str(args.episodes),
            "--out", str(args.runs / name / "confirm")]


def run_all(args: argparse.Namespace, jobs: dict[str, tuple[Path, list[str]]]) -> None:
    """Run the jobs (name -> (folder, command)) whose folder has no report, as many at once
    as ``--cores``; Ctrl-C stops every run (each leaves no report, so the next call runs
    it again)."""
    waiting = [name for name, (folder, _) in jobs.items()
               if not (folder / "report.json").is_file()]
    running: dict[int, tuple[str, subprocess.Popen]] = {}
    try:
        while waiting or running:
            for core in [c for c in args.cores if c not in running][:len(waiting)]:
                name = waiting.pop(0)
                folder, line = jobs[name]
                folder.mkdir(parents=True, exist_ok=True)
                print(f"{name}: started on core {core}", flush=True)
                with open(folder / "log.txt", "w") as log:
                    running[core] = (name, subprocess.Popen(
                        ["taskset", "-c", str(core), *line], stdout=log,
                        stderr=subprocess.STDOUT, env={**os.environ, "PYTHONPATH": ROOT}))
            time.sleep(5)
            for core, (name, process) in list(running.items()):
                if process.poll() is not None:
                    del running[core]
                    if process.returncode:
                        raise SystemExit(f"{name}: the recipe exited with {process.returncode} "
                                         f"(log: {jobs[name][0] / 'log.txt'})")
                    print(f"{name}: done", flush=True)
    finally:
        for _, process in running.values():
            process.terminate()
            process.wait()


def points(values: np.ndarray) -> list[float]:
    """Mean and 95% bootstrap interval of per-start fractions, in percentage points."""
    low, high = bootstrap_interval(values)
    return [round(100 * float(values.mean()), 2), round(100 * low, 2), round(100 * high, 2)]


def read_report(folder: Path, first_seed: int, episodes: int) -> dict:
    """``folder``'s report, checked to have played the starts ``first_seed`` <= k <
    ``first_seed + episodes`` (a run kept from a call with other ``--episodes`` is not)."""
    report = json.loads((folder / "report.json").read_text())
    seeds = report["evaluation"]["seeds"]
    if seeds != [first_seed, first_seed + episodes - 1]:
        print(f"attacker_study.py: error: {folder}: played the starts {seeds[0]}..{seeds[1]}, "
              f"not {first_seed}..{first_seed + episodes - 1}; remove it or use another "
              "--runs", file=sys.stderr)
        raise SystemExit(2)
    return report


def main() -> None:
    args = parse_args()
    scripted = args.runs / "scripted"
    run_all(args, {"scripted": (scripted, scripted_command(args, args.episodes, 0, scripted)),
                   **{name: (args.runs / name, command(args, name))
                      for name in args.variants}})
    if args.confirm:
        run_all(args, {"scripted (confirm)": (scripted / "confirm", scripted_command(
                           args, args.confirm, args.episodes, scripted / "confirm")),
                       **{f"{name} (confirm)": (args.runs / name / "confirm",
                                                confirm_command(args, name))
                          for name in args.variants}})
    reports = {name: read_report(args.runs / name, 0, args.episodes)
               for name in args.variants}
    played = {False: read_report(scripted, 0, args.episodes)["per_episode"]}
    confirms = {name: read_report(args.runs / name / "confirm", args.episodes, args.confirm)
                for name in args.variants if args.confirm}
    if args.confirm:
        played[True] = read_report(scripted / "confirm", args.episodes,
                                   args.confirm)["per_episode"]

    def fractions(episode: dict) -> np.ndarray:
        return np.asarray(episode["arrived"], dtype=np.float64) / episode["attackers"]

    def learned_arrivals(name: str, confirmed: bool = False) -> np.ndarray:
        """Variant ``name``'s per-start arrival fractions on the study's starts or,
        ``confirmed``, on the fresh ones."""
        return fractions((confirms if confirmed else reports)[name]["per_episode"]["learned"])

    def scripted_arrivals(team: str, confirmed: bool = False) -> np.ndarray:
        """The same for a scripted team."""
        return fractions(played[confirmed][team])

    figures: dict[str, float | list[float]] = {}
    for name, report in reports.items():
        learned = learned_arrivals(name)
        figures[f"arrival_percent.{name}"] = points(learned)
        for team in SCRIPTED_TEAMS:
            figures[f"minus_{team.replace('-', '_')}_points.{name}"] = points(
                learned - scripted_arrivals(team))
        if "base" in reports and name != "base":
            figures[f"minus_base_points.{name}"] = points(learned - learned_arrivals("base"))
        figures[f"ppo_steps.{name}"] = report["training"]["agent_steps"]
        figures[f"ppo_cpu_min.{name}"] = round(report["training"]["cpu_seconds"] / 60, 1)
        print(f"{name:>12}: arrival {figures[f'arrival_percent.{name}']}, - shortest-path "
              f"{figures[f'minus_shortest_path_points.{name}']}, - hj "
              f"{figures[f'minus_hj_points.{name}']}"
              + (f", - base {figures[f'minus_base_points.{name}']}"
                 if f"minus_base_points.{name}" in figures else ""))
        if args.confirm:
            learned = learned_arrivals(name, confirmed=True)
            figures[f"confirm_arrival_percent.{name}"] = points(learned)
            for team in SCRIPTED_TEAMS:
                figures[f"confirm_minus_{team.replace('-', '_')}_points.{name}"] = points(
                    learned - scripted_arrivals(team, confirmed=True))
            if "base" in reports and name != "base":
                figures[f"confirm_minus_base_points.{name}"] = points(
                    learned - learned_arrivals("base", confirmed=True))
            print(f"{name:>12}: on {args.confirm} fresh starts, arrival "
                  f"{figures[f'confirm_arrival_percent.{name}']}, - shortest-path "
                  f"{figures[f'confirm_minus_shortest_path_points.{name}']}")
    if not args.json:
        return
    for team in SCRIPTED_TEAMS:
        figures[f"arrival_percent.{team}"] = points(scripted_arrivals(team))
        if args.confirm:
            figures[f"confirm_arrival_percent.{team}"] = points(
                scripted_arrivals(team, confirmed=True))
    confirm_units = {} if not args.confirm else {
        "confirm_arrival_percent": f"the same on {args.confirm} fresh starts reset(seed=k), "
                                   f"{args.episodes} <= k < {args.episodes + args.confirm} "
                                   "(the variant's model, --evaluate-only)",
        "confirm_minus_shortest_path_points": "learned minus shortest-path on the fresh "
                                              "starts, paired, points",
        "confirm_minus_hj_points": "learned minus hj on the fresh starts, paired, points",
        "confirm_minus_base_points": "the variant's learned team minus base's on the fresh "
                                     "starts, paired, points"}
    write_result(args.json, "attacker_study", figures, {
        "arrival_percent": f"{args.scenario}, the starts reset(seed=k), k < {args.episodes}, "
                           "against hj (31^4 / 15^6 tubes): percent of attackers that "
                           "arrive, [value, low, high], 95% bootstrap over the starts",
        "minus_shortest_path_points": "the variant's learned team minus the shortest-path "
                                      "team, paired over the starts, points",
        "minus_hj_points": "the variant's learned team minus the hj team, paired, points",
        "minus_base_points": "the variant's learned team minus base's, paired, points",
        "ppo_steps": f"PPO agent steps in {args.minutes:g} minutes from "
                     + ("scratch" if args.init is None else args.init.name),
        "ppo_cpu_min": "PPO CPU minutes (time.process_time of the run)", **confirm_units})
    print(f"wrote {args.json}")


if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:
        sys.exit(130)

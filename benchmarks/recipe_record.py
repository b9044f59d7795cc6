"""A run of the team recipe (``reachavoid.training.recipe``) as a result record.

Runs the recipe with the arguments after ``--`` (in this process, as
``reachavoid.training.recipe.main``), then writes its report's figures as a result record
(``benchmarks/result_file.py``) to ``--json``:

    python benchmarks/recipe_record.py --json benchmarks/results/learned_attacker_2v1.json \\
        -- --scenario paper_2v1 --imitate-from hj --imitate-steps 40000 --imitate-epochs 40 \\
        --net-arch 256,256 --dagger-rounds 3 --dagger-steps 20000 --dagger-epochs 20 \\
        --timesteps 3000000 --max-minutes 25 --learning-rate 1e-4 --clip-range 0.1 \\
        --easy-starts 0.3 --teams learned,hj,shortest-path,random --episodes 1000 \\
        --no-video --out runs/team_2v1

Keys (a team's name with ``-`` as ``_``): ``arrival_percent.TEAM`` ([value, 95% low, 95%
high]), ``mean_captured.TEAM``, ``FIRST_minus_SECOND_points`` (the recipe's paired
differences), the training's cost (``cloning_wall_s``, ``cloning_cpu_s``,
``clone_action_mse``, ``ppo_steps``, ``ppo_wall_s``, ``ppo_cpu_s``, ``training_cpu_min``)
and the run's (``evaluation_wall_s``, ``evaluation_cpu_s``, ``run_wall_s``, ``run_cpu_s``).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from result_file import write_result

from reachavoid.training import recipe
from reachavoid.training.config import ModelError


def percent(value: float) -> float:
    return round(100 * value, 2)


def figures_of(report: dict[str, Any]) -> dict[str, Any]:
    """The figures of a recipe report, keyed as the docstring says."""
    figures: dict[str, Any] = {}
    evaluation = report["evaluation"]
    for key, record in evaluation.items():
        if key == "seeds":
            continue
        interval = [percent(record["arrival_rate"]),
                    *(percent(bound) for bound in record["arrival_rate_ci95"])]
        if "_minus_" in key:
            figures[f"{key}_points"] = interval
        else:
            team = key.replace("-", "_")
            figures[f"arrival_percent.{team}"] = interval
            figures[f"mean_captured.{team}"] = record["mean_captured"]
    cloning, training = report.get("imitation"), report.get("training")
    cpu_seconds = 0.0
    if cloning is not None:
        rounds = [cloning, *cloning.get("dagger", {}).get("rounds", [])]
        figures["cloning_wall_s"] = round(sum(r["collect_seconds"] + r["fit_seconds"]
                                              for r in rounds), 1)
        figures["cloning_cpu_s"] = cloning["cpu_seconds"]
        figures["clone_action_mse"] = round(rounds[-1]["action_mse"], 5)
        cpu_seconds += cloning["cpu_seconds"]
    if training is not None:
        figures["ppo_steps"] = training["agent_steps"]
        figures["ppo_wall_s"] = training["seconds"]
        figures["ppo_cpu_s"] = training["cpu_seconds"]
        cpu_seconds += training["cpu_seconds"]
    if cpu_seconds:
        figures["training_cpu_min"] = round(cpu_seconds / 60, 1)
    run = report["run"]
    figures.update(evaluation_wall_s=run["evaluation_seconds"],
                   evaluation_cpu_s=run["evaluation_cpu_seconds"],
                   run_wall_s=run["seconds"], run_cpu_s=run["cpu_seconds"])
    return figures


MINUS_UNITS = ("the recipe's paired difference in arrival over the same starts (first team "
               "minus second), points, [value, low, high]")
UNITS = {
    "arrival_percent": "the recipe's evaluation starts reset(seed=k) against its defenders: "
                       "percent of attackers that arrive, [value, low, high], 95% bootstrap "
                       "over the starts",
    "mean_captured": "attackers captured per episode, mean over the starts",
    "cloning_wall_s": "wall seconds of cloning the teacher and the DAgger rounds",
    "cloning_cpu_s": "CPU seconds of the cloning and the DAgger rounds",
    "clone_action_mse": "the fit's action mean-squared error against the teacher, last round",
    "ppo_steps": "PPO agent steps after cloning (one per attacker per env step)",
    "ppo_wall_s": "PPO wall seconds",
    "ppo_cpu_s": "PPO CPU seconds of the process (time.process_time)",
    "training_cpu_min": "CPU minutes of the training: cloning, DAgger and PPO",
    "evaluation_wall_s": "wall seconds of the evaluation, every team on every start",
    "evaluation_cpu_s": "CPU seconds of the evaluation",
    "run_wall_s": "wall seconds of the whole run (tubes loaded or solved, training, "
                  "evaluation)",
    "run_cpu_s": "CPU seconds of the whole run",
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", required=True, help="write the result record here")
    parser.add_argument("recipe", nargs=argparse.REMAINDER,
                        help="-- then the recipe's arguments")
    args = parser.parse_args()
    try:
        report = recipe.main(args.recipe[1:] if args.recipe[:1] == ["--"] else args.recipe)
    except ModelError as err:
        parser.exit(2, f"{parser.prog}: error: {err}\n")
    figures = figures_of(report)
    units = {key.split(".")[0]: UNITS.get(key.split(".")[0], MINUS_UNITS) for key in figures}
    write_result(args.json, "recipe_record", figures, units)
    print(f"wrote {args.json}")


if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:
        sys.exit(130)

"""The training recipes' PPO loops on the vector env against their pre-vector paths, side
by side in one run.

Each recipe's own ``train`` (``examples/train_attacker_sb3.py``: one attacker, ``paper_1v1``,
16 copies; ``examples/train_attacker_team.py``: a team, ``paper_6v2``, 2 copies) runs for
``--timesteps`` agent steps (rounded up to whole PPO rollouts, as SB3 does), PPO's updates
included, with its defaults (``hj`` defenders on the coarse 31^4 / 15^6 tubes, action
repeat 10), once on the vector env (today's default) and once on the recipe's old path
(``--single-envs``: one Gymnasium env per copy; ``--supersuit``: SuperSuit's chain over the
attacker-only env); ``--team-copies N`` adds the team recipe on the vector env with
``--copies N`` (2 copies, the figures' setting, leave the vector env little to batch;
the recipe's default is 16). The paths
alternate for ``--repeats`` rounds (vector, old, vector, old, ...) so that the machine's
drift hits them alike. Before the timed runs, each path's envs
are built and stepped a little (tubes mapped in, kernels loaded). Figures, medians of the
rounds: agent steps per wall second and per CPU second of the process, and the wall time
of the loop. Pin it to one core (torch is set to one thread, as the recipes do):

    taskset -c 0 .venv/bin/python benchmarks/recipe_throughput.py --json out.json

Scripts under ``benchmarks/`` import the installed package: to time a checkout, put it
first on the path (``PYTHONPATH=$PWD``).
"""

from __future__ import annotations

import argparse
import importlib
import os
import statistics
import tempfile
from pathlib import Path
from types import ModuleType
from typing import Any, NamedTuple

import numpy as np
import torch
from harness import timed

from reachavoid.training.flags import defender_options
from reachavoid.training.views import defender_factory


class Recipe(NamedTuple):
    """A recipe: its example's name (the example only runs it), the flag of its old path,
    agent steps per run, and the module that holds it."""

    example: str
    old_flag: str
    timesteps: int
    module: str


RECIPES = {"sb3": Recipe("train_attacker_sb3", "--single-envs", 4096,
                         "reachavoid.training.single"),
           "team": Recipe("train_attacker_team", "--supersuit", 6144,
                          "reachavoid.training.recipe")}
"""Default agent steps: one PPO rollout of the one-attacker recipe (16 copies x 256 steps;
its old path takes a minute for it on a quiet core) and two of the team recipe (2 copies x
6 attackers x 256 steps)."""
TEAM_COPIES = 2
"""The team recipe's copies on both paths (its default before it became 16), so that both
paths run the same PPO rollouts."""


class Run(NamedTuple):
    """One timed training loop."""

    agent_steps: int
    wall_s: float
    cpu_s: float


def load_recipe(recipe: Recipe) -> ModuleType:
    """The module of ``recipe``."""
    return importlib.import_module(recipe.module)


def recipe_inputs(name: str, module: ModuleType, args: argparse.Namespace) -> Any:
    """What the recipe's ``train`` takes after its parsed arguments: the env keywords of
    the one-attacker recipe, the maps of the team recipe."""
    if name == "sb3":
        return module.env_kwargs(args, module.training_scenario(args))
    return module.team_maps(args.scenario)


def warm_up(name: str, module: ModuleType, args: argparse.Namespace) -> None:
    """Build the path's training envs (the defenders' tubes loaded) and step them a few
    times with random actions, untimed."""
    inputs = recipe_inputs(name, module, args)
    scenarios = [inputs["scenario"]] if name == "sb3" else list(inputs)
    for scenario in scenarios:
        defender_factory(args.defenders, **(defender_options(args) or {}))(scenario)
    envs = module.training_envs(args, inputs)
    envs.reset()
    rng = np.random.default_rng(0)
    for _ in range(20):
        envs.step(rng.uniform(-1, 1, (envs.num_envs, 2)).astype(np.float32))
    envs.close()


def timed_train(name: str, module: ModuleType, args: argparse.Namespace) -> Run:
    """The recipe's ``train`` on ``args``, timed (``harness.timed``: CPU and wall)."""
    inputs = recipe_inputs(name, module, args)

    def work() -> int:
        return module.train(args, inputs)[0].num_timesteps

    timing = timed(work)
    return Run(int(timing.counts[0]), timing.wall_seconds[0], timing.seconds[0])


def measure(recipes: list[str], repeats: int, timesteps: dict[str, int],
            team_copies: int | None, out: Path) -> dict[str, float]:
    figures: dict[str, float] = {}
    for name in recipes:
        recipe = RECIPES[name]
        module = load_recipe(recipe)
        common = ["--timesteps", str(timesteps[name]), "--out", str(out / name)]
        if name == "sb3":
            common += ["--print-seconds", "1e9"]
        if name == "team":
            common += ["--copies", str(TEAM_COPIES)]
        paths = {"vector": module.parse_args(common),
                 "old": module.parse_args([*common, recipe.old_flag])}
        if name == "team" and team_copies is not None:
            paths[f"vector_copies{team_copies}"] = module.parse_args(
                [*common, "--copies", str(team_copies)])
        for args in paths.values():
            warm_up(name, module, args)
        runs: dict[str, list[Run]] = {path: [] for path in paths}
        for _ in range(repeats):
            for path, args in paths.items():
                run = timed_train(name, module, args)
                runs[path].append(run)
                print(f"{name} {path:<15} {run.agent_steps:>7,} agent steps  {run.wall_s:6.1f} s "
                      f"wall  {run.agent_steps / run.wall_s:7.0f}/s  "
                      f"{run.agent_steps / run.cpu_s:7.0f}/CPU s", flush=True)
        for path, done in runs.items():
            figures[f"agent_steps.{name}.{path}"] = done[0].agent_steps
            figures[f"wall_s.{name}.{path}"] = statistics.median(r.wall_s for r in done)
            figures[f"agent_steps_per_s.{name}.{path}"] = statistics.median(
                r.agent_steps / r.wall_s for r in done)
            figures[f"agent_steps_per_cpu_s.{name}.{path}"] = statistics.median(
                r.agent_steps / r.cpu_s for r in done)
        figures[f"vector_over_old.{name}"] = (figures[f"agent_steps_per_s.{name}.vector"]
                                              / figures[f"agent_steps_per_s.{name}.old"])
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recipes", nargs="+", choices=list(RECIPES), default=list(RECIPES))
    parser.add_argument("--repeats", type=int, default=2, help="rounds of vector, old")
    for name, recipe in RECIPES.items():
        parser.add_argument(f"--{name}-timesteps", type=int, default=recipe.timesteps,
                            help=f"agent steps per run of {recipe.example}.py")
    parser.add_argument("--team-copies", type=int, default=None,
                        help="also time the team recipe on the vector env with this many "
                             "copies")
    parser.add_argument("--json", type=Path, help="write the figures here")
    args = parser.parse_args()
    for field in ("repeats", "team_copies"):
        value = getattr(args, field)
        if value is not None and value < 1:
            parser.error(f"--{field.replace('_', '-')}: expected at least 1, got {value}")
    torch.set_num_threads(1)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    load_start = os.getloadavg()[0]
    print(f"cores this process may use: {cores}; load average {load_start:.2f}", flush=True)
    with tempfile.TemporaryDirectory(prefix="recipe-throughput-") as out:
        figures = measure(args.recipes, args.repeats,
                          {name: getattr(args, f"{name}_timesteps") for name in RECIPES},
                          args.team_copies, Path(out))
    figures |= {"cores": cores, "load_average.start": load_start,
                "load_average.end": os.getloadavg()[0]}
    for key, value in figures.items():
        print(f"{key:<44} {value:>12,.2f}")
    if args.json:
        from result_file import write_result

        write_result(args.json, "recipe_throughput", figures, {
            "agent_steps": "PPO agent steps of one timed run (SB3 rounds up to whole "
                           "rollouts); sb3: examples/train_attacker_sb3.py (paper_1v1, 16 "
                           "copies), team: examples/train_attacker_team.py (paper_6v2, 2 "
                           "copies, one step per attacker slot); hj defenders on 31^4 / 15^6 "
                           "tubes, action repeat 10",
            "wall_s": "wall seconds of the recipe's train(), env building and PPO updates "
                      "included, median of the rounds",
            "agent_steps_per_s": "agent steps per wall second of train(), median of the "
                                 "rounds; vector: the vector env, old: --single-envs (sb3) "
                                 "or --supersuit (team), vector_copiesN: the team recipe "
                                 "on the vector env with --copies N",
            "agent_steps_per_cpu_s": "agent steps per CPU second of the process, median",
            "vector_over_old": "the vector path's agent steps per wall second over the old "
                               "path's",
            "cores": "cores the process could run on (taskset)",
            "load_average": "the machine's 1-minute load average at the start and the end"})


if __name__ == "__main__":
    main()

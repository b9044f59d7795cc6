"""Vector env throughput: K copies of paper_8v4 stepped together, against the single env
and MPE2's simple_tag (8 good agents, 4 adversaries), in one run; and the attacker-only
training view at K copies with the ``hj`` and ``greedy`` defenders (batched) against the
single-env attacker-only view with ``hj``.

Game steps per second (one game step = one step of one copy) with random actions drawn
beforehand, resets included (autoreset in the vector env, ``reset()`` at the end of an
episode in the single envs), for both observations (v1's egocentric default, v0's global
vector). Each figure is the median of ``--repeats`` timed runs. Pin it to one core:

    taskset -c 0 .venv/bin/python benchmarks/vector_throughput.py --json out.json
"""

from __future__ import annotations

import argparse
import platform
import statistics
import subprocess
import time
from datetime import date
from pathlib import Path
from typing import Any

import numpy as np

import reachavoid_env
from reachavoid_env.files import write_json
from reachavoid_env.observations import GLOBAL, ObservationConfig
from reachavoid_env.vector import vector_env

SCENARIO = "paper_8v4"
EPISODE_STEPS = 1000
OBSERVATIONS = {"v1": ObservationConfig(), "v0": GLOBAL}
GRIDS = {"grid1": 31, "grid2": 15}      # the training recipes' tubes


def vector_rate(copies: int, steps: int, observation: ObservationConfig) -> float:
    """Game steps per second of ``copies`` copies over ``steps`` vector steps."""
    env = vector_env(SCENARIO, num_envs=copies, max_cycles=EPISODE_STEPS,
                     observation=observation)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = [{name: rng.uniform(-1, 1, (copies, 2)) for name in env.possible_agents}
               for _ in range(8)]
    start = time.perf_counter()
    for i in range(steps):
        env.step(actions[i % 8])
    return copies * steps / (time.perf_counter() - start)


def single_rate(steps: int, observation: ObservationConfig) -> float:
    env = reachavoid_env.parallel_env(scenario=SCENARIO, starts="random",
                                      max_cycles=EPISODE_STEPS, observation=observation)
    return _parallel_rate(env, steps)


def mpe_rate(steps: int) -> float:
    from mpe2 import simple_tag_v3

    env = simple_tag_v3.parallel_env(num_good=8, num_adversaries=4, num_obstacles=2,
                                     continuous_actions=True, max_cycles=EPISODE_STEPS)
    return _parallel_rate(env, steps)


def _parallel_rate(env: Any, steps: int) -> float:
    env.reset(seed=0)
    for i, name in enumerate(env.possible_agents):
        env.action_space(name).seed(i)
    drawn = [{name: env.action_space(name).sample() for name in env.possible_agents}
             for _ in range(8)]
    start = time.perf_counter()
    for i in range(steps):
        if not env.agents:
            env.reset()
        env.step({name: drawn[i % 8][name] for name in env.agents})
    return steps / (time.perf_counter() - start)


def view_rate(defenders: str, copies: int, steps: int) -> float:
    """Game steps per second of the attacker-only vector view (random attacker actions)."""
    from policies.training import make_attackers_vector_env

    view = make_attackers_vector_env(SCENARIO, defenders=defenders, num_envs=copies,
                                     defender_options=GRIDS if defenders == "hj" else None,
                                     max_cycles=EPISODE_STEPS)
    view.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (8, copies, len(view.learners), 2))
    start = time.perf_counter()
    for i in range(steps):
        view.step(actions[i % 8])
    return copies * steps / (time.perf_counter() - start)


def single_view_rate(steps: int) -> float:
    """Game steps per second of the single-game attacker-only view with ``hj``."""
    from policies.training import make_attackers_parallel_env

    env = make_attackers_parallel_env(SCENARIO, defenders="hj", defender_options=GRIDS,
                                      max_cycles=EPISODE_STEPS)
    return _parallel_rate(env, steps)


def measure(args: argparse.Namespace) -> dict[str, Any]:
    rows: dict[str, list[float]] = {}
    for _ in range(args.repeats):
        if args.views:
            rows.setdefault("attackers view hj, single env", []).append(
                single_view_rate(args.view_steps))
            for defenders in ("hj", "greedy"):
                rows.setdefault(f"attackers view {defenders} K={args.view_copies}", []).append(
                    view_rate(defenders, args.view_copies,
                              max(5, args.view_steps // args.view_copies)))
        rows.setdefault("mpe2 simple_tag 8+4", []).append(mpe_rate(args.steps))
        for label, config in OBSERVATIONS.items():
            rows.setdefault(f"parallel_env {label}", []).append(single_rate(args.steps, config))
            for copies in args.copies:
                vector_steps = max(20, args.steps // copies)
                rows.setdefault(f"vector {label} K={copies}", []).append(
                    vector_rate(copies, vector_steps, config))
    medians = {label: statistics.median(values) for label, values in rows.items()}
    views = {}
    if args.views:
        k = args.view_copies
        views = {"hj_over_greedy": medians[f"attackers view hj K={k}"]
                 / medians[f"attackers view greedy K={k}"],
                 "hj_over_single_hj": medians[f"attackers view hj K={k}"]
                 / medians["attackers view hj, single env"]}
    return {
        "benchmark": "vector_throughput", "scenario": SCENARIO, "date": str(date.today()),
        "commit": subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                                 text=True, cwd=Path(__file__).parent).stdout.strip(),
        "machine": f"{platform.machine()}, {platform.python_version()}",
        "repeats": args.repeats, "game_steps_per_second": medians,
        "vector_over_single": {f"{label} K={k}": medians[f"vector {label} K={k}"]
                               / medians[f"parallel_env {label}"]
                               for label in OBSERVATIONS for k in args.copies},
        "views": views, "grids": list(GRIDS.values()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--copies", type=int, nargs="+", default=[1, 16, 64, 256])
    parser.add_argument("--steps", type=int, default=4000,
                        help="game steps per timed run (vector runs: steps / K vector steps)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--views", action="store_true",
                        help="also time the attacker-only views (hj and greedy defenders)")
    parser.add_argument("--view-copies", type=int, default=64)
    parser.add_argument("--view-steps", type=int, default=2000,
                        help="game steps per timed run of a view")
    parser.add_argument("--json", type=Path, help="write the figures here")
    args = parser.parse_args()
    result = measure(args)
    for label, rate in result["game_steps_per_second"].items():
        print(f"{label:<28} {rate:>10,.0f} game steps/s")
    for label, ratio in result["vector_over_single"].items():
        print(f"vector / single {label:<12} {ratio:6.1f}x")
    for label, ratio in result["views"].items():
        print(f"attackers view {label:<20} {ratio:6.2f}x")
    if args.json:
        write_json(args.json, result)


if __name__ == "__main__":
    main()

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
import statistics
import time
from pathlib import Path

import numpy as np

import reachavoid_env
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


def _parallel_rate(env: object, steps: int) -> float:
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


def measure(args: argparse.Namespace) -> dict[str, float]:
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
    figures: dict[str, float] = {}
    for label, rate in medians.items():
        figures[f"game_steps_per_s.{_key(label)}"] = rate
    for label in OBSERVATIONS:
        for k in args.copies:
            figures[f"vector_over_single.{label}.k{k}"] = (
                medians[f"vector {label} K={k}"] / medians[f"parallel_env {label}"])
        figures[f"single_over_mpe.{label}"] = (medians[f"parallel_env {label}"]
                                               / medians["mpe2 simple_tag 8+4"])
    if args.views:
        k = args.view_copies
        view = medians[f"attackers view hj K={k}"]
        figures["view_hj_over_greedy"] = view / medians[f"attackers view greedy K={k}"]
        figures["view_hj_over_single_hj"] = view / medians["attackers view hj, single env"]
    return figures


def _key(label: str) -> str:
    """A row label as a dotted key: ``vector v1 K=64`` -> ``vector.v1.k64``."""
    return (label.replace("K=", "k").replace(",", "").replace("mpe2 simple_tag 8+4", "mpe")
            .replace(" ", "."))


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
    figures = measure(args)
    for key, value in figures.items():
        print(f"{key:<44} {value:>12,.2f}")
    if args.json:
        from result_file import write_result

        write_result(args.json, "vector_throughput", figures, {
            "game_steps_per_s": f"{SCENARIO}, random actions, game steps (one step of one copy) "
                                f"per second, median of the repeats; views with hj / greedy "
                                f"defenders at grids {GRIDS['grid1']}/{GRIDS['grid2']}",
            "vector_over_single": "the vector env's game steps/s over parallel_env's, same "
                                  "observation",
            "single_over_mpe": "parallel_env's steps/s over MPE2 simple_tag 8+4's",
            "view_hj_over_greedy": "attacker-only vector view: hj's game steps/s over "
                                   "greedy's",
            "view_hj_over_single_hj": "attacker-only vector view with hj over the single-env "
                                      "attacker-only view with hj"})


if __name__ == "__main__":
    main()

"""The attacker-only vector view with ``hj`` (what a training run steps), this tree against
another checkout, side by side: game steps per CPU second of
``make_attackers_vector_env`` (``harness.training_views``) at K copies, random attacker
actions drawn beforehand, timed after a warm-up (a training run's copies are at every stage
of their episodes), for each scenario. Each side runs in a fresh process with its tree first on the
path (``harness.Job``), in alternating rounds (``harness.side_by_side``); pin it to one
core::

    taskset -c 0 .venv/bin/python benchmarks/view_against.py 42401d9 \
        --scenarios paper_2v1,paper_8v4 --json benchmarks/results/view_against.json
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
from pathlib import Path

import numpy as np
from harness import CPU, ROOT, Job, checkout, commit_of, side_by_side, spread, timed, training_views
from single_view import EPISODE_STEPS, GRIDS


def view_rate(scenario: str, copies: int, steps: int, warmup: int) -> float:
    """Game steps per CPU second of the attacker-only vector view of ``scenario`` with the
    batched ``hj`` (31^4 / 15^6 tubes) at ``copies`` copies, over ``steps`` vector steps
    after ``warmup`` untimed ones (names that exist since 42401d9; ``harness.training_views``)."""
    view = training_views().make_attackers_vector_env(
        scenario, defenders="hj", num_envs=copies, defender_options=GRIDS,
        max_cycles=EPISODE_STEPS)
    view.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (8, copies, len(view.learners), 2))
    for i in range(warmup):
        view.step(actions[i % 8])

    def play() -> int:
        for i in range(steps):
            view.step(actions[i % 8])
        return copies * steps

    return timed(play, clock=CPU).median


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("against", metavar="CHECKOUT",
                        help="the other tree: a folder or a revision")
    parser.add_argument("--scenarios", default="paper_2v1,paper_8v4")
    parser.add_argument("--copies", type=int, default=64)
    parser.add_argument("--steps", type=int, default=150, help="timed vector steps a round")
    parser.add_argument("--warmup", type=int, default=300, help="untimed vector steps first")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--json", type=Path, help="write the figures here")
    args = parser.parse_args()
    figures: dict[str, float | list[float]] = {}
    with contextlib.ExitStack() as stack:
        other = stack.enter_context(checkout(args.against))
        label = commit_of(other) or args.against
        for scenario in args.scenarios.split(","):
            work = (scenario, args.copies, args.steps, args.warmup)
            rates = side_by_side({"this": Job(ROOT, "view_against:view_rate", work),
                                  "other": Job(other, "view_against:view_rate", work)},
                                 args.rounds)
            key = f"{scenario}.k{args.copies}"
            figures[f"game_steps_per_cpu_s.{key}.this"] = spread(rates["this"])
            figures[f"game_steps_per_cpu_s.{key}.{label}"] = spread(rates["other"])
            figures[f"this_over_other.{key}"] = (statistics.median(rates["this"])
                                                 / statistics.median(rates["other"]))
            print(f"{key}: this {spread(rates['this'])}, {label} {spread(rates['other'])}, "
                  f"ratio {figures[f'this_over_other.{key}']:.3f}", flush=True)
    if args.json:
        from result_file import write_result

        write_result(args.json, "view_against", figures, {
            "game_steps_per_cpu_s": f"attacker-only vector view with hj (grids "
                                    f"{GRIDS['grid1']}/{GRIDS['grid2']}), game steps per CPU "
                                    f"second, [median, lowest, highest] over the rounds, this "
                                    f"tree and {label}",
            "this_over_other": f"this tree's median over {label}'s"})


if __name__ == "__main__":
    main()

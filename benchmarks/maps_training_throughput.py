"""Training across a map library: the attackers' vector training view with ``hj`` defenders
on many maps, by how the copies take their maps, against an earlier checkout.

The team recipe's PPO loop steps ``make_attackers_vector_env`` (every attacker learns,
``hj`` defenders on 31^4 / 15^6 tubes, ``action_repeat`` 5); over a library each copy draws
its map at every reset. This times that view's step on a library (default: ``reachavoid
maps --count 24 --seed 0``, made first) with full-speed random actions, drawn beforehand,
for each ``--copies-per-map`` (``ReachAvoidVectorEnv``'s: 1 is each copy's own draw), and,
with ``--baseline CHECKOUT`` (a folder, e.g. a ``git worktree`` of an earlier commit, or a
revision: ``harness.checkout``), the same view of that checkout with each copy's own draw,
in every repeat. Each configuration runs in a fresh process (a ``harness.Job``, so one's
caches do not serve another), first ``--warmup`` view steps (a training run's copies are
at every stage of their episodes), then ``--steps`` timed ones (``harness.timed``).
Figures: agent steps (one per attacker slot and view step, PPO's count) per CPU second,
the median of ``--repeats``; and the mean number of maps the copies are on::

    taskset -c 0 .venv/bin/python benchmarks/maps_training_throughput.py \\
        --library runs/maps_train --baseline 3f9b2d0 --json out.json
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import subprocess
import sys
from pathlib import Path

import numpy as np
from harness import ROOT, Job, checkout, side_by_side, timed, training_views
from result_file import write_result


def one_run(library: str, copies: int, copies_per_map: int, warmup: int, steps: int) -> dict:
    """Time the view (module docstring) in this process; its figures."""
    options = {} if copies_per_map == 1 else {"copies_per_map": copies_per_map}
    view = training_views().make_attackers_vector_env(
        library, defenders="hj", num_envs=copies, action_repeat=5, shaping=1.0,
        timeout_reward=-1.0, defender_options={"grid1": 31, "grid2": 15},
        **options)
    view.reset(seed=0)
    m = view.vec.base_scenario.num_attackers
    rng = np.random.default_rng(0)
    headings = rng.uniform(0.0, 2.0 * np.pi, (warmup + steps, copies, m))
    actions = np.stack([np.cos(headings), np.sin(headings)], axis=-1).astype(np.float32)
    for t in range(warmup):
        view.step(actions[t])
    maps_live = []

    def play() -> int:
        for t in range(warmup, warmup + steps):
            view.step(actions[t])
            maps_live.append(len(np.unique(map_of(view.vec))))
        return steps * copies * m

    return {"agent_steps_per_cpu_s": timed(play).median,
            "maps_live": float(np.mean(maps_live))}


def map_of(vec: object) -> np.ndarray:
    """Each copy's map in the vector env of the tree on the path (its core's since
    2026-12-07, the env's own before)."""
    core = getattr(vec, "_core", None)
    return core.map_of if core is not None else vec._map_of


def job(tree: Path, args: argparse.Namespace, copies_per_map: int) -> Job:
    """``one_run`` in a fresh process with ``tree`` first on the path."""
    return Job(tree, "maps_training_throughput:one_run",
               (str(args.library), args.copies, copies_per_map, args.warmup, args.steps))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--library", type=Path, default=Path("runs/maps_train"),
                        help="map library folder (made with `reachavoid maps --count 24 "
                             "--seed 0` if missing)")
    parser.add_argument("--copies", type=int, default=16)
    parser.add_argument("--copies-per-map", type=int, nargs="+", default=[1, 4, 8, 16])
    parser.add_argument("--warmup", type=int, default=100, help="view steps before timing")
    parser.add_argument("--steps", type=int, default=200, help="timed view steps")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--baseline", metavar="CHECKOUT",
                        help="also time this checkout's view (each copy's own draw): a "
                             "folder or a revision")
    parser.add_argument("--json", type=Path, help="write the figures here")
    args = parser.parse_args(argv)
    if not (args.library / "index.toml").exists():
        subprocess.run([sys.executable, "-m", "reachavoid", "maps", "--count", "24",
                        "--seed", "0", "--out", str(args.library)], check=True)
    args.library = args.library.resolve()
    with contextlib.ExitStack() as stack:
        jobs = {"baseline": job(stack.enter_context(checkout(args.baseline)), args, 1)
                } if args.baseline else {}
        jobs |= {f"copies_per_map_{g}": job(ROOT, args, g) for g in args.copies_per_map}
        runs = side_by_side(jobs, args.repeats)
    figures = {}
    for name, rows in runs.items():
        figures[f"agent_steps_per_cpu_s.{name}"] = round(statistics.median(
            r["agent_steps_per_cpu_s"] for r in rows), 1)
        figures[f"maps_live.{name}"] = round(statistics.mean(r["maps_live"] for r in rows), 2)
    reference = figures.get("agent_steps_per_cpu_s.baseline",
                            figures.get("agent_steps_per_cpu_s.copies_per_map_1"))
    for g in args.copies_per_map:
        figures[f"over_baseline.copies_per_map_{g}"] = round(
            figures[f"agent_steps_per_cpu_s.copies_per_map_{g}"] / reference, 2)
    for name, value in figures.items():
        print(f"{name}: {value}")
    if args.json is not None:
        units = {
            "agent_steps_per_cpu_s": f"{args.copies} copies of the library's 2 vs 1 game, hj "
                                     "defenders 31/15, action_repeat 5: PPO agent steps per "
                                     "CPU second, median of the repeats",
            "maps_live": "mean number of maps the copies are on, over the timed steps",
            "over_baseline": "agent steps per CPU second over the baseline checkout's (each "
                             "copy's own draw; without --baseline, copies_per_map 1)"}
        write_result(args.json, "maps_training_throughput", figures, units)


if __name__ == "__main__":
    main()

"""Benchmark: defender methods on the same seeded random starts (BENCHMARKS.md "Defenders").

Cells: random starts of the paper map with M attackers and N defenders
(``builtin_scenario("paper_2v1").with_players(M, N)``: 2v1, 6v2, 8v4) and of the
equal-speed scenario (``paper_6v4_equal``, 6v4), against shortest-path, ``hj``,
``hj-pairs`` (those that lose alone split as a pair), ``straight`` and random attackers,
or any attacker spec (``sb3:MODEL.zip``, a trained team), named ``LABEL=SPEC`` in the
tables. Every method plays the same seeds in every cell (``reachavoid.sweep.play_seed``
on a process pool). Each finished episode is appended at once to ``--results`` (JSON
lines), so a run can be stopped and resumed or extended (more seeds, methods or cells):
episodes already stored are not played again.

Reported per cell and method: the capture rate (mean over episodes of the fraction of
attackers captured, 95% t interval over episodes), the all-captured rate (95% Wilson
interval), the arrival rate (the attackers' objective: an attacker held off until the
episode ends is neither captured nor arrived), and the paired differences of the capture
and arrival rates against ``hj`` (per-seed differences on the seeds both played, 95% t
interval)::

    python benchmarks/defenders.py --grid1 45 --grid2 30 --seeds 200 --results d.jsonl
    python benchmarks/defenders.py --results d.jsonl --report      # tables only

``--compare OTHER.jsonl@LABEL`` adds the episodes another checkout of this script played
(``git worktree add`` of a revision, the same flags) as methods ``METHOD@LABEL``, paired
with this checkout's ``hj``: the same defender before and after a change, seed by seed.

``--json PATH`` also writes the tables' figures as a result record
(``benchmarks/result_file.py``), keyed ``capture_percent.CONFIG.ATTACKERS.METHOD``,
``arrival_percent...``, ``minus_hj_points...`` (capture), ``arrival_minus_hj_points...``
and ``bound_percent.CONFIG.ATTACKERS``.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import os
import time
from collections import defaultdict
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from result_file import write_result

import reachavoid_env
from policies.intercept import race_all
from policies.registry import PolicySpec
from reachavoid.evaluation import Z95, wilson_interval
from reachavoid.sweep import play_seed, sweep_of
from reachavoid_env.geodesic import distance_field

CONFIGS = {"2v1": ("paper_2v1", 2, 1), "6v2": ("paper_2v1", 6, 2),
           "8v4": ("paper_2v1", 8, 4), "6v4eq": ("paper_6v4_equal", 6, 4)}
"""Cell name: (built-in scenario, attackers, defenders)."""
ATTACKERS = ("shortest-path", "hj", "random")
METHODS = ("hj", "hj-pairs", "paper", "intercept", "greedy", "matching", "learned-mappo")
REFERENCE = "hj"


class Task(NamedTuple):
    """One episode to play."""

    config: str
    attackers: str
    method: str
    seed: int
    grid1: int
    grid2: int


def attacker_label(attackers: str) -> tuple[str, str]:
    """``(label, spec)`` of an ``--attackers`` entry: ``LABEL=SPEC`` (a trained team,
    ``best-response=sb3:runs/x/model.zip``), else the spec is its own label."""
    label, sep, spec = attackers.partition("=")
    return (label, spec) if sep and ":" not in label else (attackers, attackers)


def play(task: Task) -> dict[str, Any]:
    """Play ``task`` (in a worker) and return its row."""
    name, m, n = CONFIGS[task.config]
    scenario = reachavoid_env.builtin_scenario(name).with_players(m, n)
    method, *settings = task.method.split("+")
    options = {key: _option(value) for key, value in (x.split("=", 1) for x in settings)}
    attackers = attacker_label(task.attackers)[1]
    grids = {key: value for key, value in (("grid1", task.grid1), ("grid2", task.grid2))
             if any(PolicySpec(side, source).choice.takes(key)
                    for side, source in (("defenders", method), ("attackers", attackers)))}
    sweep = sweep_of(scenario, method, attackers, [task.seed], **grids, **options)
    result = play_seed(sweep, task.seed)
    return task._asdict() | {"attackers_total": m, "interceptable": interceptable(scenario,
                                                                                task.seed),
                             "captured": result.captured_count,
                             "arrived": result.arrived_count, "steps": result.steps,
                             "seconds": result.seconds,
                             "guaranteed_initial": result.guarantees[0]
                             if result.guarantees else None}


def interceptable(scenario: reachavoid_env.Scenario, seed: int) -> int:
    """How many attackers of ``seed``'s start some defender can intercept: reach within
    the capture radius, by a straight line at full speed, a point of the attacker's
    shortest path to the target no later than the attacker
    (``policies.intercept.race_all``). No defender policy captures more attackers that
    run their shortest paths (the ``shortest-path`` team): the cell's headroom."""
    env = reachavoid_env.parallel_env(scenario=scenario)
    env.reset(seed=seed)
    state = env.game_state()
    race = race_all(distance_field(scenario.map, scenario.player_radius), state)
    return int(race.wins[state.active_attackers].any(axis=1).sum())


def _option(text: str) -> Any:
    """A variant's option value: JSON (numbers, ``true``/``false``) where it parses."""
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def stored(path: Path) -> list[dict[str, Any]]:
    """The rows already in ``path`` (none if it does not exist)."""
    if not path.exists():
        return []
    with path.open() as handle:
        return [json.loads(line) for line in handle if line.strip()]


def _key(row: dict[str, Any]) -> tuple:
    return tuple(row[field] for field in Task._fields)


def run(tasks: list[Task], path: Path, workers: int) -> Iterator[dict[str, Any]]:
    """Play ``tasks`` on ``workers`` processes, appending each row to ``path`` (one JSON
    line, flushed) as it finishes."""
    with path.open("a") as handle, \
            multiprocessing.get_context("spawn").Pool(workers) as pool:
        for row in pool.imap_unordered(play, tasks):
            handle.write(json.dumps(row) + "\n")
            handle.flush()
            os.fsync(handle.fileno())
            yield row


def mean_interval(samples: np.ndarray) -> tuple[float, float, float]:
    """Mean and 95% normal interval half-width of ``samples``: ``(mean, low, high)``."""
    mean = float(np.mean(samples))
    half = Z95 * float(np.std(samples, ddof=1)) / math.sqrt(len(samples)) \
        if len(samples) > 1 else 0.0
    return mean, mean - half, mean + half


def report(rows: list[dict[str, Any]], grid: tuple[int, int] | None = None,
           figures: dict[str, Any] | None = None) -> str:
    """The tables of ``rows`` (those on tubes ``grid`` if given), one per cell; their
    figures (percent) go into ``figures`` when given, keyed as the result record's."""
    figures = {} if figures is None else figures
    cells: dict[tuple, dict[str, dict[int, dict]]] = defaultdict(lambda: defaultdict(dict))
    for row in rows:
        if grid is None or (row["grid1"], row["grid2"]) == grid:
            cell = (row["config"], attacker_label(row["attackers"])[0], row["grid1"],
                    row["grid2"])
            cells[cell][row["method"]][row["seed"]] = row
    lines = []
    for (config, attackers, g1, g2), methods in sorted(cells.items()):
        lines += [f"\n{config}, {attackers} attackers, tubes {g1}/{g2}", ""]
        cell = f"{config}.{attackers}"
        if attackers == "shortest-path":
            line, bound = _headroom(methods)
            lines += [line, ""]
            if bound is not None:
                figures[f"bound_percent.{cell}"] = 100 * bound
        lines += [
                  "| method | episodes | capture rate | all captured | arrival rate | "
                  f"capture minus {REFERENCE}, paired (seeds) | arrival minus {REFERENCE}, "
                  "paired |", "|---|---|---|---|---|---|---|"]
        reference = methods.get(REFERENCE, {})
        for method in [m for m in METHODS if m in methods] + sorted(set(methods) - set(METHODS)):
            episodes = methods[method]
            fractions = np.array([r["captured"] / r["attackers_total"]
                                  for r in episodes.values()])
            everyone = sum(r["captured"] == r["attackers_total"] for r in episodes.values())
            rate, low, high = mean_interval(fractions)
            all_low, all_high = wilson_interval(everyone, len(episodes))
            arrival, *_ = mean_interval(np.array([r["arrived"] / r["attackers_total"]
                                                  for r in episodes.values()]))
            paired = {"captured": "-", "arrived": "-"}
            common = sorted(set(episodes) & set(reference))
            for outcome, key in (("captured", "minus_hj_points"),
                                 ("arrived", "arrival_minus_hj_points")):
                if method == REFERENCE or len(common) < 2:
                    continue
                diffs = np.array([episodes[s][outcome] - reference[s][outcome]
                                  for s in common]) / episodes[common[0]]["attackers_total"]
                d, d_low, d_high = mean_interval(diffs)
                paired[outcome] = (f"{100 * d:+.1f} [{100 * d_low:+.1f}, {100 * d_high:+.1f}]"
                                   f" ({len(common)})")
                figures[f"{key}.{cell}.{method}"] = [100 * d, 100 * d_low, 100 * d_high]
            figures[f"capture_percent.{cell}.{method}"] = 100 * rate
            figures[f"arrival_percent.{cell}.{method}"] = 100 * arrival
            share = everyone / len(episodes)
            lines.append(f"| {method} | {len(episodes)} | {100 * rate:.1f}% "
                         f"[{100 * low:.1f}, {100 * high:.1f}] | {100 * share:.1f}% "
                         f"[{100 * all_low:.1f}, {100 * all_high:.1f}] | {100 * arrival:.1f}% | "
                         f"{paired['captured']} | {paired['arrived']} |")
    return "\n".join(lines)


def _headroom(methods: dict[str, dict[int, dict]]) -> tuple[str, float | None]:
    """The cell's bound (``interceptable``) and the episodes of any method above it: the
    line, and the bound (a share; None where not recorded)."""
    starts = {seed: row for episodes in methods.values() for seed, row in episodes.items()
              if "interceptable" in row}
    if not starts:
        return "bound: not recorded", None
    bound = np.mean([row["interceptable"] / row["attackers_total"] for row in starts.values()])
    above = sum(row["captured"] > row.get("interceptable", math.inf)
                for episodes in methods.values() for row in episodes.values())
    return (f"bound: {100 * bound:.1f}% of the attackers can be intercepted at the start "
            f"({len(starts)} seeds; episodes of any method capturing more: {above})",
            float(bound))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid1", type=int, default=45)
    parser.add_argument("--grid2", type=int, default=30)
    parser.add_argument("--seeds", type=int, default=200, help="seeds 0..N-1 per cell")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--configs", default=",".join(CONFIGS))
    parser.add_argument("--attackers", default=",".join(ATTACKERS))
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--results", type=Path, default=Path("defenders.jsonl"),
                        help="JSON lines file the episodes are appended to (resumable)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--report", action="store_true", help="only print the tables")
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    parser.add_argument("--compare", metavar="FILE@LABEL",
                        help="also report the episodes of another checkout's --results FILE "
                             "(this script run there), each method named METHOD@LABEL, "
                             "paired with this checkout's hj")
    args = parser.parse_args()
    split = lambda text: [x.strip() for x in text.split(",") if x.strip()]  # noqa: E731
    grid = (args.grid1, args.grid2)
    if not args.report:
        done = {_key(row) for row in stored(args.results)}
        tasks = [Task(config, attackers, method, seed, *grid)
                 for config in split(args.configs) for attackers in split(args.attackers)
                 for seed in range(args.first_seed, args.first_seed + args.seeds)
                 for method in split(args.methods)]
        tasks = [task for task in tasks if tuple(task) not in done]
        started = time.perf_counter()
        print(f"{len(tasks)} episodes to play on {args.workers} workers", flush=True)
        for count, _ in enumerate(run(tasks, args.results, args.workers), 1):
            if count % 50 == 0:
                print(f"{count} / {len(tasks)} in {time.perf_counter() - started:.0f} s",
                      flush=True)
        print(f"wall time {time.perf_counter() - started:.0f} s")
    figures: dict[str, Any] = {}
    rows = stored(args.results)
    if args.compare:
        path, _, label = args.compare.rpartition("@")
        rows += [row | {"method": f"{row['method']}@{label}"} for row in stored(Path(path))]
    print(report(rows, grid, figures))
    if args.json:
        write_result(args.json, "defenders", figures, {
            "capture_percent": f"mean share of attackers captured, percent, tubes "
                               f"{args.grid1}^4 / {args.grid2}^6",
            "arrival_percent": "mean share of attackers that arrive, percent",
            "minus_hj_points": "paired per-seed difference of the capture rate against hj, "
                               "percentage points: [difference, 95% low, 95% high]",
            "arrival_minus_hj_points": "paired per-seed difference of the arrival rate "
                                       "against hj, percentage points: [difference, 95% "
                                       "low, 95% high]",
            "bound_percent": "attackers interceptable at the start along their shortest "
                             "paths (no defender policy captures more), percent"})


if __name__ == "__main__":
    main()

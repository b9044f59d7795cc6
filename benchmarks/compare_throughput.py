"""Training throughput of two checkouts side by side: ``training_throughput.py`` run in
fresh processes, alternating between the checkouts (A, B, A, B, ... ``--rounds`` each),
each process timing greedy and hj runs alternately; then one table of medians.

    taskset -c 0 .venv/bin/python benchmarks/compare_throughput.py main . \\
        --rounds 3 --json benchmarks/results/training_throughput.json \\
        -- --scenarios paper_8v4 --every 1 --steps 3000 --repeats 5

A checkout is a folder (a ``git worktree``) or a revision of this repository, unpacked
for the run (``harness.checkout``). Every process runs this checkout's
``training_throughput.measure`` with the checkout it times first on the path
(``harness.Job``), so only the library code differs. Arguments after ``--`` go to
``training_throughput.py``. The table gives, per env, the median
steps/s of greedy (both checkouts' runs) and of hj in each checkout, and the median and
range of the per-pair hj / greedy ratios (each hj run against the greedy run just before
it, in the same process), and the median share of an hj step spent in the defenders'
``act``. ``--json PATH`` writes the after checkout's figures as a result record
(``benchmarks/result_file.py``), keyed ``NAME.SCENARIO.ENV``.
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import sys

from harness import Job, checkout, side_by_side
from result_file import write_result


def share(timed: list[list[float]]) -> float:
    """The median share of the step time spent in the defenders' ``act``."""
    return statistics.median(defenders for _, defenders, _ in timed)


def ratios(hj: list[float], greedy: list[float]) -> list[float]:
    """Each hj run's rate over the greedy run just before it (same process)."""
    return [h / g for h, g in zip(hj, greedy, strict=True)]


def ratio_cell(hj: list[float], greedy: list[float]) -> str:
    pairs = ratios(hj, greedy)
    return f"{statistics.median(pairs):.0%} ({min(pairs):.0%}-{max(pairs):.0%})"


def row_key(kind: str) -> str:
    """``paper_8v4: attackers shortest-path`` -> ``paper_8v4.attackers_shortest_path``."""
    scenario, env = kind.split(": ")
    env = "single_attacker" if env == "single" else env.replace(" ", "_").replace("-", "_")
    return f"{scenario}.{env}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("before", help="checkout of the code before (a folder or a revision)")
    parser.add_argument("after", help="checkout of the code after (a folder or a revision)")
    parser.add_argument("--rounds", type=int, default=3, help="processes per checkout")
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    ours, options = sys.argv[1:], []
    if "--" in ours:
        cut = ours.index("--")
        ours, options = ours[:cut], ours[cut + 1:]
    args = parser.parse_args(ours)
    runs: dict[str, dict[str, list]] = {"before": {}, "after": {}}
    with contextlib.ExitStack() as stack:
        jobs = {side: Job(stack.enter_context(checkout(rev)), "training_throughput:measure",
                          (options,)) for side, rev in (("before", args.before),
                                                        ("after", args.after))}
        for side, done in side_by_side(jobs, args.rounds).items():
            for rows in done:
                for label, timed in rows.items():
                    runs[side].setdefault(label, []).extend(timed)
    print("\n| env | greedy | hj before | hj after | hj / greedy before | "
          "hj / greedy after | hj's act, share of its step |\n|---|---|---|---|---|---|---|")
    figures: dict[str, float] = {}
    for label in runs["after"]:
        if not label.endswith(", hj"):
            continue
        kind = label.removesuffix(", hj")
        rates = {side: {name: [rate for rate, _, _ in runs[side][f"{kind}, {name}"]]
                        for name in ("greedy", "hj")} for side in runs}
        greedy = rates["before"]["greedy"] + rates["after"]["greedy"]
        print(f"| {kind} | {statistics.median(greedy):,.0f} | "
              f"{statistics.median(rates['before']['hj']):,.0f} | "
              f"{statistics.median(rates['after']['hj']):,.0f} | "
              f"{ratio_cell(rates['before']['hj'], rates['before']['greedy'])} | "
              f"{ratio_cell(rates['after']['hj'], rates['after']['greedy'])} | "
              f"{share(runs['before'][label]):.0%} -> {share(runs['after'][label]):.0%} |")
        key = row_key(kind)
        figures |= {
            f"hj_steps_per_cpu_s.{key}": statistics.median(rates["after"]["hj"]),
            f"hj_steps_per_cpu_s_before.{key}": statistics.median(rates["before"]["hj"]),
            f"greedy_steps_per_cpu_s.{key}": statistics.median(greedy),
            f"hj_over_greedy_percent.{key}": 100 * statistics.median(
                ratios(rates["after"]["hj"], rates["after"]["greedy"]))}
    if args.json:
        write_result(args.json, "training_throughput", figures, {
            "hj_steps_per_cpu_s": "median env steps per CPU second with HJ defenders, the "
                                  "after checkout (_before: the before checkout)",
            "greedy_steps_per_cpu_s": "median with greedy defenders, both checkouts' runs",
            "hj_over_greedy_percent": "median of the per-pair ratios hj / greedy, after, "
                                      "percent"})


if __name__ == "__main__":
    main()

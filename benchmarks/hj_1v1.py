"""Benchmark: the 1 vs 1 HJ solve on the paper map (BENCHMARKS.md, "HJ solver").

Each solver runs in a fresh subprocess so that its peak RSS is its own. Reported: wall
time to convergence (numba compile or cache load excluded and reported apart), iterations,
residual, process peak RSS, the solver's own allocations (tracemalloc peak) and, when
``hj_reachability`` is installed (``pip install -e '.[bench]'``), the same game solved by
it (first order, Lax-Friedrichs, forward Euler, zero-gradient boundary) to the same game
time, with the agreement of the two winning sets.

    python benchmarks/hj_1v1.py [--grid 45] [--threads 2] [--no-hj-reachability]
                                [--base f5f4333] [--repeat 3]

``--base DIR`` also runs our solver from another checkout (a folder, e.g. a ``git
worktree``, or a revision such as the commit before a change: ``harness.checkout``),
alternating with this one ``--repeat`` times in the same run. Every solve is a
``harness.Job`` (a fresh process with its checkout first on the path).

On a machine with more cores, pin the run to two of them (``taskset -c 0,1 ...``) to
compare with the 2-core figures: jax uses every core it sees.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import resource
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
from harness import ROOT, Job, checkout, once

SPEEDS, RADIUS = (1.0, 1.5), 0.1


def _peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def worker_numba(grid: int, out: str) -> dict:
    import numba

    from reachavoid_env import builtin_map
    from solvers.hj import solve_1v1

    game_map = builtin_map("paper")
    _, compile_seconds = once(lambda: solve_1v1(game_map, SPEEDS, RADIUS, 9, cache=False,
                                                 progress=False))
    rss_before = _peak_rss_mb()
    tracemalloc.start()
    vf, seconds = once(lambda: solve_1v1(game_map, SPEEDS, RADIUS, grid, cache=False,
                                         progress=False))
    _, traced_peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    np.save(out, np.asarray(vf.values))
    return {"solver": "reachavoid (numba)", "threads": numba.get_num_threads(),
            "compile_or_load_s": compile_seconds, "seconds": seconds,
            "iterations": vf.solver["iterations"], "start": vf.solver.get("start", "cold"),
            "residual": vf.solver["residual"],
            "converged": vf.solver["converged"], "game_time": vf.solver["iterations"]
            * vf.solver["dt"], "peak_rss_mb": _peak_rss_mb(), "rss_before_solve_mb": rss_before,
            "traced_peak_mb": traced_peak / 2**20}


def worker_hj_reachability(grid: int, horizon: float, out: str) -> dict:
    import hj_reachability as hj
    import jax
    import jax.numpy as jnp

    from reachavoid_env import builtin_map
    from solvers.hj import game_1v1
    from solvers.hj.grid import Grid
    from solvers.hj.marcher import map_problem

    game_map = builtin_map("paper")
    ours = Grid.for_players(game_map.domain, 2, grid)
    target, avoid = map_problem(game_1v1(SPEEDS, RADIUS), game_map, ours).sets()
    shape = ours.shape

    class Pursuit(hj.ControlAndDisturbanceAffineDynamics):
        def __init__(self) -> None:
            ball = hj.sets.Ball(jnp.zeros(2), 1.0)
            super().__init__("min", "max", ball, ball)

        def open_loop_dynamics(self, state, time):
            return jnp.zeros(4)

        def control_jacobian(self, state, time):
            return jnp.array([[SPEEDS[0], 0.0], [0.0, SPEEDS[0]], [0.0, 0.0], [0.0, 0.0]])

        def disturbance_jacobian(self, state, time):
            return jnp.array([[0.0, 0.0], [0.0, 0.0], [SPEEDS[1], 0.0], [0.0, SPEEDS[1]]])

    def edge(x, pad_width):
        return jnp.pad(x, (pad_width, pad_width), "edge")

    hj_grid = hj.Grid.from_lattice_parameters_and_boundary_conditions(
        hj.sets.Box(np.array(ours.lo), np.array(ours.hi)), shape, boundary_conditions=(edge,) * 4)
    l_values, g_values = jnp.asarray(target), jnp.asarray(avoid)
    settings = hj.SolverSettings.with_accuracy(
        "low", value_postprocessor=lambda t, v: jnp.maximum(jnp.minimum(v, l_values), g_values))
    initial = jnp.maximum(l_values, g_values)
    dynamics = Pursuit()
    _, compile_seconds = once(lambda: jax.block_until_ready(hj.step(
        settings, dynamics, hj_grid, 0.0, initial, -1e-3, progress_bar=False)))
    values, seconds = once(lambda: np.asarray(jax.block_until_ready(hj.step(
        settings, dynamics, hj_grid, 0.0, initial, -horizon, progress_bar=False))))
    np.save(out, values.astype(np.float32))
    return {"solver": f"hj_reachability {hj.__version__} (jax {jax.__version__}, CPU)",
            "compile_or_load_s": compile_seconds, "seconds": seconds, "game_time": horizon,
            "iterations": None, "peak_rss_mb": _peak_rss_mb()}


def _run_worker(function: str, args: tuple, threads: int, tree: Path = ROOT) -> dict:
    """``function`` of this script as a ``harness.Job`` in ``tree`` on ``threads`` threads."""
    env = {"NUMBA_NUM_THREADS": str(threads), "OMP_NUM_THREADS": str(threads)}
    return Job(tree, f"hj_1v1:{function}", args, env=env).run() | {"checkout": str(tree)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid", type=int, default=45)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--no-hj-reachability", action="store_true")
    parser.add_argument("--base", help="another checkout to run side by side")
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    args = parser.parse_args()
    print(f"# hj_1v1: paper map, {args.grid}^4, vA={SPEEDS[0]}, vD={SPEEDS[1]}, R={RADIUS}, "
          f"{args.threads} threads, {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} CPUs visible, {time.strftime('%Y-%m-%d')}, load "
          f"{os.getloadavg()[0]:.1f}")
    with contextlib.ExitStack() as stack:
        scratch = stack.enter_context(tempfile.TemporaryDirectory())
        ours_file = os.path.join(scratch, "ours.npy")
        base_file = os.path.join(scratch, "base.npy")
        trees = {"": ROOT} | ({"_before": stack.enter_context(checkout(args.base))}
                              if args.base else {})
        runs: dict[str, list[dict]] = {"": [], "_before": []}
        for _ in range(args.repeat):
            for side, tree in trees.items():
                result = _run_worker("worker_numba", (args.grid, base_file if side else
                                                      ours_file), args.threads, tree)
                print(json.dumps(result | {"load_after": round(os.getloadavg()[0], 1)}),
                      flush=True)
                if not side:
                    ours = result
                runs[side].append(result)
        if args.json:
            from result_file import write_result  # here: workers run under another path

            figures = {f"{name}{side}.{args.grid}": pick(r[key] for r in done)
                       for side, done in runs.items() if done
                       for key, name, pick in (("iterations", "sweeps", max),
                                               ("seconds", "solve_s", min))}
            write_result(args.json, "hj_1v1", figures, {
                "sweeps": "sweeps to convergence, 1 vs 1 game on the paper map (_before: the "
                          "--base checkout)",
                "solve_s": "solve loop, seconds, the fastest of --repeat"})
        if args.base:
            a, b = np.load(ours_file), np.load(base_file)
            differ = (a <= 0) != (b <= 0)
            worst = np.maximum(np.abs(a), np.abs(b))[differ].max() if differ.any() else 0.0
            print(f"# against the base checkout: values identical {np.array_equal(a, b)}, "
                  f"signs differ at {int(differ.sum())} of {a.size} nodes (largest |value| "
                  f"there {worst:.2e}), largest difference {np.abs(a - b).max():.2e}")
        try:
            import hj_reachability  # noqa: F401
        except ImportError:
            print("# hj_reachability not installed: pip install -e '.[bench]'")
            return
        if args.no_hj_reachability:
            return
        theirs_file = os.path.join(scratch, "theirs.npy")
        theirs = _run_worker("worker_hj_reachability",
                             (args.grid, ours["game_time"], theirs_file), args.threads)
        a, b = np.load(ours_file), np.load(theirs_file)
        theirs["winning_set_agreement"] = float(np.mean((a <= 0) == (b <= 0)))
        print(json.dumps(theirs))
        print(f"# speed-up over hj_reachability: {theirs['seconds'] / ours['seconds']:.0f}x")


if __name__ == "__main__":
    main()

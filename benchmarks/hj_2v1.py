"""Benchmark: the 2 vs 1 HJ solve on the paper map at several grids (BENCHMARKS.md).

Each grid runs in a fresh subprocess so that its peak RSS is its own. Reported per grid:
iterations, time to convergence (the solve loop; numba compile or cache load excluded),
wall time of the whole call (tables, solve, save), process peak RSS against the solver's
own memory estimate, and the paper's example (defender (0.3, -0.3) vs attackers
(-0.5, 0) and (0, 0.8)). Then the memory guard on bigger grids: the estimate, the
available memory, and whether the solver refuses (checked by calling it).

    python benchmarks/hj_2v1.py [--grids 20 25 30] [--threads 2] [--store] [--probe 36 40 45]
                                [--base f5f4333] [--sweeps N]

``--store`` solves into the real cache (``solvers.hj.cache.cache_dir``)
and leaves the tubes there for the policies; without it a temporary cache is used. The 1 vs
1 value is the 45^4 solve (the paper's), from the same cache. ``--base DIR``: also run every
grid with the solver of another checkout (a folder, e.g. a ``git worktree``, or a revision
such as ``f5f4333``: ``harness.checkout``), alternating with ours, in the same run, and
compare the signs. Every solve is a ``harness.Job`` (a fresh process with its checkout
first on the path). ``--sweeps N``: stop after
N sweeps (for grids too slow to converge here: time per sweep and peak RSS).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import resource
import sys
import tempfile
import time

from harness import ROOT, Job, checkout, once

EXAMPLE = [-0.5, 0.0, 0.0, 0.8, 0.3, -0.3]


def worker(grid: int, sweeps: int | None, out: str) -> dict:
    """Runs with either checkout's ``solvers`` (the same public API); saves the stored
    value rows to ``out``; what the solve took, by name."""
    import numba
    import numpy as np

    import solvers
    from reachavoid_env import builtin_map
    from solvers.hj import SolverSettings, solve_1v1, solve_2v1

    game_map = builtin_map("paper")
    vf11 = solve_1v1(game_map, grid_points=45, progress=False)
    _, compile_seconds = once(lambda: solve_2v1(game_map, vf11, grid_points=8, cache=False,
                                                 progress=False))
    settings = SolverSettings() if sweeps is None else SolverSettings(max_iterations=sweeps)
    vf, wall = once(lambda: solve_2v1(game_map, vf11, grid_points=grid,
                                      progress=sys.stderr.isatty(), settings=settings,
                                      cache=sweeps is None))
    solver = vf.solver
    np.save(out, np.asarray(vf.values))
    stored_points = (grid**2 * (grid**2 + 1) // 2) * grid**2
    return {
        "solver": os.path.dirname(os.path.dirname(solvers.__file__)),
        "grid": f"{grid}^6", "threads": numba.get_num_threads(),
        "iterations": solver["iterations"], "start": solver.get("start", "cold"),
        "converged": solver["converged"],
        "residual": solver["residual"], "game_time": solver["iterations"] * solver["dt"],
        "solve_s": solver["seconds"], "wall_s": wall, "compile_or_load_s": compile_seconds,
        "sweep_s": solver["seconds"] / solver["iterations"],
        "mpoints_per_s": stored_points * solver["iterations"] / solver["seconds"] / 1e6,
        "peak_rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20,
        "example_value": float(vf.value(np.array(EXAMPLE))),
        "example_1v1": [float(v) for v in vf11.value(np.array([EXAMPLE[:2] + EXAMPLE[4:],
                                                               EXAMPLE[2:]]))],
        "cached_at": str(getattr(vf.values, "filename", "")),
    }


def _compare_signs(ours: str, base: str) -> None:
    """Print how the two checkouts' stored values compare: nodes of another sign (and the
    largest value among them), the largest difference."""
    import numpy as np

    a, b = np.load(ours, mmap_mode="r"), np.load(base, mmap_mode="r")
    differ = (a <= 0) != (b <= 0)
    worst = float(np.maximum(np.abs(a[differ]), np.abs(b[differ])).max()) if differ.any() \
        else 0.0
    print(f"# signs differ at {int(differ.sum())} of {a.size} stored nodes (largest |value| "
          f"there {worst:.2e}); largest difference {float(np.abs(a - b).max()):.2e}",
          flush=True)


def _estimate(grid: int) -> int:
    """Our solver's memory estimate for the 2 vs 1 solve on ``grid``^6 (bytes)."""
    from reachavoid_env import builtin_map
    from solvers.hj import SolverSettings, game_2v1
    from solvers.hj.grid import Grid
    from solvers.hj.reach_avoid import memory_needed

    domain = builtin_map("paper").domain
    return memory_needed(game_2v1((1.0, 1.5), 0.1), Grid.for_players(domain, 3, grid),
                         SolverSettings())


def probe(grid: int) -> dict:
    from reachavoid_env import builtin_map
    from solvers.hj import InsufficientMemoryError, solve_1v1, solve_2v1
    from solvers.hj.reach_avoid import available_memory

    game_map = builtin_map("paper")
    need = _estimate(grid)
    report = {"grid": f"{grid}^6", "estimate_gb": need / 2**30,
              "available_gb": available_memory() / 2**30}
    if need <= available_memory():
        report["verdict"] = "fits: the solver would run it (not run here)"
        return report
    vf11 = solve_1v1(game_map, grid_points=45, progress=False)
    try:
        solve_2v1(game_map, vf11, grid_points=grid, progress=False)
    except InsufficientMemoryError as err:
        report["verdict"] = f"refused: {err}"
    return report


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grids", type=int, nargs="*", default=[20, 25, 30])
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--store", action="store_true")
    parser.add_argument("--probe", type=int, nargs="*", default=[36, 40, 45])
    parser.add_argument("--base", help="another checkout to run side by side")
    parser.add_argument("--sweeps", type=int)
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    args = parser.parse_args()
    print(f"# hj_2v1: paper map, vA=1, vD=1.5, R=0.1, 1v1 at 45^4, {args.threads} threads, "
          f"{os.cpu_count()} CPUs visible, {time.strftime('%Y-%m-%d %H:%M')}, load "
          f"{os.getloadavg()[0]:.1f}", flush=True)
    sys.path.insert(0, str(ROOT))  # this checkout's solvers, whatever is installed
    with contextlib.ExitStack() as stack:
        scratch = stack.enter_context(tempfile.TemporaryDirectory())
        checkouts = [ROOT] + ([stack.enter_context(checkout(args.base))] if args.base else [])
        results = []
        for grid in args.grids:
            for side, tree in enumerate(checkouts):
                env = {"NUMBA_NUM_THREADS": str(args.threads)}
                if not args.store or side:
                    env["REACHAVOID_CACHE_DIR"] = os.path.join(scratch, str(len(results)))
                out = os.path.join(scratch, f"{grid}-{side}.npy")
                result = Job(tree, "hj_2v1:worker", (grid, args.sweeps, out), env=env).run()
                result["estimate_gb"] = _estimate(grid) / 2**30 if not side else None
                result["load_after"] = round(os.getloadavg()[0], 1)
                result["side"] = "_before" if side else ""
                results.append(result)
                print(json.dumps(result), flush=True)
            if args.base:
                _compare_signs(*(os.path.join(scratch, f"{grid}-{k}.npy") for k in (0, 1)))
        ours = [r for r in results if not r["side"]]
        if len(ours) >= 2:
            first, last = ours[0], ours[-1]
            ratio = args.grids[-1] / args.grids[0]
            print(f"# {first['grid']} -> {last['grid']}: time x"
                  f"{last['solve_s'] / first['solve_s']:.1f}, iterations x"
                  f"{last['iterations'] / first['iterations']:.2f}, points x{ratio**6:.1f}",
                  flush=True)
        for grid in args.probe:
            print(json.dumps(probe(grid)), flush=True)
    if args.json:
        from result_file import write_result  # here: workers run under another PYTHONPATH

        figures: dict[str, float] = {}
        for result in results:
            grid, side = result["grid"].split("^")[0], result["side"]
            for key, name in (("iterations", "sweeps"), ("peak_rss_gb", "peak_rss_gb"),
                              ("solve_s", "solve_s"), ("example_value", "example_value")):
                figures[f"{name}{side}.{grid}"] = result[key]
        write_result(args.json, "hj_2v1", figures, {
            "sweeps": "red-black sweeps to convergence, 2 vs 1 game on the paper map, by grid "
                      "(_before: the --base checkout)",
            "peak_rss_gb": "peak resident memory of the solving process, GB",
            "solve_s": "solve loop, seconds", "example_value":
            "the paper's worked example: positive, a defender win"})


if __name__ == "__main__":
    main()

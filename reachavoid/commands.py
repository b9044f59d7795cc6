"""The ``solve``, ``bench``, ``maps`` and ``paper`` commands: each checks what it alone
takes, hands the work to its driver (``solve``, ``suite``, ``reachavoid_env.maps``,
``paper``) and prints or writes the report (the tables: ``tables``)."""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import os
import sys
import time
from typing import Any

from reachavoid.arguments import (
    GRID_RANGE,
    OPTION_FLAGS,
    check_backend_options,
    checked,
    chosen_specs,
    defender_methods,
    load_many,
    load_one,
)
from reachavoid.evaluation import one_start, write_csv
from reachavoid.paths import (
    UsageError,
    check_outputs,
    distinct_outputs,
    reported,
    writable_file,
    writable_folder,
)
from reachavoid.solve import DEFAULT_GRID, solve_library, solve_scenario
from reachavoid.suite import (
    Cell,
    Suite,
    SuiteResult,
    library_suite,
    load_suite,
    parse_players,
    plot_suite,
    run_suite,
)
from reachavoid.tables import bench_tables, paper_lines
from reachavoid_env import PolicyMismatch, checks
from reachavoid_env.files import STDOUT, write_json
from reachavoid_env.maps import MAX_MAPS, MapError, MapOptions, options_from_text, write_library
from solvers.hj.cache import cache_dir

ONE_CELL = {"scenario": "paper_2v1", "config": "6v2", "attackers": "shortest-path"}
"""``bench``'s single cell without ``--suite`` (defaults of the flags that make it)."""


def solve(args: argparse.Namespace) -> int:
    """``solve``: one game to convergence, or with ``--defenders`` every tube of a library."""
    if args.defenders is not None:
        return _solve_library(args)
    if len(args.scenario) != 1:
        raise UsageError("--scenario: several scenarios need --defenders (which tubes to solve)",
                         field="--scenario")
    args.scenario = args.scenario[0]
    if args.grid is not None:
        checked(checks.integer, args.grid, "--grid",
                *GRID_RANGE["grid1" if args.game == "1v1" else "grid2"])
    if args.out is not None:
        writable_folder(args.out, "--out")
    if args.plot is not None:
        from solvers.hj.value import VALUE_FILES

        # a value directory's own files are replaced by --out, never by another output
        distinct_outputs([*(("--out", os.path.join(args.out, name)) for name in VALUE_FILES
                            if args.out is not None), ("--plot", args.plot)])
        writable_file(args.plot, "--plot", args.force)
    scenario = load_one(args.scenario)
    grid1 = args.grid1 if args.grid1 is not None else DEFAULT_GRID["1v1"]
    try:
        grid = grid1 if args.game == "1v1" and args.grid is None else args.grid
        report = solve_scenario(scenario, args.game, grid, out=args.out, grid_points_1v1=grid1,
                                plot=args.plot, progress=args.progress)
    except (ValueError, MemoryError) as err:
        raise reported(err) from None
    print(report.summary())
    return 0


def _solve_library(args: argparse.Namespace) -> int:
    for flag, value in (("--out", args.out), ("--plot", args.plot), ("--grid", args.grid)):
        if value is not None:
            raise UsageError(f"{flag}: not with --defenders (a library goes to the cache)",
                             field=flag)
    methods = defender_methods(args.defenders)
    check_backend_options(args)
    scenarios = load_many(args.scenario)
    try:
        rows = solve_library(scenarios, methods, args.grid1, args.grid2, backend=args.backend,
                             workers=args.workers, address=args.address,
                             progress=args.progress)
    except (ValueError, MemoryError) as err:
        if getattr(err, "field", None) == "workers":
            raise UsageError(f"--{err}", "--workers") from None
        raise reported(err) from None
    print(f"{'map':<24} {'game':<5} {'grid':>5} {'seconds':>9} {'peak MiB':>9}")
    for row in rows:
        seconds = "cached" if row.seconds is None else f"{row.seconds:.1f}"
        print(f"{row.map:<24} {row.game:<5} {row.grid:>5} {seconds:>9} "
              f"{row.peak_bytes / 2**20:>9.0f}")
    solved = sum(row.seconds is not None for row in rows)
    print(f"{len(rows)} tubes on {len({row.map for row in rows})} maps: {solved} solved, "
          f"{len(rows) - solved} from the cache ({cache_dir()})")
    return 0


def bench(args: argparse.Namespace) -> int:
    """``bench``: the suite's cells played by each method; tables, CSV, JSON, plot."""
    checked(checks.integer, args.episodes, "--episodes", 1, 10_000_000)
    methods = defender_methods(args.defenders)
    baseline = args.baseline or ("hj" if "hj" in methods else methods[0])
    if baseline not in methods:
        raise UsageError(f"--baseline: {baseline!r} is not among --defenders "
                         f"({', '.join(methods)})", field="--baseline")
    check_backend_options(args)
    check_outputs((("--csv", args.csv), ("--plot", args.plot), ("--json", args.json)),
                  args.force, text={"--csv", "--json"})
    suite = _bench_suite(args)
    attackers = dict.fromkeys(cell.attackers for cell in suite.cells)
    chosen_specs([*(("defenders", m) for m in methods),
                  *(("attackers", a) for a in attackers)], args)
    repeated = [cell.label for cell in suite.cells
                if (cell.episodes or args.episodes) > 1 and one_start(cell.scenario)]
    if repeated:
        print(f"reachavoid bench: warning: {len(repeated)} cell(s) play every episode from "
              f"the same start (fixed starts), so their intervals cover the policies' "
              f"randomness only: {', '.join(repeated)}", file=sys.stderr)
    options = {name: getattr(args, name) for name in OPTION_FLAGS
               if getattr(args, name) is not None}
    started = time.perf_counter()
    try:
        result = run_suite(suite, methods, args.episodes, baseline, options, OPTION_FLAGS,
                           backend=args.backend, workers=args.workers, address=args.address,
                           progress=args.progress)
    except PolicyMismatch as err:   # a policy that cannot play a cell (a model's players)
        raise reported(err) from None
    seconds = time.perf_counter() - started
    report = result.to_dict() | {"episodes": args.episodes, "wall_seconds": seconds}
    if args.csv:
        write_csv(args.csv, [{k: (";".join(v) if isinstance(v, list) else v)
                              for k, v in row.items()} for row in report["rows"]])
    if args.plot:
        plot_suite(result, args.plot)
    if args.csv == STDOUT:   # the rows went to standard output: the tables go beside them
        with contextlib.redirect_stdout(sys.stderr):
            return _print_bench(args, result, report, seconds)
    return _print_bench(args, result, report, seconds)


def _bench_suite(args: argparse.Namespace) -> Suite:
    """The suite to play: ``--suite``, or one cell of ``--scenario`` and ``--config``."""
    if args.suite is not None:
        given = [f"--{key}" for key, default in ONE_CELL.items()
                 if getattr(args, key) not in (None, default)]
        if given:
            raise UsageError(f"{given[0]}: not with --suite (the suite names its cells)",
                             field=given[0])
        try:
            suite = load_suite(args.suite)
        except OSError as err:
            raise UsageError(f"--suite: cannot read {args.suite!r}: {err.strerror}",
                             field="--suite") from None
        except ValueError as err:
            raise reported(err) from None
        return suite if args.seed is None else Suite(suite.name, suite.version, args.seed,
                                                      suite.cells)
    players = (None if args.config is None
               else checked(parse_players, args.config, "--config"))
    scenarios = load_many(args.scenario)
    if len(scenarios) > 1:
        return library_suite(args.scenario, scenarios, args.attackers, args.seed or 0, players)
    scenario = scenarios[0].with_players(*(players or parse_players(ONE_CELL["config"],
                                                                    "--config")))
    cell = Cell(scenario.name, scenario, args.attackers)
    return Suite(scenario.name, 0, args.seed or 0, (cell,))


def _print_bench(args: argparse.Namespace, result: SuiteResult, report: dict[str, Any],
                 seconds: float) -> int:
    if args.json == "-":
        print(json.dumps(report))
        return 0
    if args.json:
        write_json(args.json, report, indent=1)
    print(bench_tables(result, seconds))
    for flag, path in (("per-episode rows", args.csv), ("JSON", args.json), ("plot", args.plot)):
        if path:
            print(f"{flag}: {path}")
    return 0


def maps(args: argparse.Namespace) -> int:
    """``maps``: a library of generated maps written to ``--out``."""
    checked(checks.integer, args.count, "--count", 1, MAX_MAPS)
    out = writable_folder(args.out, "--out")
    try:
        options = options_from_text({option.name: getattr(args, f"map_{option.name}")
                                     for option in dataclasses.fields(MapOptions)})
        written = write_library(out, options, args.seed, args.count)
    except MapError as err:
        flag = f"--{(err.field or '').replace('_', '-')}"
        raise UsageError(err.renamed(flag), flag) from None
    print(f"{args.count} maps and {written[-1].name} -> {out}/")
    return 0


def paper(args: argparse.Namespace) -> int:
    """``paper``: the paper's table printed, its videos and figure written."""
    from reachavoid import paper as paper_table

    out = writable_folder(args.out, "--out")
    check_outputs([("--out", path) for path in paper_table.outputs(out, not args.no_video)],
                  args.force, out)
    out.mkdir(parents=True, exist_ok=True)
    rows = paper_table.reproduce(out, args.grid1, args.grid2, videos=not args.no_video,
                                 progress=args.progress)
    print(paper_lines(rows, args.grid1, args.grid2, paper_table.ATTACKERS, out))
    return 0


def exploit(args: argparse.Namespace) -> int:
    """``exploit``: every run not finished in ``--out`` (``reachavoid.training.exploit``),
    then ``exploitability.json``, the plot and a line per defender."""
    from policies.registry import DEFENDERS
    from reachavoid.training import exploit as best_response
    from reachavoid.training import transfer
    from reachavoid.training.budget import Budget, check_budget

    methods = defender_methods(args.defenders)
    untrainable = [method for method in methods if method not in DEFENDERS]
    if untrainable:
        raise UsageError(f"--defenders: {untrainable[0]!r}: the recipe trains against the "
                         f"built-in defenders only ({', '.join(DEFENDERS)})",
                         field="--defenders")
    checked(checks.integer, args.seeds, "--seeds", 1, 10_000)
    budget = Budget(**{item.name: getattr(args, item.name)
                       for item in dataclasses.fields(Budget)})
    try:
        check_budget(budget)
    except checks.FieldError as err:
        raise reported(err) from None
    check_backend_options(args)
    players = checked(parse_players, args.config, "--config")
    out = writable_folder(args.out, "--out")
    result_path = out / "exploitability.json"
    check_outputs((("--out", result_path), ("--plot", args.plot)), args.force, out)
    game = best_response.Game(load_one(args.scenario).with_players(*players), args.grid1,
                              args.grid2)
    try:
        best_response.check_folder(out, game, budget)
    except checks.FieldError as err:
        raise reported(err) from None
    result = best_response.exploit(game, budget, methods, args.seeds, out, args.backend,
                                   args.workers, args.address)
    if args.transfer:
        transfer.transfer(game, {method: entry["best_scripted"]
                                 for method, entry in result["defenders"].items()},
                          budget.episodes, out, args.backend, args.workers, args.address)
    result["defenders"] = {method: transfer.defender_entry(entry, method, out)
                           for method, entry in result["defenders"].items()}
    write_json(result_path, result, indent=1)
    if args.plot:
        best_response.plot(result, args.plot)
    for method, entry in result["defenders"].items():
        print(f"{method}: exploitability {entry['mean_exploitability']:+.3f} over "
              f"{len(entry['runs'])} seed(s) (best scripted team: {entry['best_scripted']})"
              + (f"; strongest attack known {entry['strongest_arrival_rate']:.3f} "
                 f"({entry['strongest_team']})" if "strongest_team" in entry else ""))
    print(f"JSON: {result_path}" + (f"\nplot: {args.plot}" if args.plot else ""))
    return 0

"""What every command checks of its arguments before any work, beside the output paths
(``paths``): numbers in their ranges, the chosen policies and their options, the scenarios
named, the backend flags. Each failure is a one-line ``UsageError`` naming the flag (exit
status 2); ``check_common`` runs before every command."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from policies.registry import TABLES, PolicySpec, policy_specs
from reachavoid.paths import UsageError, reported
from reachavoid.sweep import check_backend
from reachavoid_env import Scenario, checks, load_scenario
from reachavoid_env.maps import load_library
from solvers.hj.cache import check_cache

EXIT_USAGE, EXIT_FAILED, EXIT_INTERRUPTED, EXIT_PIPE = 2, 1, 130, 141
"""Exit statuses: bad input; a failed write or a dead worker; Ctrl-C; a closed pipe."""
MAX_SEED = 2**63 - 1
GRID_RANGE = {"grid1": (5, 201), "grid2": (5, 101)}
"""Nodes per axis accepted for the 1 vs 1 and 2 vs 1 tubes (the memory guard still
refuses what this machine cannot hold)."""
OPTION_FLAGS = {"grid1": "--grid1", "grid2": "--grid2", "margin_cells": "--margin-cells"}
"""The policy options the command line takes (each goes to the chosen policies that take
it; one that none takes is an error)."""


def checked(check: Any, value: Any, field: str, *bounds: Any) -> Any:
    """``check(value, field, *bounds)`` (a ``reachavoid_env.checks`` validator), its
    ``ValueError`` reported as a ``UsageError``."""
    try:
        return check(value, field, *bounds)
    except ValueError as err:
        raise reported(err) from None


def check_common(args: argparse.Namespace) -> None:
    """The flags several commands share (grids, seed, margin) and the cache; sets
    ``args.progress`` (progress bars when standard error is a terminal)."""
    for name in ("grid1", "grid2"):
        if getattr(args, name, None) is not None:
            checked(checks.integer, getattr(args, name), f"--{name}", *GRID_RANGE[name])
    if getattr(args, "seed", None) is not None:
        checked(checks.integer, args.seed, "--seed", 0, MAX_SEED)
    if getattr(args, "margin_cells", None) is not None:
        from policies.strategy import check_margin_cells

        checked(check_margin_cells, args.margin_cells, "--margin-cells")
    if not check_cache():
        print(f"reachavoid {args.command}: warning: the cache ($REACHAVOID_CACHE_DIR) is "
              "not writable; what is solved now is not kept", file=sys.stderr)
    args.progress = sys.stderr.isatty()


def check_backend_options(args: argparse.Namespace) -> None:
    """``--backend`` (Ray importable), ``--workers`` and ``--address``."""
    try:
        check_backend(args.backend)   # Ray importable, before any tube is solved
    except ValueError as err:
        raise UsageError(f"--{err}") from None
    if args.workers is not None:
        checked(checks.integer, args.workers, "--workers", 1, 4096)
    if args.address is not None and args.backend != "ray":
        raise UsageError("--address: only with --backend ray", field="--address")


def load_one(source: str) -> Scenario:
    """The scenario ``source`` names (a built-in name or a TOML file)."""
    try:
        return load_scenario(source)
    except OSError as err:
        raise UsageError(f"scenario: cannot read {source!r}: {err.strerror}",
                         field="scenario") from None


def load_many(source: str | list[str]) -> tuple[Scenario, ...]:
    """The scenarios ``source`` names: scenarios, map library folders or index files."""
    try:
        return load_library(source)
    except OSError as err:
        raise UsageError(f"scenario: cannot read {err.filename or source!r}: "
                         f"{err.strerror}", field="scenario") from None


def chosen_specs(choices: list[tuple[str, str]], args: argparse.Namespace) -> list[PolicySpec]:
    """The chosen policies, each with the options given on the command line that it takes
    (``OPTION_FLAGS``); a policy that cannot be found, or an option none takes, is a
    ``UsageError`` naming the flag."""
    options = {name: getattr(args, name) for name in OPTION_FLAGS
               if getattr(args, name, None) is not None}
    try:
        return policy_specs(choices, options, OPTION_FLAGS)
    except ValueError as err:
        side = getattr(err, "field", None)
        if side in TABLES:   # a choice on a side: name its flag
            raise UsageError(f"--{err}", f"--{side}") from None
        raise reported(err) from None


def defender_methods(text: str) -> list[str]:
    """Comma-separated defender methods (specs), each once, in order."""
    methods = list(dict.fromkeys(m.strip() for m in text.split(",") if m.strip()))
    if not methods:
        raise UsageError(f"--defenders: expected comma-separated methods, got {text!r}",
                         field="--defenders")
    return methods

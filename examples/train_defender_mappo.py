"""Train the ``learned-mappo`` defenders (MAPPO with TorchRL, ``rl`` extra) and write
their actor as the weights file the registry plays (``policies/mappo.py``).

    python examples/train_defender_mappo.py --out policies/weights/learned_mappo.npz

The recipe is ``reachavoid.training.mappo.train_defenders``: one shared actor, a
centralised critic, the default suite's games in turn (random starts, shortest-path
attackers, and random ones in 6v2). It prints one line per iteration and, with
``--report``, writes every iteration's record as JSON. The same ``--seed`` on the same
machine and library versions writes the same file, bit for bit. Every flag and output is
checked before any work; an existing file is replaced only with ``--force``.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Sequence
from dataclasses import asdict
from typing import Any

from policies.mappo import save_weights
from reachavoid.paths import UsageError, check_outputs
from reachavoid.training.flags import Bounds, check_ranges
from reachavoid.training.mappo import GAMES, TrainConfig, games_of, train_defenders
from reachavoid_env.files import atomic_write, forget_expected
from reachavoid_env.vector import MAX_COPIES

RANGES: dict[str, Bounds] = {
    "iterations": (1, 10**6), "copies": (1, MAX_COPIES), "steps": (1, 10**6),
    "action_repeat": (1, 1000), "epochs": (1, 10**4), "minibatch": (1, 10**9),
    "hidden": (1, 4096), "seed": (0, 2**32 - 1), "shaping": (None, None),
    "lr": (0.0, None, True), "entropy": (0.0, None)}
"""Every number's range (``check_ranges``), checked before any work; an action repeat as
the weights file holds it (``policies.mappo``)."""


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    defaults = TrainConfig()
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--out", required=True, help="the weights file to write (.npz)")
    parser.add_argument("--report", help="write the iterations' records here (.json)")
    parser.add_argument("--games", default=",".join("/".join(game) for game in GAMES),
                        help="SCENARIO/ATTACKERS, comma-separated, trained in turn")
    for name in ("iterations", "copies", "steps", "action_repeat", "epochs", "minibatch",
                 "hidden", "seed"):
        parser.add_argument(f"--{name.replace('_', '-')}", type=int,
                            default=getattr(defaults, name))
    for name in ("shaping", "lr", "entropy"):
        parser.add_argument(f"--{name}", type=float, default=getattr(defaults, name))
    parser.add_argument("--force", action="store_true",
                        help="replace output files that exist (default: refuse, before any work)")
    args = parser.parse_args(argv)
    check_ranges(parser, args, RANGES)
    try:
        args.games = games_of(args.games.split(","))
        check_outputs([("--out", args.out), ("--report", args.report)], args.force,
                      text={"--report"})
    except (ValueError, UsageError) as err:
        parser.error(f"--{err}" if str(err).startswith("games:") else str(err))
    return args


def main(argv: Sequence[str] | None = None) -> list[dict[str, Any]]:
    args = parse_args(argv)
    try:
        return run(args)
    finally:
        forget_expected()


def run(args: argparse.Namespace) -> list[dict[str, Any]]:
    """Train as ``args`` (checked by ``parse_args``) say; write the weights and report."""
    options = {key: value for key, value in vars(args).items()
               if key not in ("out", "report", "games", "force")}
    config = TrainConfig(games=args.games, **options)
    started = time.perf_counter()

    def log(record: dict[str, Any]) -> None:
        print(", ".join(f"{key} {value:.4g}" if isinstance(value, float) else f"{key} {value}"
                        for key, value in record.items()), flush=True)

    weights, history = train_defenders(config, log)
    save_weights(args.out, weights)
    wall = time.perf_counter() - started
    print(f"wrote {args.out}: {history[-1]['cpu_s']:.0f} CPU s, {wall:.0f} wall s")
    if args.report:
        with atomic_write(args.report) as handle:
            json.dump({"config": asdict(config), "wall_s": wall, "history": history},
                      handle, indent=1)
    return history


if __name__ == "__main__":
    main()

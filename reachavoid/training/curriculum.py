"""The start curriculum: easy starts first (``StartCurriculum``), set from ``--easy-starts``
and ``--easy-fraction`` (``add_curriculum_arguments``, ``start_curriculum``); the recipe's
callback (``callbacks.EasyStarts``) moves the vector env's start reach before every
rollout."""

from __future__ import annotations

import argparse
from dataclasses import dataclass

from reachavoid_env import checks


@dataclass(frozen=True)
class StartCurriculum:
    """Easy starts first: random attackers start within ``first`` map units of the target
    (the vector env's ``start_reach``), a reach that grows linearly to the map's diagonal
    over the first ``fraction`` of training; after that, anywhere."""

    first: float
    fraction: float = 0.5

    def __post_init__(self) -> None:
        checks.positive(self.first, "easy_starts")
        checks.positive(self.fraction, "easy_fraction", 1.0)

    def reach(self, progress: float, diagonal: float) -> float | None:
        """The start reach (map units; ``None``: anywhere) when ``progress`` (0 to 1) of
        the training is done, on a map whose domain's diagonal is ``diagonal``."""
        if progress >= self.fraction:
            return None
        return self.first + max(diagonal - self.first, 0.0) * progress / self.fraction


def add_curriculum_arguments(parser: argparse.ArgumentParser) -> None:
    """``--easy-starts D`` and ``--easy-fraction F`` (``StartCurriculum``'s ``first`` and
    ``fraction``); ``start_curriculum`` reads them."""
    parser.add_argument("--easy-starts", type=float, default=None, metavar="D",
                        help="curriculum: attackers start within D map units of the target "
                             "at first (default: anywhere from the start)")
    parser.add_argument("--easy-fraction", type=float, default=0.5, metavar="F",
                        help="the share of training over which the start reach grows to the "
                             "whole map (default: %(default)s)")


def start_curriculum(args: argparse.Namespace) -> StartCurriculum | None:
    """The curriculum of ``add_curriculum_arguments``' values (``None`` without
    ``--easy-starts``); ``ValueError`` naming the option if a value is out of range."""
    if args.easy_starts is None:
        return None
    return StartCurriculum(args.easy_starts, args.easy_fraction)

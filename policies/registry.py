"""Policies by name: the one table that the command line, the training envs and the
benchmarks build their policies from.

    from policies.registry import make_policy
    defenders = make_policy("defenders", "hj", scenario, grid1=31, grid2=15)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from policies.attackers import HJAttacker, RandomAttacker, ShortestPathAttacker, StraightAttacker
from policies.defenders import (
    GreedyDefender,
    HJDefenderPolicy,
    HJPairsDefenderPolicy,
    IdleDefender,
    MatchingDefenderPolicy,
)
from policies.intercept import InterceptDefender
from reachavoid_env import Policy, Scenario


@dataclass(frozen=True)
class NamedPolicy:
    """A policy choice: one line of help, ``build(scenario, **options)`` and the option
    names it accepts."""

    help: str
    build: Callable[..., Policy]
    options: frozenset[str] = frozenset()


DEFENDERS: dict[str, NamedPolicy] = {
    "hj": NamedPolicy("the reference: HJ tubes + the paper's assignment MIP (CP-SAT), "
                      "re-solved every step",
                      HJDefenderPolicy.for_scenario,
                      frozenset({"grid1", "grid2", "idle", "margin_cells", "progress"})),
    "hj-pairs": NamedPolicy("the reference with defender teams: two defenders may share an "
                            "attacker neither stops alone (1 vs 2 tube), re-solved every step",
                            HJPairsDefenderPolicy.for_scenario,
                            frozenset({"grid1", "grid2", "idle", "margin_cells", "progress"})),
    "paper": NamedPolicy("the paper's Algorithm 1 exactly: HJ tubes + the assignment MIP, "
                         "every value > 0 a defender win, unassigned defenders stand still",
                         HJDefenderPolicy.paper, frozenset({"grid1", "grid2", "progress"})),
    "matching": NamedPolicy("the maximum-matching baseline (unmatched defenders stand still)",
                            MatchingDefenderPolicy.for_scenario,
                            frozenset({"grid1", "unmatched", "margin_cells", "progress"})),
    "intercept": NamedPolicy("the time-to-intercept heuristic: each defender races the most "
                             "threatening attacker it can cut off to a point of its shortest "
                             "path, spare defenders back up",
                             lambda scenario, **o: InterceptDefender(**o), frozenset({"cells"})),
    "greedy": NamedPolicy("chase the nearest active attacker",
                          lambda scenario: GreedyDefender()),
    "idle": NamedPolicy("stand still", lambda scenario: IdleDefender()),
}

ATTACKERS: dict[str, NamedPolicy] = {
    "shortest-path": NamedPolicy("the time-optimal path to the target around obstacles, "
                                 "ignoring defenders (the paper's attackers)",
                                 lambda scenario, **o: ShortestPathAttacker(**o),
                                 frozenset({"cells"})),
    "hj": NamedPolicy("1 vs 1 optimal control against the most dangerous defender",
                      HJAttacker.for_scenario, frozenset({"grid1", "progress"})),
    "straight": NamedPolicy("run straight for the nearest target centre",
                            lambda scenario: StraightAttacker()),
    "random": NamedPolicy("run in random directions, redrawn every 0.25 s",
                          lambda scenario, **o: RandomAttacker(**o),
                          frozenset({"seed", "hold"})),
}

TABLES = {"defenders": DEFENDERS, "attackers": ATTACKERS}


def named_policy(side: str, name: str) -> NamedPolicy:
    """The table entry of ``name`` on ``side`` (``"defenders"`` or ``"attackers"``)."""
    if side not in TABLES:
        raise ValueError(f"side: expected 'defenders' or 'attackers', got {side!r}")
    if name not in TABLES[side]:
        raise ValueError(f"{side}: unknown policy {name!r} (choices: {', '.join(TABLES[side])})")
    return TABLES[side][name]


def make_policy(side: str, name: str, scenario: Scenario, **options: Any) -> Policy:
    """Build the policy ``name`` for ``scenario``; unknown options are an error."""
    entry = named_policy(side, name)
    unknown = sorted(set(options) - entry.options)
    if unknown:
        accepted = ", ".join(sorted(entry.options)) or "none"
        raise ValueError(f"{side} {name!r}: unknown option(s) {unknown} (accepted: {accepted})")
    return entry.build(scenario, **options)


def accepted_options(side: str, name: str, **available: Any) -> dict[str, Any]:
    """The subset of ``available`` options that policy ``name`` accepts (for callers, such as
    the command line, that hold one set of options for every choice)."""
    entry = named_policy(side, name)
    return {key: value for key, value in available.items() if key in entry.options}

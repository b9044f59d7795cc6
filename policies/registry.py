"""Policies by name: the one table that the command line, the training envs and the
benchmarks build their policies from.

    from policies.registry import make_policy
    defenders = make_policy("defenders", "hj", scenario, grid1=31, grid2=15)
"""

from __future__ import annotations

import pkgutil
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from reachavoid_env import Policy, Scenario


@dataclass(frozen=True)
class NamedPolicy:
    """A policy choice: one line of help, its factory and the option names it accepts.

    ``factory`` is ``"module:attribute"`` (imported on first use, so the tables cost
    nothing to read); it is called as ``factory(scenario, **options)``, or
    ``factory(**options)`` when ``scenario`` is false.
    """

    help: str
    factory: str
    options: frozenset[str] = frozenset()
    scenario: bool = True

    def build(self, scenario: Scenario, **options: Any) -> Policy:
        """The policy for ``scenario`` with ``options`` (already checked)."""
        factory = pkgutil.resolve_name(self.factory)
        return factory(scenario, **options) if self.scenario else factory(**options)


DEFENDERS: dict[str, NamedPolicy] = {
    "hj": NamedPolicy("the reference: HJ tubes + the paper's assignment MIP (CP-SAT), "
                      "re-solved every step",
                      "policies.defenders:HJDefenderPolicy.for_scenario",
                      frozenset({"grid1", "grid2", "idle", "margin_cells", "progress"})),
    "hj-pairs": NamedPolicy("the reference with defender teams: two defenders may share an "
                            "attacker neither stops alone (1 vs 2 tube), re-solved every step",
                            "policies.defenders:HJPairsDefenderPolicy.for_scenario",
                            frozenset({"grid1", "grid2", "idle", "margin_cells", "progress"})),
    "matching": NamedPolicy("the maximum-matching baseline (unmatched defenders stand still)",
                            "policies.defenders:MatchingDefenderPolicy.for_scenario",
                            frozenset({"grid1", "unmatched", "margin_cells", "progress"})),
    "greedy": NamedPolicy("chase the nearest active attacker",
                          "policies.defenders:GreedyDefender", scenario=False),
    "idle": NamedPolicy("stand still", "policies.defenders:IdleDefender", scenario=False),
}

ATTACKERS: dict[str, NamedPolicy] = {
    "shortest-path": NamedPolicy("the time-optimal path to the target around obstacles, "
                                 "ignoring defenders (the paper's attackers)",
                                 "policies.attackers:ShortestPathAttacker",
                                 frozenset({"cells"}), scenario=False),
    "hj": NamedPolicy("1 vs 1 optimal control against the most dangerous defender",
                      "policies.attackers:HJAttacker.for_scenario",
                      frozenset({"grid1", "progress"})),
    "straight": NamedPolicy("run straight for the nearest target centre",
                            "policies.attackers:StraightAttacker", scenario=False),
    "random": NamedPolicy("run in random directions, redrawn every 0.25 s",
                          "policies.attackers:RandomAttacker", frozenset({"seed", "hold"}),
                          scenario=False),
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

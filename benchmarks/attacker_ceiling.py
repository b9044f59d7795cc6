"""Benchmark: how far any attacker can get above the scripts against the reference defenders.

The learned-attacker goal (beat the scripted ``shortest-path`` attackers by a paired
interval that excludes 0) needs starts where the script fails and some other play
succeeds. Against defenders that play a reach-avoid game soundly, an attacker whose game
the defender wins never arrives, whatever it does. So this benchmark asks, per random
start of the paper map, what the paper's own grids (the oracle tubes, finer than the
defenders' training tubes) say the attackers can win, and where each scripted team
arrives:

- ``1v1``: the 1 vs 1 value at the start: the attacker wins or the defender does;
- ``2v1``: the 2 vs 1 value (the defender wins if it captures both) and how many of the
  two attackers win their 1 vs 1 game alone.

Each scripted team (``policies.registry.ATTACKERS``) plays the same seeded starts
(``reset(seed=k)``, the team recipe's evaluation starts) against ``hj`` on the defenders'
tubes (the ``hj`` and ``hj-pairs`` attackers on those tubes too). Reported per cell: arrival
percent per team; the starts the oracle calls winnable and lost; per team, its arrivals in
each class; and ``room_points``, the arrival a team would add over ``shortest-path`` by
reaching the oracle's count in every start: in 1 vs 1 the winnable starts where the script
did not arrive (a bound, if the oracle is exact and the defenders never err); in 2 vs 1 one
attacker per start the pair wins where the script's pair brought in none, and the second
attacker of each start where both win alone and only one came in (the count a defender that
captures whom it can leaves)::

    python benchmarks/attacker_ceiling.py --episodes 200 \\
        --json benchmarks/results/attacker_ceiling.json

``6v2`` has no oracle (no tube of that game): the cell reports each team's arrival and
``best_of_teams_percent``, the arrival of the best scripted team chosen per start after
the fact. That is not a bound: a maximum over teams per start is biased upward by the
episodes' noise, and a play none of the teams makes may do better; it says how far apart
the known plays are::

    python benchmarks/attacker_ceiling.py --cells 6v2 --episodes 200 \\
        --json benchmarks/results/attacker_ceiling_6v2.json
"""

from __future__ import annotations

import argparse
import sys
from typing import NamedTuple

import numpy as np
from result_file import write_result

from policies.registry import PolicySpec, make_policy
from policies.tubes import tube_1v1, tube_2v1
from reachavoid.evaluation import run_episodes
from reachavoid_env import GameState, Scenario, builtin_scenario, parallel_env

CELLS = {"1v1": ("paper_1v1", 1, 1), "2v1": ("paper_2v1", 2, 1), "6v2": ("paper_6v2", 6, 2)}
"""Cell name: (built-in scenario, attackers, defenders)."""
TEAMS = ("shortest-path", "hj", "hj-pairs", "straight")


class Oracle(NamedTuple):
    """What the oracle tubes say of one start."""

    team_wins: bool     # the attackers' side wins the cell's game (1 vs 1 or 2 vs 1)
    solo_wins: int      # how many attackers win their 1 vs 1 game against the defender alone


def oracle(state: GameState, scenario: Scenario, grid1: int, grid2: int) -> Oracle:
    """The oracle's verdict on ``state`` (one defender) at ``grid1``^4 / ``grid2``^6."""
    defender = state.defender_positions[0]
    vf11 = tube_1v1(scenario, grid1, progress=False)
    solo = sum(bool(vf11.attacker_wins(np.concatenate([a, defender])[None])[0])
               for a in state.attacker_positions)
    if len(state.attacker_positions) == 1:
        return Oracle(solo == 1, solo)
    _, vf21 = tube_2v1(scenario, grid1, grid2, progress=False)
    joint = np.concatenate([*state.attacker_positions, defender])[None]
    return Oracle(bool(vf21.attacker_wins(joint)[0]), solo)


def starts(scenario: Scenario, episodes: int) -> list[GameState]:
    """The first state of episodes ``reset(seed=k)``, k < ``episodes``."""
    env = parallel_env(scenario=scenario)
    states = []
    for seed in range(episodes):
        env.reset(seed=seed)
        states.append(env.game_state())
    env.close()
    return states


def room(arrived: np.ndarray, verdicts: list[Oracle]) -> int:
    """Attackers the best possible team could add over ``arrived`` (per-start counts)."""
    extra = 0
    for count, verdict in zip(arrived, verdicts, strict=True):
        if verdict.team_wins:
            extra += max(0, max(1, verdict.solo_wins) - int(count))
    return extra


def cell(name: str, args: argparse.Namespace) -> dict[str, float | list[float]]:
    """The figures of one cell."""
    base, attackers, defenders = CELLS[name]
    scenario = builtin_scenario(base).with_players(attackers, defenders)
    figures: dict[str, float | list[float]] = {}
    verdicts = None
    if defenders == 1:
        verdicts = [oracle(state, scenario, args.oracle_grid1, args.oracle_grid2)
                    for state in starts(scenario, args.episodes)]
        wins = np.array([v.team_wins for v in verdicts])
        figures[f"winnable_percent.{name}"] = 100.0 * wins.mean()
        figures[f"cooperative_starts.{name}"] = int(sum(v.team_wins and v.solo_wins == 0
                                                        for v in verdicts))
    best = np.zeros(args.episodes, dtype=np.int64)
    env = parallel_env(scenario=scenario)
    defender = make_policy("defenders", "hj", scenario, grid1=args.grid1, grid2=args.grid2)
    for team in TEAMS:
        choice = PolicySpec("attackers", team).choice
        options = {flag: getattr(args, flag) for flag in ("grid1", "grid2") if choice.takes(flag)}
        results = run_episodes(env, make_policy("attackers", team, scenario, **options),
                               defender, args.episodes, progress=sys.stderr.isatty(),
                               description=team)
        arrived = np.array([len(r.arrived) for r in results])
        best = np.maximum(best, arrived)
        figures[f"arrival_percent.{name}.{team}"] = 100.0 * arrived.mean() / attackers
        if verdicts is None:
            continue
        figures[f"arrived_in_lost_starts.{name}.{team}"] = int(arrived[~wins].sum())
        figures[f"missed_in_winnable_starts.{name}.{team}"] = room(arrived, verdicts)
        if team == "shortest-path":
            figures[f"room_points.{name}"] = (100.0 * room(arrived, verdicts)
                                              / (attackers * args.episodes))
    figures[f"best_of_teams_percent.{name}"] = 100.0 * best.mean() / attackers
    env.close()
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cells", default="1v1,2v1", help="comma-separated: 1v1, 2v1, 6v2")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--grid1", type=int, default=31, help="the defenders' 1 vs 1 grid")
    parser.add_argument("--grid2", type=int, default=15, help="the defenders' 2 vs 1 grid")
    parser.add_argument("--oracle-grid1", type=int, default=45)
    parser.add_argument("--oracle-grid2", type=int, default=30)
    parser.add_argument("--json", default=None, help="write the result record here")
    args = parser.parse_args()
    figures: dict[str, float | list[float]] = {}
    for name in args.cells.split(","):
        figures |= cell(name, args)
    for key, value in figures.items():
        print(f"{key}: {value:.1f}" if isinstance(value, float) else f"{key}: {value}")
    if args.json:
        write_result(args.json, "attacker_ceiling", figures, units={
            "winnable_percent": "percent of the random starts whose game (1 vs 1, or 2 vs 1: "
                                "the defender wins by capturing both) the attackers win, by "
                                "the oracle tubes (the paper's grids)",
            "cooperative_starts": "2 vs 1 starts the pair wins though neither attacker wins "
                                  "its 1 vs 1 game alone",
            "arrival_percent": "percent of attackers that arrive, per scripted team, against "
                               "hj on the defenders' tubes",
            "arrived_in_lost_starts": "attackers that arrived in starts the oracle calls lost",
            "missed_in_winnable_starts": "attackers short of the oracle's best in the starts "
                                         "it calls winnable (one per start the pair wins, "
                                         "each attacker that wins alone)",
            "room_points": "missed_in_winnable_starts of shortest-path in percentage points "
                           "of arrival: at most this much can any attacker add over the "
                           "script against defenders that do not err",
            "best_of_teams_percent": "percent of attackers that arrive when each start is "
                                     "played by the scripted team that did best on it, "
                                     "chosen after the fact (biased upward; not a bound)"})


if __name__ == "__main__":
    main()

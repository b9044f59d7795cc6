"""The paper's Table I, its videos and its tube figure (Fig. 2), from the built-in scenarios.

The games are the built-ins that carry a ``[paper]`` table (what the paper reports for
them: ``captured = {method = count}``, methods named as in ``policies.registry``: ``paper``
is the paper's Algorithm 1, ``matching`` its baseline). Every method plays its game once
against the paper's shortest-path attackers, with unassigned or unmatched defenders
standing still as in the paper's simulations, and the tubes read as the paper reads them
(``margin_cells=0``: every value > 0 a defender win). The figure
slices the tubes at the starts of the smallest such game (``paper_2v1``: one defender, two
attackers).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import reachavoid_env
from policies.registry import make_policy, policy_specs
from policies.tubes import tube_2v1
from reachavoid.rollout import episode_title, run_episode
from reachavoid_env import Scenario
from reachavoid_env.files import write_json
from solvers.hj.plot import scenario_panels, tube_figure

ATTACKERS = "shortest-path"
"""The paper's attackers: the time-optimal path to the target, ignoring defenders."""


def paper_scenarios() -> list[Scenario]:
    """The built-in scenarios the paper reports on, smallest first."""
    scenarios = [reachavoid_env.builtin_scenario(name) for name in reachavoid_env.builtin_names()]
    reported = [sc for sc in scenarios if sc.paper_captures]
    return sorted(reported, key=lambda sc: (sc.num_attackers, sc.num_defenders))


@dataclass(frozen=True)
class PaperRow:
    """One game: per method, what the paper reports and what we measured (``run_episode``'s
    JSON fields plus ``video``)."""

    scenario: str
    reported: dict[str, int]
    measured: dict[str, dict[str, Any]]


def outputs(out: Path, videos: bool = True) -> list[Path]:
    """The files ``reproduce`` writes into ``out``."""
    names = [_video_name(sc.name, method) for sc in paper_scenarios()
             for method in dict(sc.paper_captures)] if videos else []
    return [out / name for name in (*names, "tubes.png", "table.json")]


def _video_name(scenario: str, method: str) -> str:
    return f"{scenario}_{method}.mp4"


def reproduce(out: Path, grid1: int, grid2: int, videos: bool = True,
              progress: bool = False) -> list[PaperRow]:
    """Play every paper game with every method it reports, write the videos (``out/NAME_
    METHOD.mp4``), ``out/tubes.png`` and ``out/table.json``; return the rows."""
    scenarios = paper_scenarios()
    options = {"grid1": grid1, "grid2": grid2, "unmatched": "stand", "margin_cells": 0.0}
    rows = []
    for scenario in scenarios:
        measured = {}
        methods = list(dict(scenario.paper_captures))
        for method, spec in zip(methods, policy_specs([("defenders", m) for m in methods],
                                                      options), strict=True):
            defenders = spec(scenario, progress=progress)
            attackers = make_policy("attackers", ATTACKERS, scenario)
            env = reachavoid_env.parallel_env(scenario=scenario,
                                              render_mode="rgb_array" if videos else None)
            video = out / _video_name(scenario.name, method) if videos else None
            try:
                result = run_episode(env, attackers, defenders, seed=0, video=video,
                                     title=episode_title(scenario.name, method, ATTACKERS, 0),
                                     progress=progress)
            finally:
                env.close()
            measured[method] = result.to_dict() | {"video": None if video is None
                                                   else str(video)}
        rows.append(PaperRow(scenario.name, dict(scenario.paper_captures), measured))
    figure_game = scenarios[0]
    vf11, vf21 = tube_2v1(figure_game, grid1, grid2, progress)
    attackers, defenders = figure_game.attackers, figure_game.defenders
    tube_figure(scenario_panels(vf11, attackers, defenders)[:1]
                + scenario_panels(vf21, attackers, defenders), out / "tubes.png")
    write_json(out / "table.json",
               {row.scenario: {"reported": row.reported, **row.measured} for row in rows})
    return rows

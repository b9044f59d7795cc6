"""A scenario's HJ tubes, loaded from the on-disk cache or solved once (with progress).

Each tube is read once per process (memory-mapped from the cache) and then shared by every
policy and env of the process that asks for it: a training env over a library of maps
loads each map's tubes the first time that map is played.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from reachavoid_env import GameMap, Scenario
from solvers.hj import (
    PAPER_GRIDS,
    ValueFunction,
    check_tubes_memory,
    solve_1v1,
    solve_1v2,
    solve_2v1,
)
from solvers.hj.cache import cache_dir


def check_memory(scenario: Scenario, grid1: int = PAPER_GRIDS.grid1,
                 grid2: int | None = PAPER_GRIDS.grid2) -> None:
    """``InsufficientMemoryError`` before any solve when a tube on these grids cannot fit."""
    check_tubes_memory(scenario.map, (scenario.attacker_speed, scenario.defender_speed),
                       scenario.capture_radius, grid1, grid2)


class TubeKey(NamedTuple):
    """What identifies a loaded tube: the cache folder, the game and its grids (``grid2``
    is 0 for the 1 vs 1 game) and the scenario's map, speeds and capture radius."""

    cache: str
    game: str
    grid1: int
    grid2: int
    map: GameMap
    attacker_speed: float
    defender_speed: float
    capture_radius: float


_LOADED: dict[TubeKey, ValueFunction] = {}


def _once(scenario: Scenario, game: str, grid1: int, grid2: int,
          load: Callable[[], ValueFunction]) -> ValueFunction:
    """``load()`` the first time this process asks for this tube (in this cache folder)."""
    key = TubeKey(str(cache_dir()), game, grid1, grid2, scenario.map, scenario.attacker_speed,
                  scenario.defender_speed, scenario.capture_radius)
    if key not in _LOADED:
        _LOADED[key] = load()
    return _LOADED[key]


def loaded_tubes(scenario: Scenario) -> dict[TubeKey, ValueFunction]:
    """The tubes of ``scenario``'s game (map, speeds, capture radius) this process loaded
    from the current cache folder."""
    wanted = (str(cache_dir()), scenario.map, scenario.attacker_speed, scenario.defender_speed,
              scenario.capture_radius)
    return {key: vf for key, vf in _LOADED.items()
            if (key.cache, key.map, key.attacker_speed, key.defender_speed,
                key.capture_radius) == wanted}


def tube_1v1(scenario: Scenario, grid1: int = PAPER_GRIDS.grid1,
             progress: bool = True) -> ValueFunction:
    """The 1 vs 1 value of the scenario's map, speeds and capture radius on ``grid1``^4."""
    return _once(scenario, "1v1", grid1, 0, lambda: solve_1v1(
        scenario.map, speeds=(scenario.attacker_speed, scenario.defender_speed),
        capture_radius=scenario.capture_radius, grid_points=grid1, progress=progress))


def tube_2v1(scenario: Scenario, grid1: int = PAPER_GRIDS.grid1, grid2: int = PAPER_GRIDS.grid2,
             progress: bool = True) -> tuple[ValueFunction, ValueFunction]:
    """The 1 vs 1 value on ``grid1``^4 and the 2 vs 1 value built on it, on ``grid2``^6."""
    check_memory(scenario, grid1, grid2)
    vf11 = tube_1v1(scenario, grid1, progress)
    return vf11, _once(scenario, "2v1", grid1, grid2, lambda: solve_2v1(
        scenario.map, vf11, grid_points=grid2, progress=progress))


def tube_1v2(scenario: Scenario, grid1: int = PAPER_GRIDS.grid1, grid2: int = PAPER_GRIDS.grid2,
             progress: bool = True) -> ValueFunction:
    """The 1 vs 2 value (one attacker, two defenders) on ``grid2``^6, built on the 1 vs 1
    value on ``grid1``^4."""
    check_memory(scenario, grid1, grid2)
    vf11 = tube_1v1(scenario, grid1, progress)
    return _once(scenario, "1v2", grid1, grid2, lambda: solve_1v2(
        scenario.map, vf11, grid_points=grid2, progress=progress))


def check_tube(vf: ValueFunction, scenario: Scenario, name: str) -> None:
    """Refuse a tube solved for another map, other speeds or another capture radius."""
    mismatches = [
        field for field, ours, theirs in (
            ("attacker_speed", scenario.attacker_speed, vf.attacker_speed),
            ("defender_speed", scenario.defender_speed, vf.defender_speed),
            ("capture_radius", scenario.capture_radius, vf.capture_radius),
        ) if not np.isclose(ours, theirs)
    ]
    if vf.game_map.to_dict() != scenario.map.to_dict():
        mismatches.append("map")
    if mismatches:
        raise ValueError(f"{name}: the value function was solved for another game "
                         f"(differs in {', '.join(mismatches)}) than scenario {scenario.name!r}")

"""A scenario's HJ tubes, loaded from the on-disk cache or solved once (with progress)."""

from __future__ import annotations

from reachavoid_env import Scenario
from solvers.hj import (
    PAPER_GRIDS,
    ValueFunction,
    check_tubes_memory,
    solve_1v1,
    solve_1v2,
    solve_2v1,
)


def check_memory(scenario: Scenario, grid1: int = PAPER_GRIDS.grid1,
                 grid2: int | None = PAPER_GRIDS.grid2) -> None:
    """``InsufficientMemoryError`` before any solve when a tube on these grids cannot fit."""
    check_tubes_memory(scenario.map, (scenario.attacker_speed, scenario.defender_speed),
                       scenario.capture_radius, grid1, grid2)


def tube_1v1(scenario: Scenario, grid1: int = PAPER_GRIDS.grid1,
             progress: bool = True) -> ValueFunction:
    """The 1 vs 1 value of the scenario's map, speeds and capture radius on ``grid1``^4."""
    return solve_1v1(scenario.map, speeds=(scenario.attacker_speed, scenario.defender_speed),
                     capture_radius=scenario.capture_radius, grid_points=grid1,
                     progress=progress)


def tube_2v1(scenario: Scenario, grid1: int = PAPER_GRIDS.grid1, grid2: int = PAPER_GRIDS.grid2,
             progress: bool = True) -> tuple[ValueFunction, ValueFunction]:
    """The 1 vs 1 value on ``grid1``^4 and the 2 vs 1 value built on it, on ``grid2``^6."""
    check_memory(scenario, grid1, grid2)
    vf11 = tube_1v1(scenario, grid1, progress)
    return vf11, solve_2v1(scenario.map, vf11, grid_points=grid2, progress=progress)


def tube_1v2(scenario: Scenario, grid1: int = PAPER_GRIDS.grid1, grid2: int = PAPER_GRIDS.grid2,
             progress: bool = True) -> ValueFunction:
    """The 1 vs 2 value (one attacker, two defenders) on ``grid2``^6, built on the 1 vs 1
    value on ``grid1``^4."""
    check_memory(scenario, grid1, grid2)
    return solve_1v2(scenario.map, tube_1v1(scenario, grid1, progress), grid_points=grid2,
                     progress=progress)

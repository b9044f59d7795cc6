"""Hamilton-Jacobi reach-avoid solvers (numba) for games declared as players, target and
avoid functions and symmetries (``game``); the paper's 1 vs 1 and 2 vs 1, and 1 vs 2,
in ``games``."""

from solvers.hj.game import Game, Player, attacker, defender, distance, maximum, minimum, table
from solvers.hj.games import (
    check_tubes_memory,
    game_1v1,
    game_1v2,
    game_2v1,
    solve_1v1,
    solve_1v2,
    solve_2v1,
)
from solvers.hj.grid import Grid
from solvers.hj.reach_avoid import InsufficientMemoryError, SolveResult
from solvers.hj.schemes import ENO2, GODUNOV, LAX_FRIEDRICHS, Scheme
from solvers.hj.settings import SOLVER_VERSION, SolverSettings
from solvers.hj.solve import solve_declared
from solvers.hj.value import (
    OutputPathError,
    ValueFunction,
    ValueFunctionError,
    load_value_function,
)

__all__ = [
    "check_tubes_memory",
    "ENO2",
    "GODUNOV",
    "LAX_FRIEDRICHS",
    "SOLVER_VERSION",
    "Game",
    "Grid",
    "InsufficientMemoryError",
    "OutputPathError",
    "Player",
    "Scheme",
    "SolveResult",
    "SolverSettings",
    "ValueFunction",
    "ValueFunctionError",
    "attacker",
    "defender",
    "distance",
    "game_1v1",
    "game_1v2",
    "game_2v1",
    "load_value_function",
    "maximum",
    "minimum",
    "solve_1v1",
    "solve_1v2",
    "solve_2v1",
    "solve_declared",
    "table",
]

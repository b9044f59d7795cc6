"""Hamilton-Jacobi reach-avoid solvers for the 1 vs 1 and 2 vs 1 games (numba)."""

from solvers.hj.games import SolveReport, solve_1v1, solve_2v1, solve_game
from solvers.hj.grid import Grid
from solvers.hj.reach_avoid import InsufficientMemoryError, SolveResult
from solvers.hj.settings import SolverSettings
from solvers.hj.value import ValueFunction, ValueFunctionError, load_value_function

__all__ = [
    "Grid",
    "InsufficientMemoryError",
    "SolveReport",
    "SolveResult",
    "SolverSettings",
    "ValueFunction",
    "ValueFunctionError",
    "load_value_function",
    "solve_1v1",
    "solve_2v1",
    "solve_game",
]

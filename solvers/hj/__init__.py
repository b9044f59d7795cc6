"""Hamilton-Jacobi reach-avoid solvers (numba) for games declared as players, target and
avoid functions and symmetries (``game``); the paper's 1 vs 1 and 2 vs 1, and 1 vs 2,
in ``games``.

The settings and schemes load with the package; the declarations, the solver, grids and
values (numpy, and numba when a tube is touched) load on first use (PEP 562).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from reachavoid_env import lazy
from solvers.hj.schemes import ENO2, GODUNOV, LAX_FRIEDRICHS, Scheme
from solvers.hj.settings import PAPER_GRIDS, SOLVER_VERSION, TRAINING_GRIDS, SolverSettings

if TYPE_CHECKING:
    from solvers.hj.game import (
        Game,
        Player,
        attacker,
        defender,
        distance,
        maximum,
        minimum,
        table,
    )
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
    "PAPER_GRIDS",
    "SOLVER_VERSION",
    "TRAINING_GRIDS",
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

__getattr__, __dir__ = lazy.attributes(__name__, {
    **dict.fromkeys(["Game", "Player", "attacker", "defender", "distance", "maximum", "minimum",
                     "table"], "solvers.hj.game"),
    **dict.fromkeys(["check_tubes_memory", "game_1v1", "game_1v2", "game_2v1", "solve_1v1",
                     "solve_1v2", "solve_2v1"], "solvers.hj.games"),
    "Grid": "solvers.hj.grid",
    "InsufficientMemoryError": "solvers.hj.reach_avoid", "SolveResult": "solvers.hj.reach_avoid",
    "solve_declared": "solvers.hj.solve",
    **dict.fromkeys(["OutputPathError", "ValueFunction", "ValueFunctionError",
                     "load_value_function"], "solvers.hj.value"),
})

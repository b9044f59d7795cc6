"""Numerical settings of the HJ reach-avoid solver, composed in one frozen dataclass."""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import Any, Literal, NamedTuple

from solvers.hj.schemes import GODUNOV, Scheme, scheme_named

SOLVER_VERSION = "3"
"""Bumped whenever a change can alter solved values or files; part of every cache key and
checked when a value file is loaded (files of another version are solved again)."""



class Grids(NamedTuple):
    """Nodes per axis of a scenario's tubes: ``grid1`` for the 1 vs 1 game (``grid1^4``
    nodes), ``grid2`` for the 2 vs 1 and 1 vs 2 games (``grid2^6``)."""

    grid1: int
    grid2: int


PAPER_GRIDS = Grids(45, 30)
"""The paper's grids: the defaults of every solve, tube and command."""
TRAINING_GRIDS = Grids(31, 15)
"""Coarser grids for training attackers against the HJ defenders (many envs, fast starts)."""

Iteration = Literal["red_black", "jacobi"]
Accuracy = Literal["low", "medium", "high"]

_ITERATIONS = ("red_black", "jacobi")


@dataclass(frozen=True)
class SolverSettings:
    """How the reach-avoid variational inequality is discretised and marched.

    - ``scheme``: the numerical Hamiltonian (``schemes``: ``"godunov"``, the default,
      upwinds each player separately; ``"lax_friedrichs"`` is central differences plus
      dissipation ``alpha = speed`` per axis, the paper's OptimizedDP scheme; ``"eno2"``
      is second order). A name or a ``Scheme``.
    - ``iteration``: ``"red_black"`` (Gauss-Seidel) updates the value array in place, the
      rows of one colour at a time (``layout.Layout.colours``: one value array in memory);
      ``"jacobi"`` computes every iteration from the previous one (two arrays).
    - ``cfl``: fraction of the scheme's largest stable time step, in (0, 1].
    - ``tolerance``: convergence when the largest change of the value over one unit of game
      time, on the grid nodes next to the zero level set, falls below this (value units per
      second; values are map units).
    - ``max_iterations``: give up (``converged=False``) after this many iterations.
    - ``exchange_symmetry``: store and solve one ordering of the game's exchangeable players
      (``Game.symmetries``) and read the others by index mapping; exact, halves the memory
      and work of 2 vs 1.
    - ``warm_start``: start a grid of ``n`` nodes per axis from the solve on
      ``(n + 1) // 2`` nodes (itself warm-started the same way, down to ``warm_from``
      nodes), interpolated, plus ``warm_margin`` map units (``reach_avoid``).
    - ``clip_start``: clip the start at the proved bound of the value where the attackers
      can reach the target (``start``: the capture radius in the paper's games; Godunov
      only); the same fixed point, in fewer sweeps where the defender-win region's
      settling sets the count (BENCHMARKS.md: 1 vs 1 25^4 -24%, 45^4 -7%; 2 vs 1 20^6
      unchanged).
    """

    scheme: Scheme = GODUNOV
    iteration: Iteration = "red_black"
    cfl: float = 0.95
    tolerance: float = 5e-3
    max_iterations: int = 20_000
    exchange_symmetry: bool = True
    warm_start: bool = False
    warm_from: int = 12
    warm_margin: float = 0.1
    clip_start: bool = True

    def __post_init__(self) -> None:
        object.__setattr__(self, "scheme", scheme_named(self.scheme))
        if self.iteration not in _ITERATIONS:
            raise ValueError(f"settings.iteration: expected one of {_ITERATIONS}, got "
                             f"{self.iteration!r}")
        if not 0.0 < self.cfl <= 1.0:
            raise ValueError(f"settings.cfl: must lie in (0, 1] to keep the scheme monotone, "
                             f"got {self.cfl}")
        if not self.tolerance > 0.0:
            raise ValueError(f"settings.tolerance: must be positive, got {self.tolerance}")
        if self.max_iterations < 1:
            raise ValueError(f"settings.max_iterations: must be >= 1, got {self.max_iterations}")
        if self.warm_from < 3:
            raise ValueError(f"settings.warm_from: must be >= 3 nodes, got {self.warm_from}")
        if not self.warm_margin >= 0.0:
            raise ValueError(f"settings.warm_margin: must be >= 0, got {self.warm_margin}")

    @classmethod
    def with_accuracy(cls, level: Accuracy) -> SolverSettings:
        """Presets: ``"low"`` (quick looks), ``"medium"`` (default), ``"high"`` (references)."""
        presets = {
            "low": cls(tolerance=2e-2),
            "medium": cls(),
            "high": cls(tolerance=1e-4),
        }
        if level not in presets:
            raise ValueError(f"accuracy: expected one of {sorted(presets)}, got {level!r}")
        return presets[level]

    def replace(self, **changes: Any) -> SolverSettings:
        return replace(self, **changes)

    def coarse_points(self, points: tuple[int, ...]) -> tuple[int, ...] | None:
        """Node counts of the warm start's coarse grid, or ``None`` for a cold start."""
        if not self.warm_start:
            return None
        coarse = tuple((n + 1) // 2 for n in points)
        return coarse if min(coarse) >= self.warm_from else None

    def to_dict(self) -> dict[str, Any]:
        """Every field by name, in declared order, the scheme by its name (JSON-ready; the
        cache key of a solve lists these values, so a new field keys its own entries)."""
        return asdict(self) | {"scheme": self.scheme.name}

"""Numerical settings of the HJ reach-avoid solver, composed in one frozen dataclass."""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import Any, Literal

SOLVER_VERSION = "1"
"""Bumped whenever a change can alter solved values; part of every cache key."""

Scheme = Literal["godunov", "lax_friedrichs"]
Iteration = Literal["red_black", "jacobi"]
Accuracy = Literal["low", "medium", "high"]

_SCHEMES = ("godunov", "lax_friedrichs")
_ITERATIONS = ("red_black", "jacobi")


@dataclass(frozen=True)
class SolverSettings:
    """How the reach-avoid variational inequality is discretised and marched.

    - ``scheme``: the monotone first-order numerical Hamiltonian. ``"godunov"`` upwinds
      each player separately (the exact min-max of the one-step dynamic programme on the
      grid); ``"lax_friedrichs"`` is central differences plus dissipation ``alpha = speed``
      per axis (the paper's OptimizedDP scheme, more diffusive and a smaller time step).
    - ``iteration``: ``"red_black"`` (Gauss-Seidel) updates the value array in place, the
      rows of one parity of the attacker node indices, then the other (one value array in
      memory); ``"jacobi"`` computes every sweep from the previous one (two arrays). Both
      are monotone, need about as many sweeps and converge to the same fixed point.
    - ``cfl``: fraction of the largest time step that keeps the scheme monotone, in (0, 1].
    - ``tolerance``: convergence when the largest change of the value over one unit of game
      time, on the grid nodes next to the zero level set, falls below this (value units per
      second; values are map units).
    - ``max_iterations``: give up (``converged=False``) after this many sweeps.
    - ``exchange_symmetry``: 2 vs 1 only; solve the half of the state space with
      ``A1 >= A2`` (flat grid index) and read the other half through
      ``V(a1, a2, d) = V(a2, a1, d)``; exact, halves the work.
    """

    scheme: Scheme = "godunov"
    iteration: Iteration = "red_black"
    cfl: float = 0.95
    tolerance: float = 5e-3
    max_iterations: int = 20_000
    exchange_symmetry: bool = True

    def __post_init__(self) -> None:
        if self.scheme not in _SCHEMES:
            raise ValueError(f"settings.scheme: expected one of {_SCHEMES}, got {self.scheme!r}")
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

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

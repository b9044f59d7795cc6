"""Upwind schemes: the numerical Hamiltonian as a strategy of ``SolverSettings``.

A scheme names its two kernel pieces (``kernels``: the term of the player whose plane is a
row, and the term of a player across rows), how many nodes deep its stencil reaches
(``width``; the row layout's colouring and neighbour tables follow from it) and the
largest monotone time step. The solve loop and the generated iteration (``codegen``) read
only these fields, so a new scheme is one instance here and two pieces in ``kernels``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class Scheme:
    """``name`` (recorded in value files), kernel pieces ``in_row`` and ``across`` (names
    in ``kernels``), stencil ``width`` (nodes each side), ``order`` of accuracy, and
    ``step_factor``: the fraction of the first-order monotone step it is stable at."""

    name: str
    in_row: str
    across: str
    width: int
    order: int
    central: bool = False
    step_factor: float = 1.0

    def time_step(self, players: Sequence[tuple[float, float, float]], cfl: float) -> float:
        """The time step (seconds) for players ``(speed, hx, hy)`` at ``cfl`` in (0, 1].

        Godunov upwinding is monotone while ``dt sum_players v sqrt(hx^-2 + hy^-2) <= 1``;
        Lax-Friedrichs with dissipation ``alpha = v`` per axis while
        ``dt sum_players v (1/hx + 1/hy) <= 1``.
        """
        if self.central:
            rate = sum(v * (1 / hx + 1 / hy) for v, hx, hy in players)
        else:
            rate = sum(v * math.hypot(1 / hx, 1 / hy) for v, hx, hy in players)
        return cfl * self.step_factor / rate


GODUNOV = Scheme("godunov", "godunov_in_row", "godunov_across", width=1, order=1)
LAX_FRIEDRICHS = Scheme("lax_friedrichs", "lax_friedrichs_in_row", "lax_friedrichs_across",
                        width=1, order=1, central=True)
ENO2 = Scheme("eno2", "eno2_in_row", "eno2_across", width=2, order=2, step_factor=0.5)
"""Second-order ENO with Godunov upwinding; forward Euler is stable for it at about half
the first-order step (not monotone: its fixed point is reached, not approached from
above)."""

SCHEMES = {s.name: s for s in (GODUNOV, LAX_FRIEDRICHS, ENO2)}


def scheme_named(name: str | Scheme) -> Scheme:
    if isinstance(name, Scheme):
        return name
    if name not in SCHEMES:
        raise ValueError(f"settings.scheme: expected one of {tuple(SCHEMES)}, got {name!r}")
    return SCHEMES[name]

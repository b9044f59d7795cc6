"""Row layout of a game's value array: rows, stored rows under symmetry, colouring.

Axis order is the game's player order. The last player's plane is a row of ``m = nx * ny``
contiguous elements; each configuration of the other players (the row players, node
indices in C order) is a row. With exchange symmetry (``Game.symmetries``, groups of row
players) a configuration and its exchanges hold the same values, so only the canonical
one, the node indices of each group in non-increasing order, is stored: ``stored_of``
maps every configuration to the stored row, ``row_nodes`` lists each stored row's node
indices. Queries of any configuration read the stored row (index mapping only).

A group that contains the last player cannot be stored by rows and is solved in full.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from solvers.hj.game import Game
from solvers.hj.grid import Grid


@dataclass(frozen=True, eq=False)
class Layout:
    """``row_nodes`` ``(stored rows, P)``, ``row_shape`` ``(P, 2)``, ``row_stride`` ``(P,)``
    (row number strides), ``stored_of`` ``(rows,)``: all int64. ``groups``: the symmetry
    groups the storage uses (player indices)."""

    grid: Grid
    row_nodes: np.ndarray
    row_shape: np.ndarray
    row_stride: np.ndarray
    stored_of: np.ndarray
    groups: tuple[tuple[int, ...], ...]

    @property
    def stored_rows(self) -> int:
        return int(self.row_nodes.shape[0])

    @property
    def row_length(self) -> int:
        return self.grid.shape[-2] * self.grid.shape[-1]

    @property
    def stored_shape(self) -> tuple[int, int]:
        return self.stored_rows, self.row_length

    @property
    def stored_fraction(self) -> float:
        return self.stored_rows / self.stored_of.size

    def colours(self, width: int) -> np.ndarray:
        """Colour of each stored row, ``0..width``: the sum of the row players' node indices
        modulo ``width + 1``. Stencil neighbours (``1..width`` nodes along one axis) never
        share a colour, and exchanging players keeps the sum, so neither do their stored
        twins: the rows of one colour may be updated in place in any order."""
        ny = self.row_shape[:, 1]
        index_sum = (self.row_nodes // ny + self.row_nodes % ny).sum(axis=1)
        return index_sum % (width + 1)

    def full(self, stored: np.ndarray) -> np.ndarray:
        """The value on the whole grid from its stored rows (small grids)."""
        return np.asarray(stored)[self.stored_of].reshape(self.grid.shape)


def layout_of(grid: Grid, groups: tuple[tuple[int, ...], ...] = ()) -> Layout:
    """The row layout on ``grid`` (``ndim / 2`` planar players) storing one ordering of each
    group of exchangeable players (indices in axis order; groups with the last player are
    ignored: module docstring)."""
    players = grid.ndim // 2 - 1
    row_shape = np.array([grid.shape[2 * k:2 * k + 2] for k in range(players)], dtype=np.int64)
    counts = row_shape.prod(axis=1)
    row_stride = np.ones(players, dtype=np.int64)
    for k in range(players - 2, -1, -1):
        row_stride[k] = row_stride[k + 1] * counts[k + 1]
    groups = tuple(tuple(g) for g in groups if max(g) < players)
    for group in groups:
        if len({grid.sub((2 * k, 2 * k + 1)) for k in group}) != 1:
            raise ValueError(f"grid: exchangeable players {group} need the same planar grid")
    rows = int(counts.prod())
    nodes = np.stack(np.unravel_index(np.arange(rows, dtype=np.int64), tuple(counts)), axis=1)
    canonical = nodes.copy()
    for group in groups:
        canonical[:, group] = -np.sort(-nodes[:, group], axis=1)
    canonical_row = canonical @ row_stride
    stored = canonical_row == np.arange(rows)
    position = np.cumsum(stored) - 1
    stored_of = position[canonical_row].astype(np.int64)
    return Layout(grid=grid, row_nodes=np.ascontiguousarray(nodes[stored]), row_shape=row_shape,
                  row_stride=row_stride, stored_of=stored_of, groups=groups)


def stored_groups(game: Game, use_symmetry: bool) -> tuple[tuple[int, ...], ...]:
    """The symmetry groups of ``game`` (player indices) that row storage can use."""
    if not use_symmetry:
        return ()
    last = len(game.players) - 1
    groups = tuple(tuple(game.index(n) for n in g) for g in game.symmetries)
    return tuple(g for g in groups if last not in g)

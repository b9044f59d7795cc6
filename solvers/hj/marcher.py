"""A game on a grid made ready to march: the ``Problem`` (the game, its grid and tables), the
rows of one iteration (``iteration_orders``) and the generated kernels (``Marcher``).

``reach_avoid`` runs the loop over a ``Marcher``; ``start`` bounds its start.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from reachavoid_env import GameMap, ScenarioError
from solvers.hj import geometry
from solvers.hj.codegen import TableSpec, compile_kernel
from solvers.hj.game import PLANAR_TABLES, Coordinate, Expr, Game, Op, Table, evaluate
from solvers.hj.grid import Grid
from solvers.hj.layout import Layout, layout_of, stored_groups
from solvers.hj.settings import SolverSettings


@dataclass(frozen=True, eq=False)
class Problem:
    """A game on a grid with its tables: ``planar[name][player]`` (``PLANAR_TABLES``,
    ``(nx, ny)`` float over the player's grid) and ``extra[name]`` (the game's pair tables,
    ``(nx_p, ny_p, nx_q, ny_q)``, e.g. a lower game's value). Grid axes: the game's."""

    game: Game
    grid: Grid
    planar: Mapping[str, Mapping[str, np.ndarray]]
    extra: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.grid.ndim != 2 * len(self.game.players):
            raise ValueError(f"grid: the {self.game.name} game needs {2 * len(self.game.players)}"
                             f" axes, got {self.grid.ndim}")
        for name, over in self.game.tables().items():
            if name not in self.extra:
                raise ValueError(f"tables: the {self.game.name} game reads {name!r}, not given")
            shape = sum((self.plane(k).shape for k in over), ())
            if tuple(self.extra[name].shape) != shape:
                raise ValueError(f"tables.{name}: expected shape {shape}, got "
                                 f"{tuple(self.extra[name].shape)}")

    def plane(self, player: int | str) -> Grid:
        k = player if isinstance(player, int) else self.game.index(player)
        return self.grid.sub((2 * k, 2 * k + 1))

    def evaluate(self, expr: Expr, span: tuple[str, ...]) -> np.ndarray:
        """``expr`` over the grids of ``span`` (player names in axis order), float64, shape
        the concatenation of their planar shapes."""
        shapes = [self.plane(p).shape for p in span]
        ndim = 2 * len(span)

        def place(array: np.ndarray, players: tuple[str, ...]) -> np.ndarray:
            order = sorted(range(len(players)), key=lambda i: span.index(players[i]))
            axes = [a for i in order for a in (2 * i, 2 * i + 1)]
            array = np.transpose(array, axes)
            shape = [1] * ndim
            for i in order:
                k = span.index(players[i])
                shape[2 * k:2 * k + 2] = shapes[k]
            return array.reshape(shape)

        def lookup(leaf: Expr) -> np.ndarray:
            if isinstance(leaf, Coordinate):
                coords = self.plane(leaf.player).mesh()[..., leaf.axis]
                return place(coords, (leaf.player,))
            assert isinstance(leaf, Table)
            if leaf.name in PLANAR_TABLES:
                return place(self.planar[leaf.name][leaf.over[0]], leaf.over)
            return place(self.extra[leaf.name], leaf.over)

        return np.broadcast_to(evaluate(expr, lookup=lookup), sum(shapes, ()))

    def sets(self) -> tuple[np.ndarray, np.ndarray]:
        """Full target and avoid arrays ``l``, ``g`` (float64, small grids: the reference)."""
        span = tuple(p.name for p in self.game.players)
        return self.evaluate(self.game.target, span), self.evaluate(self.game.avoid, span)


def map_problem(game: Game, game_map, grid: Grid,
                extra: Mapping[str, np.ndarray] | None = None) -> Problem:
    """``game`` on ``game_map`` (a ``GameMap``): the planar tables from the map's shapes.

    ``ScenarioError`` (a ``ValueError``) when no free node of a player's plane lies in the
    target: the grid cannot see the target, and its tube would say nobody ever arrives."""
    planes = {p.name: grid.sub((2 * k, 2 * k + 1)) for k, p in enumerate(game.players)}
    planar = {"target": {n: geometry.target_distance(game_map, g) for n, g in planes.items()},
              "free": {n: geometry.free_distance(game_map, g) for n, g in planes.items()}}
    for plane in {(g.lo, g.hi, g.shape): g for g in planes.values()}.values():
        check_target_seen(game_map, plane, game.name)
    return Problem(game=game, grid=grid, planar=planar, extra=dict(extra or {}))


def check_target_seen(game_map: GameMap, plane: Grid, label: str) -> None:
    """``ScenarioError`` (a ``ValueError``) unless a free node of the planar grid ``plane``
    lies in the target of ``game_map``: a grid that cannot see the target solves a tube in
    which nobody ever arrives (the defender "wins" everywhere)."""
    inside = geometry.target_distance(game_map, plane) <= 0
    if not np.any(inside & (geometry.free_distance(game_map, plane) > 0)):
        spacing = ", ".join(f"{h:.3g}" for h in plane.spacing)
        raise ScenarioError(f"map.target: no free grid node lies in the target on the {label} "
                            f"grid ({'x'.join(map(str, plane.shape))} nodes, spacing "
                            f"{spacing}); use a finer grid or a larger target",
                            field="map.target")


def _fill_tables(problem: Problem, specs: tuple[TableSpec, ...]) -> tuple[np.ndarray, ...]:
    """The kernel's arrays, float32, shaped ``(row-player nodes..., m)``; a table equal to
    another up to its row player (the same expression on the same grids) is filled once."""
    game = problem.game
    last = game.players[-1].name
    done: dict[tuple, np.ndarray] = {}
    arrays = []
    for spec in specs:
        row_players = [p for p in spec.span if p != last]
        key: tuple = (spec.expr, spec.span)
        if len(row_players) == 1 and isinstance(spec.expr, Op):
            player = row_players[0]
            key = (_renamed(spec.expr, player), problem.plane(player), problem.plane(last),
                   last in spec.span)
        if key not in done:
            values = problem.evaluate(spec.expr, spec.span)
            shape = [problem.plane(p).shape[0] * problem.plane(p).shape[1] for p in spec.span]
            done[key] = np.ascontiguousarray(values.reshape(shape), dtype=np.float32)
        arrays.append(done[key])
    return tuple(arrays)


def _renamed(expr: Expr, player: str) -> Expr:
    """``expr`` with ``player`` written as ``"_"`` (to recognise equal tables)."""
    if isinstance(expr, Coordinate) and expr.player == player:
        return Coordinate("_", expr.axis)
    if isinstance(expr, Table):
        return Table(expr.name, tuple("_" if p == player else p for p in expr.over))
    if isinstance(expr, Op):
        return Op(expr.kind, tuple(_renamed(a, player) for a in expr.args))
    return expr


class Order(NamedTuple):
    """One iteration's order: the stored ``rows`` (int64) in plane order, plane ``p`` being
    ``rows[planes[p]:planes[p + 1]]``, walked backwards when ``reverse``."""

    rows: np.ndarray
    planes: np.ndarray
    reverse: bool


def iteration_orders(layout: Layout, settings: SolverSettings) -> list[Order]:
    """The ``Order`` of successive iterations (``iteration.iterate``).

    Jacobi: all stored rows in one plane. Red-black: the rows of each colour
    (``Layout.colours``) form a plane, forwards and then backwards on the next iteration.
    """
    stored = np.arange(layout.stored_rows, dtype=np.int64)
    if settings.iteration == "jacobi":
        return [Order(stored, np.array([0, stored.size], dtype=np.int64), False)]
    colours = layout.colours(settings.scheme.width)
    rows = np.argsort(colours, kind="stable").astype(np.int64)
    counts = np.bincount(colours, minlength=settings.scheme.width + 1)
    planes = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    return [Order(rows, planes, False), Order(rows, planes, True)]


@dataclass(frozen=True, eq=False)
class Marcher:
    """A problem ready for the generated kernels: its layout, tables and kernel module."""

    problem: Problem
    settings: SolverSettings
    layout: Layout
    tables: tuple[np.ndarray, ...]
    module: object

    @classmethod
    def prepare(cls, problem: Problem, settings: SolverSettings) -> Marcher:
        kernel = compile_kernel(problem.game, settings.scheme)
        layout = layout_of(problem.grid, stored_groups(problem.game, settings.exchange_symmetry))
        return cls(problem, settings, layout, _fill_tables(problem, kernel.tables), kernel.module)

    def project(self, values: np.ndarray) -> None:
        """``values = max(min(values, l), g)`` on every stored row, in place."""
        rows = np.arange(self.layout.stored_rows, dtype=np.int64)
        self.module.project(values, rows, self.layout.row_nodes, self.tables)

    def iterate(self, values: np.ndarray, out: np.ndarray, order: Order, dt: float,
                n_chunks: int | None = None) -> float:
        """One iteration over ``order``'s rows (``iteration_orders``) from ``values`` into
        ``out`` (the same array: in place); returns the largest change near the zero level
        set."""
        import numba

        from solvers.hj import kernels

        game, grid = self.problem.game, self.problem.grid
        layout = self.layout
        row_layout = kernels.RowLayout(layout.row_nodes, layout.row_shape, layout.row_stride,
                                       layout.stored_of, np.int64(grid.shape[-1]))
        motion = kernels.Motion((1.0 / np.asarray(grid.spacing)).astype(np.float32),
                                np.array([p.speed for p in game.players], dtype=np.float32),
                                np.array([p.role == "defender" for p in game.players]))
        chunks = n_chunks or 4 * numba.get_num_threads()
        return float(self.module.iterate(values, out, order.rows, order.planes, order.reverse,
                                         row_layout, motion, np.float32(dt), self.tables,
                                         chunks))

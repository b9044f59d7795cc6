"""A reach-avoid game as a declaration: players in axis order, target and avoid functions.

A game lists its players in axis order; each is a planar position ``(x, y)`` on the map's
grid with a role (``"attacker"`` minimises the value, ``"defender"`` maximises it) and a
speed (map units per second; single integrator ``x' = speed * u``, ``|u| <= 1``). Its
target function ``l`` (<= 0: the attacker side has won) and avoid function ``g`` (> 0:
the attacker side has lost) are expressions written once per grid node from:

- ``player.target`` / ``player.free``: the map's signed distance to the target (negative
  inside) and to the obstacles and the domain's exterior (negative inside an obstacle) at
  the player's node (``geometry``), map units;
- ``player.x``, ``player.y``: the node's coordinates;
- ``table(name, p, q)``: a lower game's value over two players' grids (for example the
  1 vs 1 value inside 2 vs 1), supplied as an array when the game is solved;
- numbers, ``+``, ``-``, ``*``, ``minimum``, ``maximum``, ``distance``.

``symmetries`` are groups of players of one role, speed and grid that may be exchanged
without changing the value; the solver then stores one ordering of each group only.
Everything else (Hamiltonian, time step, memory, row layout, colouring, files, controls,
plots) is derived from this (``reach_avoid``, ``codegen``, ``layout``, ``value``).
The value is <= 0 exactly where the attacker side wins.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

Role = Literal["attacker", "defender"]
ROLES = ("attacker", "defender")
PLANAR_TABLES = ("target", "free")
"""Tables the solver computes itself for every player from the map (``geometry``)."""


class Expr:
    """A node of a target or avoid expression (immutable, hashable)."""

    def __add__(self, other: Expr | float) -> Expr:
        return Op("add", (self, _expr(other)))

    def __radd__(self, other: float) -> Expr:
        return Op("add", (_expr(other), self))

    def __sub__(self, other: Expr | float) -> Expr:
        return Op("sub", (self, _expr(other)))

    def __rsub__(self, other: float) -> Expr:
        return Op("sub", (_expr(other), self))

    def __mul__(self, other: Expr | float) -> Expr:
        return Op("mul", (self, _expr(other)))

    def __rmul__(self, other: float) -> Expr:
        return Op("mul", (_expr(other), self))

    def __neg__(self) -> Expr:
        return Op("neg", (self,))

    def players(self) -> frozenset[str]:
        """Names of the players this expression depends on."""
        raise NotImplementedError

    def children(self) -> tuple[Expr, ...]:
        return ()


@dataclass(frozen=True)
class Const(Expr):
    value: float

    def players(self) -> frozenset[str]:
        return frozenset()


@dataclass(frozen=True)
class Coordinate(Expr):
    """Coordinate ``axis`` (0: x, 1: y) of ``player``'s node, map units."""

    player: str
    axis: int

    def players(self) -> frozenset[str]:
        return frozenset((self.player,))


@dataclass(frozen=True)
class Table(Expr):
    """Table ``name`` at the nodes of ``players`` (one player: planar; two: a pair table)."""

    name: str
    over: tuple[str, ...]

    def players(self) -> frozenset[str]:
        return frozenset(self.over)


@dataclass(frozen=True)
class Op(Expr):
    """``kind`` in ``add sub mul neg min max sqrt`` applied to ``args``."""

    kind: str
    args: tuple[Expr, ...]

    def players(self) -> frozenset[str]:
        return frozenset().union(*(a.players() for a in self.args))

    def children(self) -> tuple[Expr, ...]:
        return self.args


def _expr(value: Expr | float) -> Expr:
    return value if isinstance(value, Expr) else Const(float(value))


def minimum(*args: Expr | float) -> Expr:
    return _fold("min", args)


def maximum(*args: Expr | float) -> Expr:
    return _fold("max", args)


def _fold(kind: str, args: Sequence[Expr | float]) -> Expr:
    if not args:
        raise ValueError(f"{kind}imum: needs at least one argument")
    result = _expr(args[0])
    for arg in args[1:]:
        result = Op(kind, (result, _expr(arg)))
    return result


def sqrt(arg: Expr) -> Expr:
    return Op("sqrt", (arg,))


@dataclass(frozen=True)
class Player:
    """One planar player: ``name`` (axes ``x<name>``, ``y<name>``), role, speed."""

    name: str
    role: Role
    speed: float

    def __post_init__(self) -> None:
        if self.role not in ROLES:
            raise ValueError(f"player {self.name}: role must be one of {ROLES}, got "
                             f"{self.role!r}")
        if not self.speed > 0:
            raise ValueError(f"player {self.name}: speed must be positive, got {self.speed}")

    @property
    def x(self) -> Expr:
        return Coordinate(self.name, 0)

    @property
    def y(self) -> Expr:
        return Coordinate(self.name, 1)

    @property
    def target(self) -> Expr:
        """Signed distance of the player's node to the map's target (negative inside)."""
        return Table("target", (self.name,))

    @property
    def free(self) -> Expr:
        """Signed distance to obstacles and the domain's exterior (negative inside one)."""
        return Table("free", (self.name,))

    @property
    def axes(self) -> tuple[str, str]:
        return f"x{self.name}", f"y{self.name}"


def attacker(name: str, speed: float) -> Player:
    return Player(name, "attacker", float(speed))


def defender(name: str, speed: float) -> Player:
    return Player(name, "defender", float(speed))


def distance(p: Player, q: Player) -> Expr:
    """Euclidean distance between the two players' nodes."""
    return sqrt((p.x - q.x) * (p.x - q.x) + (p.y - q.y) * (p.y - q.y))


def table(name: str, p: Player, q: Player) -> Expr:
    """A pair table ``name`` over the nodes of ``p`` and ``q`` (``(nx_p, ny_p, nx_q, ny_q)``)."""
    return Table(name, (p.name, q.name))


@dataclass(frozen=True)
class Game:
    """A reach-avoid game (module docstring). ``parameters`` are recorded in value files
    (for example ``capture_radius``) and are part of the cache key."""

    name: str
    players: tuple[Player, ...]
    target: Expr
    avoid: Expr
    symmetries: tuple[tuple[str, ...], ...] = ()
    parameters: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        names = [p.name for p in self.players]
        if len(self.players) < 2 or len(set(names)) != len(names):
            raise ValueError(f"game {self.name}: needs two or more players with distinct "
                             f"names, got {names}")
        for label, expr in (("target", self.target), ("avoid", self.avoid)):
            unknown = expr.players() - set(names)
            if unknown:
                raise ValueError(f"game {self.name}.{label}: unknown players {sorted(unknown)}")
            for leaf in leaves(expr):
                if isinstance(leaf, Table) and len(leaf.over) not in (1, 2):
                    raise ValueError(f"game {self.name}: table {leaf.name} needs one or "
                                     f"two players, got {leaf.over}")
        for group in self.symmetries:
            members = [self.player(n) for n in group]
            if len(members) < 2 or len({(p.role, p.speed) for p in members}) != 1:
                raise ValueError(f"game {self.name}: symmetry {group} needs two or more "
                                 "players of one role and speed")

    @property
    def axes(self) -> tuple[str, ...]:
        return tuple(a for p in self.players for a in p.axes)

    def player(self, name: str) -> Player:
        for p in self.players:
            if p.name == name:
                return p
        raise ValueError(f"game {self.name}: no player {name!r} (players "
                         f"{[p.name for p in self.players]})")

    def index(self, name: str) -> int:
        return [p.name for p in self.players].index(self.player(name).name)

    def tables(self) -> dict[str, tuple[int, ...]]:
        """Extra tables the game reads (name -> indices of the players it spans)."""
        found: dict[str, tuple[int, ...]] = {}
        for expr in (self.target, self.avoid):
            for leaf in leaves(expr):
                if isinstance(leaf, Table) and leaf.name not in PLANAR_TABLES:
                    found.setdefault(leaf.name, tuple(self.index(n) for n in leaf.over))
        return found

    def describe(self) -> dict[str, object]:
        """What a value file records of the game (``value`` module)."""
        return {"name": self.name,
                "players": [[p.name, p.role, p.speed] for p in self.players],
                "symmetries": [list(g) for g in self.symmetries],
                "parameters": dict(self.parameters)}


def leaves(expr: Expr) -> list[Expr]:
    """The leaves of ``expr`` (with repeats)."""
    if isinstance(expr, Op):
        return [leaf for arg in expr.args for leaf in leaves(arg)]
    return [expr]


# ---------------------------------------------------------------------------------------
# numpy evaluation (the reference, and the kernels' precomputed pair tables)
# ---------------------------------------------------------------------------------------

_NUMPY = {"add": np.add, "sub": np.subtract, "mul": np.multiply, "neg": np.negative,
          "min": np.minimum, "max": np.maximum, "sqrt": np.sqrt}


def evaluate(expr: Expr, leaf_value: Mapping[Expr, np.ndarray] | None = None,
             lookup: object = None) -> np.ndarray:
    """Evaluate ``expr`` in float64; ``lookup(leaf)`` gives each leaf's broadcastable array."""
    cache: dict[Expr, np.ndarray] = dict(leaf_value or {})

    def run(node: Expr) -> np.ndarray:
        if node not in cache:
            if isinstance(node, Op):
                cache[node] = _NUMPY[node.kind](*(run(a) for a in node.args))
            elif isinstance(node, Const):
                cache[node] = np.float64(node.value)
            else:
                cache[node] = np.asarray(lookup(node), dtype=np.float64)  # type: ignore[operator]
        return cache[node]

    return run(expr)

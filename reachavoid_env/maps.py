"""Generated maps and map libraries: seeded, validated scenarios for training and testing
across maps.

``MapOptions`` holds what researchers vary (obstacle count, kinds, size and density, the
minimum clearance, the target's size and place, player counts, speeds, capture radius);
``generate_map(options, seed, index)`` draws map ``index`` of the library of ``seed`` as a
``Scenario`` with random starts (``players.attackers = M``), pure data from numpy's
generator seeded with ``(seed, index)``: the same arguments always give the same map, and
map ``k`` does not depend on how many maps are drawn. Every map is checked, not hoped:

- obstacles keep ``clearance`` (map units) from each other, from the domain's walls and
  from the target (measured on dense outline samples with a safety margin);
- the free region where starts are drawn (points at least ``start_clearance`` from
  obstacles and walls) is one connected component on a raster, and it reaches the target
  (``connected_to_target``), so every start has a path to the target;
- the obstacles cover a fraction of the domain within ``density``;
- random starts drawn by ``Scenario.starts`` pass ``Scenario.validate_starts``.

A library is a folder of scenario TOML files and ``index.toml`` (``write_library``);
``load_library`` reads a folder, an index file, one scenario or a list of them.
Coordinates in map units, speeds in map units per second.
"""

from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any, Union

import numpy as np
import tomli_w

from reachavoid_env import checks
from reachavoid_env.files import atomic_write
from reachavoid_env.game_map import flood_fill
from reachavoid_env.scenario import (
    MAX_COORDINATE,
    MAX_SPEED,
    GameMap,
    Scenario,
    ScenarioError,
    load_scenario,
    read_toml,
)
from reachavoid_env.shapes import SHAPES, Box, Circle, Polygon, Shape

INDEX = "index.toml"
"""The index file of a library folder."""
GENERATOR_VERSION = 1
"""Bumped whenever the same options and seed would draw different maps."""
MAX_MAPS = 100_000
MAX_OBSTACLES = 64
MAX_ATTEMPTS = 200
"""Draws of a whole map before giving up (each one rejected for a reason named in the
error)."""
_OUTLINE_STEP = 0.005
"""Spacing of the outline samples of the clearance check (map units)."""
_PLAYER_RADIUS = {f.name: f.default for f in fields(Scenario)}["player_radius"]


ScenarioSource = Union[str, "os.PathLike[str]", Scenario, Sequence[Any]]
"""What ``load_library`` reads: a built-in name, a TOML file, a library folder or index, a
``Scenario``, or a list of these."""


class MapError(checks.FieldError):
    """A generator option is invalid, or no map satisfies the options; the message names
    the option."""


def _option(default: Any, help_text: str) -> Any:
    """A ``MapOptions`` field: its default and its one-line help (``fields(...).metadata``)."""
    return field(default=default, metadata={"help": help_text})


@dataclass(frozen=True)
class MapOptions:
    """What the generator varies. Ranges are ``(low, high)`` pairs, drawn uniformly per map.

    Lengths are map units, speeds map units per second.
    """

    domain: tuple[float, float, float, float] = _option(
        (-1.0, 1.0, -1.0, 1.0), "XMIN,XMAX,YMIN,YMAX of every map")
    obstacles: tuple[int, int] = _option((2, 6), "LOW,HIGH number of obstacles")
    shapes: tuple[str, ...] = _option(("box", "circle", "polygon"),
                                      "obstacle kinds, drawn uniformly (box, circle, polygon)")
    obstacle_size: tuple[float, float] = _option(
        (0.15, 0.5), "LOW,HIGH extent of one obstacle (box sides, circle or polygon diameter)")
    density: tuple[float, float] = _option(
        (0.03, 0.3), "LOW,HIGH fraction of the domain's area the obstacles cover")
    clearance: float = _option(
        0.1, "least gap between two obstacles, an obstacle and a wall or the target")
    target_size: tuple[float, float] = _option((0.15, 0.3), "LOW,HIGH side of the square target")
    target_region: tuple[float, float, float, float] | None = _option(
        None, "XMIN,XMAX,YMIN,YMAX the whole target lies in (default: the domain)")
    attackers: int = _option(2, "attackers per map (random starts)")
    defenders: int = _option(1, "defenders per map (random starts)")
    attacker_speed: float = _option(1.0, "attacker speed")
    defender_speed: float = _option(1.5, "defender speed")
    capture_radius: float = _option(0.1, "capture radius")
    start_clearance: float = _option(
        0.05, "least distance of a random start to obstacles and walls; the connectivity "
              "check's free region")
    raster: int = _option(256, "cells per axis of the connectivity and density checks")

    def __post_init__(self) -> None:
        d = tuple(_real(v, f"domain[{i}]", -MAX_COORDINATE, MAX_COORDINATE)
                  for i, v in enumerate(_sequence(self.domain, "domain", 4)))
        if not (d[1] > d[0] and d[3] > d[2]):
            raise MapError(f"domain: need xmin < xmax and ymin < ymax, got {d}", field="domain")
        object.__setattr__(self, "domain", d)
        small = min(d[1] - d[0], d[3] - d[2])
        low, high = _range(self.obstacles, "obstacles", 0, MAX_OBSTACLES, integer=True)
        object.__setattr__(self, "obstacles", (low, high))
        kinds = _sequence(self.shapes, "shapes")
        unknown = [k for k in kinds if k not in _DRAW]
        if not kinds or unknown:
            raise MapError(f"shapes: expected some of {', '.join(_DRAW)}, got {list(kinds)}",
                           field="shapes")
        object.__setattr__(self, "shapes", tuple(kinds))
        object.__setattr__(self, "obstacle_size",
                           _range(self.obstacle_size, "obstacle_size", 0.0, small, open_low=True))
        object.__setattr__(self, "density", _range(self.density, "density", 0.0, 0.9))
        covered = high * self.obstacle_size[1] ** 2 / ((d[1] - d[0]) * (d[3] - d[2]))
        if covered < self.density[0]:
            raise MapError(f"density: at least {self.density[0]:g} of the domain cannot be "
                           f"covered by at most {high} obstacles of extent at most "
                           f"{self.obstacle_size[1]:g} (at most {covered:.3g})", field="density")
        object.__setattr__(self, "clearance", _real(self.clearance, "clearance", 0.0, small / 2))
        object.__setattr__(self, "target_size",
                           _range(self.target_size, "target_size", 0.0, small, open_low=True))
        large = max(d[1] - d[0], d[3] - d[2])
        beside = self.target_size[0] + 2 * self.clearance + self.obstacle_size[0]
        if self.target_size[0] >= small or (low and beside > large):
            raise MapError(f"target_size: a target of side {self.target_size[0]:g} leaves no "
                           f"room in the domain {d} for the players and {low} obstacle(s) "
                           f"(side + 2 x clearance + the smallest obstacle must be at most "
                           f"{large:g}, the side below {small:g})", field="target_size")
        if self.target_region is not None:
            r = tuple(_real(v, f"target_region[{i}]", -MAX_COORDINATE, MAX_COORDINATE)
                      for i, v in enumerate(_sequence(self.target_region, "target_region", 4)))
            if not (d[0] <= r[0] and r[1] <= d[1] and d[2] <= r[2] and r[3] <= d[3]):
                raise MapError(f"target_region: {r} must lie within the domain {d}",
                               field="target_region")
            if min(r[1] - r[0], r[3] - r[2]) < self.target_size[0]:
                raise MapError(f"target_region: {r} is smaller than the smallest target "
                               f"{self.target_size[0]:g}", field="target_region")
            object.__setattr__(self, "target_region", r)
        for name in ("attackers", "defenders"):
            object.__setattr__(self, name, checks.integer(getattr(self, name), name, 1, 64,
                                                          error=MapError))
        for name, high in (("attacker_speed", MAX_SPEED), ("defender_speed", MAX_SPEED),
                           ("capture_radius", small)):
            object.__setattr__(self, name, checks.positive(getattr(self, name), name, high,
                                                           error=MapError))
        object.__setattr__(self, "start_clearance",
                           _real(self.start_clearance, "start_clearance", 0.0, small / 4))
        object.__setattr__(self, "raster", checks.integer(self.raster, "raster", 32, 2048,
                                                          error=MapError))
        cell = math.hypot(d[1] - d[0], d[3] - d[2]) / self.raster
        if cell >= self.free_clearance:
            raise MapError(f"raster: a cell's diagonal {cell:.3g} must be below the start "
                           f"clearance {self.free_clearance:g} for a sound connectivity check; "
                           f"raise raster or start_clearance", field="raster")

    @property
    def free_clearance(self) -> float:
        """Least distance of a random start to obstacles and walls, as ``Scenario.starts``
        keeps it (``start_clearance``, at least the player radius): the connectivity
        check's free region."""
        return max(self.start_clearance, _PLAYER_RADIUS)

    def to_dict(self) -> dict[str, Any]:
        """The options as TOML-ready data (``None`` fields left out)."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()
                if v is not None}


def options_from_text(texts: dict[str, str | None]) -> MapOptions:
    """``MapOptions`` from command-line text: a comma-separated list for a tuple option,
    one number otherwise (``None`` keeps the default). ``MapError`` naming the option."""
    values: dict[str, Any] = {}
    for option in fields(MapOptions):
        text = texts.get(option.name)
        if text is None:
            continue
        example = option.default if option.default is not None else (0.0,)
        kind = type(example[0] if isinstance(example, tuple) else example)
        try:
            items = tuple(kind(item.strip()) for item in text.split(","))
        except ValueError:
            raise MapError(f"{option.name}: expected {kind.__name__} values separated by commas, "
                           f"got {text!r}", field=option.name) from None
        values[option.name] = items if isinstance(example, tuple) else items[0] \
            if len(items) == 1 else items
    return MapOptions(**values)


def _real(value: Any, name: str, low: float, high: float) -> float:
    return checks.real(value, name, low, high, error=MapError)


def _sequence(value: Any, name: str, length: int | None = None) -> tuple:
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) \
            or (length is not None and len(value) != length):
        size = f"{length} values" if length else "a list"
        raise MapError(f"{name}: expected {size}, got {value!r}", field=name)
    return tuple(value)


def _range(value: Any, name: str, low: float, high: float, integer: bool = False,
           open_low: bool = False) -> tuple[Any, Any]:
    pair = _sequence(value, name, 2)
    if integer:
        a, b = (checks.integer(v, f"{name}[{i}]", int(low), int(high), error=MapError)
                for i, v in enumerate(pair))
    else:
        a, b = (checks.real(v, f"{name}[{i}]", low, high, low_open=open_low, error=MapError)
                for i, v in enumerate(pair))
    if a > b:
        raise MapError(f"{name}: the low end {a:g} exceeds the high end {b:g}", field=name)
    return (a, b)


# -- drawing shapes -------------------------------------------------------------------------

def _rounded(value: float) -> float:
    return round(float(value), 4)


def _draw_box(rng: np.random.Generator, center: np.ndarray, size: tuple[float, float]) -> Box:
    half = rng.uniform(*size, size=2) / 2
    return Box((_rounded(center[0] - half[0]), _rounded(center[1] - half[1])),
               (_rounded(center[0] + half[0]), _rounded(center[1] + half[1])))


def _draw_circle(rng: np.random.Generator, center: np.ndarray,
                 size: tuple[float, float]) -> Circle:
    return Circle((_rounded(center[0]), _rounded(center[1])), _rounded(rng.uniform(*size) / 2))


def _draw_polygon(rng: np.random.Generator, center: np.ndarray,
                  size: tuple[float, float]) -> Polygon:
    """A star-shaped polygon (convex or concave): 5-8 vertices, one in each equal sector
    around ``center`` (so neighbours are less than pi apart and the polygon is simple), the
    largest radius half the drawn extent and the others at least 40% of it."""
    count = int(rng.integers(5, 9))
    angles = (np.arange(count) + rng.uniform(0.15, 0.85, count)) * (2 * np.pi / count)
    radii = rng.uniform(0.4, 1.0, count)
    radii *= rng.uniform(*size) / 2 / radii.max()
    points = center + radii[:, None] * np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    return Polygon(tuple((_rounded(x), _rounded(y)) for x, y in points))


_DRAW = {"box": _draw_box, "circle": _draw_circle, "polygon": _draw_polygon}
"""How to draw each obstacle kind (every kind here is a ``SHAPES`` entry)."""
assert set(_DRAW) <= set(SHAPES)


# -- checks ---------------------------------------------------------------------------------

def _samples(shape: Shape) -> np.ndarray:
    """Points along ``shape``'s boundary, at most ``_OUTLINE_STEP`` apart."""
    ring = shape.outline()
    edges = np.roll(ring, -1, axis=0) - ring
    steps = np.maximum(1, np.ceil(np.linalg.norm(edges, axis=1) / _OUTLINE_STEP)).astype(int)
    edge = np.repeat(np.arange(len(ring)), steps)
    along = (np.arange(steps.sum()) - np.repeat(np.cumsum(steps) - steps, steps)) / steps[edge]
    return ring[edge] + along[:, None] * edges[edge]


def shape_gap(a: Shape, b: Shape) -> float:
    """Distance between two shapes (map units; <= 0 where they touch or overlap), from
    boundary samples ``_OUTLINE_STEP`` apart: an overestimate by at most about half that."""
    return float(min(b.signed_distance(_samples(a)).min(), a.signed_distance(_samples(b)).min()))


def _clear(a: Shape, b: Shape, gap: float) -> bool:
    """Whether ``a`` and ``b`` are at least ``gap`` apart (their bounding boxes first)."""
    ax0, ax1, ay0, ay1 = a.bounds()
    bx0, bx1, by0, by1 = b.bounds()
    if max(bx0 - ax1, ax0 - bx1, by0 - ay1, ay0 - by1) >= gap:
        return True
    return shape_gap(a, b) >= gap


def _wall_gap(shape: Shape, domain: tuple[float, float, float, float]) -> float:
    x0, x1, y0, y1 = shape.bounds()
    return min(x0 - domain[0], domain[1] - x1, y0 - domain[2], domain[3] - y1)


def raster_points(domain: tuple[float, float, float, float], cells: int) -> np.ndarray:
    """Cell centres ``(cells, cells, 2)`` of a ``cells`` x ``cells`` raster of ``domain``."""
    xmin, xmax, ymin, ymax = domain
    xs = xmin + (np.arange(cells) + 0.5) * (xmax - xmin) / cells
    ys = ymin + (np.arange(cells) + 0.5) * (ymax - ymin) / cells
    return np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1)


def connected_to_target(game_map: GameMap, clearance: float, cells: int = 256) -> bool:
    """Whether the free region (points at least ``clearance`` from obstacles and walls) is
    one connected component that reaches the target, on a ``cells`` x ``cells`` raster.

    The component is grown from the free cells inside the target by 4-neighbour steps
    (a flood fill: connected-component labelling of the target's component); the map
    passes when it holds every free cell. Sound when a cell's diagonal is below
    ``clearance``: two neighbouring free cell centres are then joined by a segment that
    keeps clear of every obstacle.
    """
    points = raster_points(game_map.domain, cells)
    free = game_map.obstacle_signed_distance(points) >= clearance
    reached = flood_fill(free, game_map.in_target(points))
    return bool(reached.any() and np.array_equal(reached, free))


def _area(shape: Shape) -> float:
    """Area of an obstacle (square map units)."""
    if isinstance(shape, Circle):
        return math.pi * shape.radius ** 2
    if isinstance(shape, Polygon):
        return abs(shape.area)
    x0, x1, y0, y1 = shape.bounds()
    return (x1 - x0) * (y1 - y0)


# -- generation -----------------------------------------------------------------------------

def map_name(seed: int, index: int) -> str:
    """The scenario name of map ``index`` of the library of ``seed``."""
    return f"gen-s{seed}-{index:04d}"


def generate_map(options: MapOptions, seed: int, index: int = 0,
                 attempts: int = MAX_ATTEMPTS) -> Scenario:
    """Map ``index`` of the library of ``seed``: a validated ``Scenario`` with random starts.

    Draws whole maps from ``numpy.random.default_rng((seed, index))`` until one passes
    every check (module docstring); ``MapError`` naming the options to relax after
    ``attempts`` draws.
    """
    checks.integer(seed, "seed", 0, 2**63 - 1, error=MapError)
    checks.integer(index, "index", 0, MAX_MAPS, error=MapError)
    rng = np.random.default_rng((seed, index))
    reasons: dict[str, int] = {}
    for _ in range(attempts):
        scenario, reason = _attempt(options, rng, map_name(seed, index))
        if scenario is not None:
            return scenario
        reasons[reason] = reasons.get(reason, 0) + 1
    worst = max(reasons, key=reasons.get)
    raise MapError(f"{worst}: no map of seed {seed}, index {index} met the options in "
                   f"{attempts} draws (rejections: "
                   f"{', '.join(f'{k} {v}' for k, v in sorted(reasons.items()))}); relax "
                   f"{worst}", field=worst)


def _attempt(options: MapOptions, rng: np.random.Generator,
             name: str) -> tuple[Scenario | None, str]:
    """One draw of a whole map: the scenario, or ``None`` and the option that rejected it."""
    domain = options.domain
    xmin, xmax, ymin, ymax = options.target_region or domain
    side = rng.uniform(*options.target_size)
    corner = rng.uniform((xmin, ymin), (xmax - side, ymax - side))
    target = Box((_rounded(corner[0]), _rounded(corner[1])),
                 (_rounded(corner[0] + side), _rounded(corner[1] + side)))
    lowest, most = options.obstacles
    domain_area = (domain[1] - domain[0]) * (domain[3] - domain[2])
    goal = rng.uniform(*options.density) * domain_area
    need = options.clearance + _OUTLINE_STEP
    obstacles: list[Shape] = []
    covered = 0.0
    for _ in range(50 * max(most, 1)):
        if len(obstacles) == most or (covered >= goal and len(obstacles) >= lowest):
            break
        kind = options.shapes[int(rng.integers(len(options.shapes)))]
        center = rng.uniform(domain[0::2], domain[1::2])
        shape = _DRAW[kind](rng, center, options.obstacle_size)
        if _wall_gap(shape, domain) >= options.clearance and _clear(shape, target, need) \
                and all(_clear(shape, other, need) for other in obstacles):
            obstacles.append(shape)
            covered += _area(shape)
    if len(obstacles) < lowest:
        return None, "obstacles"
    if not options.density[0] <= covered / domain_area <= options.density[1]:
        return None, "density"
    game_map = GameMap(domain, (target,), tuple(obstacles))
    if not connected_to_target(game_map, options.free_clearance, options.raster):
        return None, "clearance"
    try:
        scenario = Scenario(game_map, options.attackers, options.defenders,
                            attacker_speed=options.attacker_speed,
                            defender_speed=options.defender_speed,
                            capture_radius=options.capture_radius,
                            start_clearance=options.start_clearance, name=name)
        for _ in range(4):
            scenario.validate_starts(*scenario.starts(rng))
    except ScenarioError:
        return None, "start_clearance"
    return scenario, ""


# -- libraries ------------------------------------------------------------------------------

@dataclass(frozen=True)
class LibraryFile:
    """One map of a library's index: its file (relative to the index) and content hash."""

    file: str
    name: str
    sha256: str


def map_file(index: int) -> str:
    """The file name of map ``index`` in a library folder."""
    return f"map-{index:04d}.toml"


def _toml_bytes(data: dict[str, Any]) -> bytes:
    return tomli_w.dumps(data).encode("utf-8")


def library_files(options: MapOptions, seed: int, count: int) -> dict[str, bytes]:
    """Every file of the library of ``count`` maps of ``seed``: name -> bytes (the maps'
    TOML, as ``save_scenario`` writes it, and ``index.toml``). A pure function."""
    checks.integer(count, "count", 1, MAX_MAPS, error=MapError)
    files: dict[str, bytes] = {}
    entries = []
    for index in range(count):
        scenario = generate_map(options, seed, index)
        data = _toml_bytes(scenario.to_dict())
        files[map_file(index)] = data
        entries.append({"file": map_file(index), "name": scenario.name,
                        "sha256": hashlib.sha256(data).hexdigest()})
    index_data = {"generator": {"version": GENERATOR_VERSION, "seed": seed, "count": count,
                                "options": options.to_dict()},
                  "maps": entries}
    files[INDEX] = _sealed(b"# A map library written by `reachavoid maps`; load it with "
                           b"reachavoid_env.maps.load_library.\n" + _toml_bytes(index_data))
    return files


SEAL = b"# sha256 of the lines above: "
"""The index's last line: the hash of what precedes it, so an edit shows."""


def _sealed(text: bytes) -> bytes:
    return text + SEAL + hashlib.sha256(text).hexdigest().encode() + b"\n"


def unedited_index(data: bytes) -> bool:
    """Whether ``data`` is an ``index.toml`` as ``write_library`` wrote it (its seal holds)."""
    body, seal, digest = data.rpartition(SEAL)
    return bool(seal) and digest == hashlib.sha256(body).hexdigest().encode() + b"\n"


def read_index(path: Path) -> list[LibraryFile]:
    """The maps an ``index.toml`` lists; ``ValueError`` saying why it is not an index."""
    data = read_toml(path.read_bytes(), repr(str(path)), ValueError)
    try:
        checks.integer(data["generator"]["version"], "generator.version", 1)
        if not isinstance(data["maps"], list):
            raise TypeError("maps: expected an array of tables [[maps]]")
        entries = [_entry(entry, k) for k, entry in enumerate(data["maps"])]
    except (ValueError, KeyError, TypeError) as err:
        raise ValueError(f"{str(path)!r} is not a map library index ({err})") from None
    return entries


def _entry(entry: Any, k: int) -> LibraryFile:
    """``maps[k]`` of an index: a table of three strings."""
    names = [f.name for f in fields(LibraryFile)]
    if not isinstance(entry, dict) or sorted(entry) != sorted(names):
        raise TypeError(f"maps[{k}]: expected a table of {', '.join(names)}")
    for key, value in entry.items():
        if not isinstance(value, str) or not value:
            raise TypeError(f"maps[{k}].{key}: expected a non-empty string, got {value!r}")
    return LibraryFile(**entry)


def _written_by_us(folder: Path) -> dict[str, str]:
    """Files of ``folder`` that an earlier ``write_library`` wrote (its index lists them):
    name -> sha256 as written (empty without an index)."""
    index = folder / INDEX
    if not index.exists():
        return {}
    try:
        return {entry.file: entry.sha256 for entry in read_index(index)}
    except ValueError as err:
        raise MapError(f"out: {err}; choose another folder", field="out") from None


def write_library(folder: str | os.PathLike[str], options: MapOptions, seed: int,
                  count: int) -> list[Path]:
    """Write the library of ``count`` maps of ``seed`` to ``folder`` (created if missing)
    and return the paths written.

    Refuses (``MapError`` naming ``out``), before writing anything, to replace a file that
    an earlier call did not write, or that changed since: an existing map file is replaced
    only when the folder's index lists it with its current content, an existing index only
    when its last line (``SEAL``) still hashes what precedes it. Every file
    is written atomically; the same call always writes the same bytes.
    """
    folder = Path(folder)
    files = library_files(options, seed, count)
    ours = _written_by_us(folder) if folder.is_dir() else {}
    for name, data in files.items():
        path = folder / name
        if not path.exists() and not path.is_symlink():
            continue
        if not path.is_file():
            raise MapError(f"out: {path} exists and is not a file", field="out")
        current = path.read_bytes()
        ours_unchanged = (unedited_index(current) if name == INDEX
                          else ours.get(name) == hashlib.sha256(current).hexdigest())
        if current != data and not ours_unchanged:
            raise MapError(f"out: {path} exists and was not written by `reachavoid maps` (or "
                           f"was changed since); choose another folder", field="out")
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for name, data in files.items():   # the index last: it vouches only for written maps
        with atomic_write(folder / name, "wb") as handle:
            handle.write(data)
        written.append(folder / name)
    return written


def load_library(source: ScenarioSource) -> tuple[Scenario, ...]:
    """The scenarios of a library: a folder (its ``index.toml``, else every ``*.toml`` in
    name order), an index file, a scenario (built-in name, TOML file or ``Scenario``) or a
    list of any of these. ``ScenarioError`` naming the source when it holds none, naming
    the file of a map that fails to load, and when two different maps share a name (tables
    and caches tell maps apart by name); the same map listed twice counts once."""
    named: dict[str, tuple[Scenario, str]] = {}
    for scenario, origin in _load_library(source):
        first = named.setdefault(scenario.name, (scenario, origin))
        if first[0] != scenario:
            raise ScenarioError(f"scenario: {first[1]} and {origin} are different maps named "
                                f"{scenario.name!r}; names in a library are unique",
                                field="scenario")
    return tuple(scenario for scenario, _ in named.values())


def _load_library(source: ScenarioSource) -> list[tuple[Scenario, str]]:
    """``load_library``'s scenarios, each with where it came from."""
    if isinstance(source, Scenario):
        return [(source, f"scenario {source.name!r}")]
    if isinstance(source, (list, tuple)):
        if not source:
            raise ScenarioError("scenario: an empty list of scenarios", field="scenario")
        return [found for item in source for found in _load_library(item)]
    if not isinstance(source, (str, os.PathLike)):
        raise TypeError(f"scenario: expected a built-in name, a TOML file, a library folder "
                        f"or index, a Scenario or a list of them, got {type(source).__name__}")
    path = Path(source)
    if path.is_dir():
        if (path / INDEX).is_file():
            return _load_library(path / INDEX)
        files = sorted(path.glob("*.toml"))
        if not files:
            raise ScenarioError(f"scenario: folder {str(path)!r} holds no .toml scenario",
                                field="scenario")
        return [(_load_map(f), str(f)) for f in files]
    if path.name == INDEX and path.is_file():
        try:
            entries = read_index(path)
        except ValueError as err:
            raise ScenarioError(f"scenario: {err}", field="scenario") from None
        if not entries:
            raise ScenarioError(f"scenario: {str(path)!r} lists no maps", field="scenario")
        files = [path.parent / entry.file for entry in entries]
        return [(_load_map(f), str(f)) for f in files]
    return [(load_scenario(source), str(source))]


def _load_map(path: Path) -> Scenario:
    """A map file of a library; its errors name it."""
    try:
        return load_scenario(path)
    except ScenarioError as err:
        message = str(err)
        raise ScenarioError(message if str(path) in message else f"{path}: {message}",
                            field=err.field) from None

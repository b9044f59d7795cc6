"""Scenarios: TOML load/save, validation, built-ins and random starts (maps: ``game_map``).

Coordinates are map units, ``x`` then ``y``; times are seconds; speeds are map units per
second. Point arrays have shape ``(..., 2)``. The TOML format is design.md section 5.
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from reachavoid_env import checks, rules
from reachavoid_env.files import atomic_write
from reachavoid_env.game_map import MAX_COORDINATE, MIN_EXTENT, GameMap, ScenarioError
from reachavoid_env.shapes import Box, Shape, ShapeError, shape_from_dict

__all__ = ["MAX_COORDINATE", "MIN_EXTENT", "Box", "GameMap", "Scenario", "ScenarioError",
           "Shape", "ShapeError", "builtin_map", "builtin_names", "builtin_scenario",
           "load_scenario", "save_scenario", "shape_from_dict", "substeps_for"]
"""Also the names that lived here before ``game_map`` (``GameMap``, ``ScenarioError``, the
shapes), so that older imports keep working."""

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib

Point = tuple[float, float]

MAX_SPEED = 1e3
"""Largest player speed (map units per second)."""
MAX_DT = 1.0
"""Longest step (seconds)."""
MAX_STEPS = 10_000_000
"""Most steps in an episode."""
MAX_PLAYERS = 1024
"""Most attackers, and most defenders, in a scenario: the env's per-step tables grow with
attackers times defenders, and every observation with all players."""
MAX_SUBSTEPS = 10_000
"""Most physics sub-steps per step (``substeps_for``): a smaller ``player_radius`` or a
longer ``dt`` would make every step crawl."""


def substeps_for(max_speed: float, dt: float, player_radius: float) -> int:
    """Physics sub-steps per step (``world.World``) so nobody moves more than
    ``player_radius / 2`` in one (speed in map units per second, ``dt`` in seconds)."""
    ratio = max_speed * dt / (0.5 * player_radius)
    return max(1, math.ceil(ratio - 1e-9))


def _points_field(value: Any, field_name: str) -> tuple[Point, ...] | int:
    if isinstance(value, bool):
        raise ScenarioError(f"{field_name}: expected a list of [x, y] or a count, got {value!r}",
                            field=field_name)
    if isinstance(value, int):
        if value < 1:
            raise ScenarioError(f"{field_name}: the count must be at least 1, got {value}",
                                field=field_name)
        return value
    if not isinstance(value, list) or not value:
        raise ScenarioError(f"{field_name}: expected a non-empty list of [x, y] or a count",
                            field=field_name)
    points = []
    for i, p in enumerate(value):
        if not isinstance(p, list) or len(p) != 2:
            raise ScenarioError(f"{field_name}[{i}]: expected a vector [x, y] of length 2, "
                                f"got {p!r}", field=f"{field_name}[{i}]")
        points.append((checks.real(p[0], f"{field_name}[{i}][0]", error=ScenarioError),
                       checks.real(p[1], f"{field_name}[{i}][1]", error=ScenarioError)))
    return tuple(points)


@dataclass(frozen=True)
class Scenario:
    """A map, the players and the simulation settings.

    ``attackers`` / ``defenders`` are fixed start positions, or ``None`` when the starts
    are drawn at reset (``num_attackers`` / ``num_defenders`` give the counts).
    Speeds in map units per second, ``capture_radius`` and ``player_radius`` in map units,
    ``dt`` in seconds.
    """

    map: GameMap
    num_attackers: int
    num_defenders: int
    attackers: tuple[Point, ...] | None = None
    defenders: tuple[Point, ...] | None = None
    attacker_speed: float = 1.0
    defender_speed: float = 1.5
    capture_radius: float = 0.1
    dt: float = 0.005
    max_steps: int = 1000
    player_radius: float = 0.005
    start_clearance: float = 0.05
    name: str = "custom"
    paper_captures: tuple[tuple[str, int], ...] = field(default=(), compare=False)

    def __post_init__(self) -> None:
        if not self.name or not self.name.isprintable():
            raise ScenarioError(f"name: expected printable text (no control characters such "
                                f"as NUL or a line break), got {self.name[:60]!r}",
                                field="name")
        size = min(self.map.size)
        for name, high in (("attacker_speed", MAX_SPEED), ("defender_speed", MAX_SPEED),
                           ("capture_radius", size), ("dt", MAX_DT),
                           ("player_radius", 0.1 * size)):
            object.__setattr__(self, name, checks.positive(
                getattr(self, name), f"{_SECTION[name]}.{name}", high, error=ScenarioError))
        object.__setattr__(self, "start_clearance", checks.real(
            self.start_clearance, "sim.start_clearance", 0.0, 0.5 * size, error=ScenarioError))
        checks.integer(self.max_steps, "sim.max_steps", 1, MAX_STEPS, error=ScenarioError)
        substeps = substeps_for(max(self.attacker_speed, self.defender_speed), self.dt,
                                self.player_radius)
        if substeps > MAX_SUBSTEPS:
            raise ScenarioError(f"sim.dt: {self.dt:g} s at speed "
                                f"{max(self.attacker_speed, self.defender_speed):g} needs "
                                f"{substeps} physics sub-steps per step with player_radius "
                                f"{self.player_radius:g} (at most {MAX_SUBSTEPS}); shorten "
                                f"sim.dt or grow sim.player_radius", field="sim.dt")
        for method, count in self.paper_captures:
            checks.integer(count, f"paper.captured.{method}", 0, self.num_attackers,
                           error=ScenarioError)
        for role, count in (("attackers", self.num_attackers), ("defenders", self.num_defenders)):
            if count < 1:
                raise ScenarioError(f"players.{role}: need at least one, got {count}",
                                    field=f"players.{role}")
            if count > MAX_PLAYERS:
                raise ScenarioError(f"players.{role}: at most {MAX_PLAYERS}, got {count}",
                                    field=f"players.{role}")
            starts = getattr(self, role)
            if starts is not None and len(starts) != count:
                raise ScenarioError(f"players.{role}: {len(starts)} starts for {count} players",
                                    field=f"players.{role}")
        if self.attackers is not None and self.defenders is not None:
            self.validate_starts(np.asarray(self.attackers), np.asarray(self.defenders))

    @property
    def attacker_names(self) -> list[str]:
        return [f"attacker_{i}" for i in range(self.num_attackers)]

    @property
    def defender_names(self) -> list[str]:
        return [f"defender_{j}" for j in range(self.num_defenders)]

    def validate_starts(self, attackers: np.ndarray, defenders: np.ndarray) -> None:
        """Raise ``ScenarioError`` naming the player when a start is not valid."""
        for role, points in (("attackers", attackers), ("defenders", defenders)):
            for i, p in enumerate(np.asarray(points, dtype=np.float64)):
                name = f"players.{role}[{i}]"
                where = f"{name}: ({p[0]:g}, {p[1]:g})"
                xmin, xmax, ymin, ymax = self.map.domain
                if not (xmin <= p[0] <= xmax and ymin <= p[1] <= ymax):
                    raise ScenarioError(f"{where} lies outside the domain {self.map.domain}",
                                        field=name)
                for k, obstacle in enumerate(self.map.obstacles):
                    if obstacle.contains(p):
                        raise ScenarioError(f"{where} lies inside obstacle {k}", field=name)
                    if obstacle.signed_distance(p) < self.player_radius:
                        raise ScenarioError(f"{where} is closer than player_radius "
                                            f"{self.player_radius:g} to obstacle {k}",
                                            field=name)
        for i, p in enumerate(np.asarray(attackers, dtype=np.float64)):
            name = f"players.attackers[{i}]"
            where = f"{name}: ({p[0]:g}, {p[1]:g})"
            if self.map.in_target(p):
                raise ScenarioError(f"{where} starts inside the target", field=name)
            caught = rules.within_capture(p[None], np.asarray(defenders, dtype=np.float64),
                                          self.capture_radius)[0]
            if caught.any():
                gaps = np.linalg.norm(np.asarray(defenders) - p, axis=-1)
                j = int(np.argmin(gaps))
                raise ScenarioError(f"{where} starts captured by defenders[{j}] "
                                    f"(distance {gaps[j]:.3g} <= capture_radius "
                                    f"{self.capture_radius:g})", field=name)

    def starts(self, rng: np.random.Generator, attacker_reach: float | None = None,
               ) -> tuple[np.ndarray, np.ndarray]:
        """Start positions ``(attackers (M, 2), defenders (N, 2))``, float64.

        Fixed starts are returned as given; missing ones are drawn from ``rng``, uniformly
        over the free space with at least ``start_clearance`` to obstacles and walls; an
        attacker also keeps that clearance from the target and from every capture disc,
        and with ``attacker_reach`` (map units; ``None``: anywhere) lies within that
        distance of the target (easy starts for a curriculum). The same ``rng`` state
        draws the same starts when ``attacker_reach`` is ``None``.
        """
        defenders = (np.asarray(self.defenders, dtype=np.float64) if self.defenders is not None
                     else self._sample(rng, self.num_defenders, None))
        attackers = (np.asarray(self.attackers, dtype=np.float64) if self.attackers is not None
                     else self._sample(rng, self.num_attackers, defenders, attacker_reach))
        return attackers, defenders

    def _sample(self, rng: np.random.Generator, count: int, defenders: np.ndarray | None,
                reach: float | None = None) -> np.ndarray:
        xmin, xmax, ymin, ymax = self.map.domain
        clearance = max(self.start_clearance, self.player_radius)
        chosen: list[np.ndarray] = []
        for _ in range(1000):
            batch = rng.uniform((xmin, ymin), (xmax, ymax), size=(256, 2))
            ok = self.map.obstacle_signed_distance(batch) >= clearance
            if defenders is not None:
                to_target = self.map.target_signed_distance(batch)
                ok &= to_target >= clearance
                if reach is not None:
                    ok &= to_target <= reach
                gaps = np.linalg.norm(batch[:, None, :] - defenders[None], axis=-1)
                ok &= np.all(gaps >= self.capture_radius + clearance, axis=-1)
            chosen.extend(batch[ok])
            if len(chosen) >= count:
                return np.asarray(chosen[:count])
        role = "attackers" if defenders is not None else "defenders"
        within = "" if reach is None else f" within {reach:g} of the target"
        raise ScenarioError(f"players.{role}: could not draw {count} valid random starts with "
                            f"clearance {clearance:g}{within}", field=f"players.{role}")

    def with_players(self, num_attackers: int, num_defenders: int) -> Scenario:
        """The same map and settings with random starts for the given numbers of players."""
        return replace(self, num_attackers=num_attackers, num_defenders=num_defenders,
                       attackers=None, defenders=None, paper_captures=(),
                       name=f"{self.name.split('_')[0]}_random_{num_attackers}v{num_defenders}")

    def with_starts(self, attackers: np.ndarray, defenders: np.ndarray) -> Scenario:
        """The same scenario with fixed starts (validated)."""
        a = tuple((float(x), float(y)) for x, y in np.asarray(attackers, dtype=np.float64))
        d = tuple((float(x), float(y)) for x, y in np.asarray(defenders, dtype=np.float64))
        return replace(self, attackers=a, defenders=d, num_attackers=len(a),
                       num_defenders=len(d))

    def to_dict(self) -> dict[str, Any]:
        players: dict[str, Any] = {
            "attacker_speed": self.attacker_speed,
            "defender_speed": self.defender_speed,
            "capture_radius": self.capture_radius,
            "attackers": ([list(p) for p in self.attackers] if self.attackers is not None
                          else self.num_attackers),
            "defenders": ([list(p) for p in self.defenders] if self.defenders is not None
                          else self.num_defenders),
        }
        sim = {"dt": self.dt, "max_steps": self.max_steps, "player_radius": self.player_radius,
               "start_clearance": self.start_clearance}
        paper = {"paper": {"captured": dict(self.paper_captures)}} if self.paper_captures else {}
        return {"name": self.name, "map": self.map.to_dict(), "players": players, "sim": sim,
                **paper}

    @classmethod
    def from_dict(cls, data: dict[str, Any], name: str = "custom") -> Scenario:
        unknown = set(data) - {"name", "map", "players", "sim", "paper"}
        if unknown:
            raise ScenarioError(f"unknown top-level tables {sorted(unknown)} "
                                "(expected map, players, sim, paper)")
        if "map" not in data:
            raise ScenarioError("map: missing [map] table", field="map")
        game_map = GameMap.from_dict(data["map"])
        players = data.get("players")
        if not isinstance(players, dict):
            raise ScenarioError("players: missing [players] table", field="players")
        sim = data.get("sim", {})
        if not isinstance(sim, dict):
            raise ScenarioError("sim: expected a table", field="sim")
        allowed_players = {"attacker_speed", "defender_speed", "capture_radius", "attackers",
                           "defenders"}
        allowed_sim = {"dt", "max_steps", "player_radius", "start_clearance"}
        for table, keys, allowed in (("players", players, allowed_players),
                                     ("sim", sim, allowed_sim)):
            extra = set(keys) - allowed
            if extra:
                raise ScenarioError(f"{table}: unknown keys {sorted(extra)}", field=table)
        for role in ("attackers", "defenders"):
            if role not in players:
                raise ScenarioError(f"players.{role}: missing", field=f"players.{role}")
        attackers = _points_field(players["attackers"], "players.attackers")
        defenders = _points_field(players["defenders"], "players.defenders")
        kwargs: dict[str, Any] = {key: players[key] for key in
                                  ("attacker_speed", "defender_speed", "capture_radius")
                                  if key in players}
        kwargs.update((key, sim[key]) for key in allowed_sim if key in sim)
        paper = data.get("paper", {})
        if not isinstance(paper, dict) or set(paper) - {"captured"} \
                or not isinstance(paper.get("captured", {}), dict):
            raise ScenarioError("paper: expected a table with captured = {method = count, ...}",
                                field="paper")
        kwargs["paper_captures"] = tuple(paper.get("captured", {}).items())
        return cls(
            map=game_map,
            num_attackers=attackers if isinstance(attackers, int) else len(attackers),
            num_defenders=defenders if isinstance(defenders, int) else len(defenders),
            attackers=None if isinstance(attackers, int) else attackers,
            defenders=None if isinstance(defenders, int) else defenders,
            name=str(data.get("name", name)),
            **kwargs,
        )


_SECTION = {"attacker_speed": "players", "defender_speed": "players",
            "capture_radius": "players", "dt": "sim", "player_radius": "sim"}


def builtin_names() -> list[str]:
    """Names of the built-in scenarios (the paper's games, design.md section 7)."""
    folder = resources.files("reachavoid_env") / "scenarios"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def builtin_scenario(name: str) -> Scenario:
    """A built-in scenario by name, e.g. ``"paper_6v2"``."""
    if name not in builtin_names():
        raise ScenarioError(f"scenario: unknown built-in {name!r} "
                            f"(built-ins: {', '.join(builtin_names())})", field="scenario")
    data = (resources.files("reachavoid_env") / "scenarios" / f"{name}.toml").read_bytes()
    return _parse(data, name, source=f"built-in {name}")


def builtin_map(name: str = "paper") -> GameMap:
    """The map shared by the built-in scenarios whose names start with ``name``."""
    matches = [n for n in builtin_names() if n.split("_")[0] == name]
    if not matches:
        raise ScenarioError(f"map: unknown built-in map {name!r}", field="map")
    return builtin_scenario(matches[0]).map


def read_toml(data: bytes, source: str,
              error: type[ValueError] = ScenarioError) -> dict[str, Any]:
    """The table of the TOML text ``data`` (UTF-8, a byte-order mark allowed): what every
    input file of the project (scenario, suite, library index) is read with; ``error``
    naming ``source`` (its ``field``, for a ``FieldError``) when it is not UTF-8, not TOML,
    or nested too deeply to read."""

    def failure(message: str) -> ValueError:
        if issubclass(error, checks.FieldError):
            return error(f"{source}: {message}", field=source)
        return error(f"{source}: {message}")

    try:
        return tomllib.loads(data.decode("utf-8-sig"))
    except UnicodeDecodeError as err:
        raise failure(f"not UTF-8 text (byte {err.start}); TOML files are UTF-8") from None
    except tomllib.TOMLDecodeError as err:
        raise failure(f"malformed TOML: {err}") from None
    except RecursionError:
        raise failure("arrays or tables nested too deeply") from None


def _parse(data: bytes, name: str, source: str) -> Scenario:
    return Scenario.from_dict(read_toml(data, source), name=name)


def load_scenario(source: str | os.PathLike[str]) -> Scenario:
    """Load a scenario from a TOML file, or a built-in by name."""
    path = Path(source)
    if path.suffix != ".toml" and str(source) in builtin_names():
        return builtin_scenario(str(source))
    if not path.is_file():
        raise ScenarioError(f"scenario: no such file or built-in {str(source)!r} "
                            f"(built-ins: {', '.join(builtin_names())})", field="scenario")
    return _parse(path.read_bytes(), path.stem, source=str(path))


def save_scenario(scenario: Scenario, path: str | os.PathLike[str]) -> None:
    """Write ``scenario`` as TOML (to a temporary name, then renamed into place)."""
    with atomic_write(path, "wb") as handle:
        tomli_w.dump(scenario.to_dict(), handle)

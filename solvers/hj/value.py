"""A solved reach-avoid game: interpolated values, gradients, optimal controls, files.

Sign convention (design.md section 4): value <= 0 exactly where the attacker side wins.
On disk a solved game is a directory ``NAME.vf/`` with ``value.npy`` (float32, C order,
opened with ``mmap_mode="r"``) and ``meta.json``.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from reachavoid_env import GameMap, ScenarioError
from solvers.hj.grid import Grid

AXES = {
    "1v1": ("xA", "yA", "xD", "yD"),
    "2v1": ("xA1", "yA1", "xA2", "yA2", "xD", "yD"),
}
_GRADIENT_FLOOR = 1e-9


class ValueFunctionError(ValueError):
    """A value-function directory is missing, truncated or does not match what was asked."""


def _map_dict(game_map: GameMap) -> dict[str, Any]:
    """The map's TOML table as it reads back from JSON (lists, floats)."""
    return json.loads(json.dumps(game_map.to_dict()))


@dataclass(frozen=True, eq=False)
class ValueFunction:
    """The value of a 1 vs 1 (4-D) or 2 vs 1 (6-D) game on a grid.

    States are arrays ``(..., ndim)`` in the game's axis order (``axes``), map units.
    ``values`` may be a read-only memory map of ``value.npy``.
    """

    values: np.ndarray
    grid: Grid
    game: str
    attacker_speed: float
    defender_speed: float
    capture_radius: float
    game_map: GameMap
    solver: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.game not in AXES:
            raise ValueError(f"game: expected one of {sorted(AXES)}, got {self.game!r}")
        if self.grid.ndim != len(AXES[self.game]):
            raise ValueError(f"grid: the {self.game} game needs {len(AXES[self.game])} axes, "
                             f"got {self.grid.ndim}")
        if tuple(self.values.shape) != self.grid.shape or self.values.dtype != np.float32:
            raise ValueError(f"values: expected float32 {self.grid.shape}, got "
                             f"{self.values.dtype} {tuple(self.values.shape)}")

    @property
    def axes(self) -> tuple[str, ...]:
        return AXES[self.game]

    @property
    def num_attackers(self) -> int:
        return self.grid.ndim // 2 - 1

    def _states(self, states: np.ndarray) -> tuple[np.ndarray, tuple[int, ...]]:
        states = np.asarray(states, dtype=np.float64)
        if states.shape[-1:] != (self.grid.ndim,):
            raise ValueError(f"states: expected shape (..., {self.grid.ndim}) with axes "
                             f"{self.axes}, got {states.shape}")
        return states.reshape(-1, self.grid.ndim), states.shape[:-1]

    def value(self, states: np.ndarray) -> np.ndarray:
        """Interpolated value ``(...)`` of ``states (..., ndim)``; <= 0: attackers win."""
        flat, lead = self._states(states)
        return self.grid.interpolate(self.values, flat).reshape(lead)

    def gradient(self, states: np.ndarray) -> np.ndarray:
        """Interpolated gradient ``(..., ndim)`` of the value (per map unit)."""
        flat, lead = self._states(states)
        return self.grid.interpolate_gradient(self.values, flat).reshape(*lead, self.grid.ndim)

    def attacker_wins(self, states: np.ndarray) -> np.ndarray:
        """Whether the attacker side wins from ``states`` (value <= 0)."""
        return self.value(states) <= 0.0

    def attacker_control(self, states: np.ndarray, attacker: int = 0) -> np.ndarray:
        """The paper's optimal attacker heading ``-p_A / |p_A|`` ``(..., 2)``, a unit vector
        (multiply by the attacker speed for a velocity); zero where ``p_A`` vanishes."""
        if not 0 <= attacker < self.num_attackers:
            raise ValueError(f"attacker: expected 0..{self.num_attackers - 1}, got {attacker}")
        p = self.gradient(states)[..., 2 * attacker:2 * attacker + 2]
        return -_unit(p)

    def defender_control(self, states: np.ndarray) -> np.ndarray:
        """The paper's optimal defender heading ``p_D / |p_D|`` ``(..., 2)``, a unit vector;
        zero where ``p_D`` vanishes."""
        return _unit(self.gradient(states)[..., -2:])

    def meta(self) -> dict[str, Any]:
        """The ``meta.json`` contents (design.md section 4)."""
        return {
            "game": self.game,
            "axes": list(self.axes),
            "grid_min": list(self.grid.lo),
            "grid_max": list(self.grid.hi),
            "shape": list(self.grid.shape),
            "attacker_speed": self.attacker_speed,
            "defender_speed": self.defender_speed,
            "capture_radius": self.capture_radius,
            "map": _map_dict(self.game_map),
            "solver": self.solver,
        }

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the directory ``path`` (``value.npy`` + ``meta.json``) and return it.

        Both files are written into a temporary sibling directory that is then renamed into
        place, so an interrupted save leaves no partial directory behind.
        """
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        temporary = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp"))
        try:
            with open(temporary / "value.npy", "wb") as handle:
                np.save(handle, np.ascontiguousarray(self.values), allow_pickle=False)
                handle.flush()
                os.fsync(handle.fileno())
            (temporary / "meta.json").write_text(json.dumps(self.meta(), indent=2) + "\n")
            if path.exists():
                retired = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.",
                                                suffix=".old"))
                os.replace(path, retired / path.name)
                os.replace(temporary, path)
                shutil.rmtree(retired, ignore_errors=True)
            else:
                os.replace(temporary, path)
        except BaseException:
            shutil.rmtree(temporary, ignore_errors=True)
            raise
        return path


def _unit(p: np.ndarray) -> np.ndarray:
    norm = np.linalg.norm(p, axis=-1, keepdims=True)
    safe = np.where(norm > _GRADIENT_FLOOR, norm, 1.0)
    return np.where(norm > _GRADIENT_FLOOR, p / safe, 0.0)


def load_value_function(path: str | os.PathLike[str],
                        game_map: GameMap | None = None) -> ValueFunction:
    """Open a saved value function; ``value.npy`` is memory-mapped read-only.

    With ``game_map`` the file must have been solved on that map. Raises
    ``ValueFunctionError`` naming the problem for a missing, truncated or mismatched file.
    """
    path = Path(path)
    meta_path, value_path = path / "meta.json", path / "value.npy"
    for required in (meta_path, value_path):
        if not required.is_file():
            raise ValueFunctionError(f"{path}: missing {required.name}")
    try:
        meta = json.loads(meta_path.read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise ValueFunctionError(f"{meta_path}: unreadable ({err})") from None
    try:
        game = meta["game"]
        shape = tuple(int(n) for n in meta["shape"])
        grid = Grid(tuple(meta["grid_min"]), tuple(meta["grid_max"]), shape)
        stored_map = GameMap.from_dict(meta["map"])
        speeds = (float(meta["attacker_speed"]), float(meta["defender_speed"]))
        capture_radius = float(meta["capture_radius"])
    except (KeyError, TypeError, ValueError, ScenarioError) as err:
        raise ValueFunctionError(f"{meta_path}: malformed ({err})") from None
    if game not in AXES or list(meta.get("axes", [])) != list(AXES[game]):
        raise ValueFunctionError(f"{meta_path}: unknown game {game!r} or axes {meta.get('axes')}")
    if game_map is not None and meta["map"] != _map_dict(game_map):
        raise ValueFunctionError(f"{meta_path}: solved for another map ({meta['map']}), "
                                 f"not {_map_dict(game_map)}")
    values = _open_values(value_path, shape)
    return ValueFunction(values=values, grid=grid, game=game, attacker_speed=speeds[0],
                         defender_speed=speeds[1], capture_radius=capture_radius,
                         game_map=stored_map, solver=dict(meta.get("solver", {})))


def _open_values(value_path: Path, shape: tuple[int, ...]) -> np.ndarray:
    try:
        values = np.load(value_path, mmap_mode="r", allow_pickle=False)
    except (OSError, ValueError, EOFError) as err:
        raise ValueFunctionError(f"{value_path}: not a readable .npy file, truncated or "
                                 f"corrupt ({err})") from None
    if tuple(values.shape) != shape:
        raise ValueFunctionError(f"{value_path}: shape {tuple(values.shape)} does not match "
                                 f"meta.json shape {shape}")
    if values.dtype != np.float32 or not values.flags.c_contiguous:
        raise ValueFunctionError(f"{value_path}: expected a C-order float32 array, got "
                                 f"{values.dtype}")
    expected = values.offset + values.nbytes
    actual = value_path.stat().st_size
    if actual != expected:
        raise ValueFunctionError(f"{value_path}: {actual} bytes, expected {expected} for "
                                 f"shape {shape} (truncated or corrupt)")
    return values

"""A solved reach-avoid game: interpolated values, gradients, optimal controls, files.

Sign convention (design.md section 4): value <= 0 exactly where the attacker side wins.
On disk a solved game is a directory ``NAME.vf/`` with ``value.npy`` (float32, C order,
opened with ``mmap_mode="r"``) and ``meta.json``. Under exchange symmetry ``value.npy``
holds the stored rows only (``layout``): ``(stored rows, m)``; any state is answered
from them by index mapping.
"""

from __future__ import annotations

import errno
import fcntl
import json
import math
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from reachavoid_env import GameMap, ScenarioError
from reachavoid_env.rules import unit_vectors
from solvers.hj.game import Player
from solvers.hj.grid import Grid
from solvers.hj.layout import Layout, layout_of
from solvers.hj.settings import SOLVER_VERSION

_GRADIENT_FLOOR = 1e-9
VALUE_FILES = ("meta.json", "value.npy")
"""The files of a value directory (``save``), which only this program writes."""
_CHUNK = 1 << 24
_META_BYTES = 1 << 24


class ValueFunctionError(ValueError):
    """A value-function directory is missing, truncated or does not match what was asked."""


class OutputPathError(ValueError):
    """A save would replace something that is not a value directory written by us."""


def _map_dict(game_map: GameMap) -> dict[str, Any]:
    """The map's TOML table as it reads back from JSON (lists, floats)."""
    return json.loads(json.dumps(game_map.to_dict()))


@dataclass(frozen=True, eq=False)
class ValueFunction:
    """The value of a game on a grid (axes: each player's ``x``, ``y`` in ``players`` order).

    ``values`` is the grid's array, or, when ``symmetries`` (groups of exchangeable
    players' names) are given, the stored rows of ``layout``; it may be a read-only
    memory map of ``value.npy``. ``parameters``: the game's (``capture_radius``...).
    States are arrays ``(..., ndim)`` in axis order (``axes``), map units.
    """

    values: np.ndarray
    grid: Grid
    game: str
    players: tuple[Player, ...]
    game_map: GameMap
    parameters: dict[str, float] = field(default_factory=dict)
    symmetries: tuple[tuple[str, ...], ...] = ()
    solver: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.grid.ndim != 2 * len(self.players):
            raise ValueError(f"grid: the {self.game} game needs {2 * len(self.players)} axes, "
                             f"got {self.grid.ndim}")
        expected = self.layout.stored_shape if self.symmetries else self.grid.shape
        if tuple(self.values.shape) != tuple(expected) or self.values.dtype != np.float32:
            raise ValueError(f"values: expected float32 {tuple(expected)}, got "
                             f"{self.values.dtype} {tuple(self.values.shape)}")

    @cached_property
    def layout(self) -> Layout:
        names = [p.name for p in self.players]
        return layout_of(self.grid, tuple(tuple(names.index(n) for n in g)
                                          for g in self.symmetries))

    @property
    def axes(self) -> tuple[str, ...]:
        return tuple(a for p in self.players for a in p.axes)

    @cached_property
    def attackers(self) -> tuple[Player, ...]:
        return tuple(p for p in self.players if p.role == "attacker")

    @cached_property
    def defenders(self) -> tuple[Player, ...]:
        return tuple(p for p in self.players if p.role == "defender")

    @property
    def num_attackers(self) -> int:
        return len(self.attackers)

    @property
    def attacker_speed(self) -> float:
        return self.attackers[0].speed

    @property
    def defender_speed(self) -> float:
        return self.defenders[0].speed

    @property
    def capture_radius(self) -> float:
        return float(self.parameters["capture_radius"])

    @property
    def stored_of(self) -> np.ndarray:
        """Stored row of every row (``layout``); one row when the array is held whole."""
        return self._rows[1]

    def stored_values(self) -> np.ndarray:
        """The values as stored rows ``(rows, m)`` (one row when held whole)."""
        return self.values if self.symmetries else self.values.reshape(1, -1)

    @cached_property
    def _rows(self) -> tuple[np.ndarray, np.ndarray]:
        """``stored_values()`` as a plain array (a view, also of a memory map) and
        ``stored_of``: what the interpolation kernels read, made once."""
        stored_of = self.layout.stored_of if self.symmetries else np.zeros(1, dtype=np.int64)
        return np.asarray(self.stored_values()), stored_of

    def full_values(self) -> np.ndarray:
        """The value on every node, ``grid.shape`` (expands stored rows: small grids)."""
        return self.layout.full(self.values) if self.symmetries else np.asarray(self.values)

    def _states(self, states: np.ndarray) -> tuple[np.ndarray, tuple[int, ...]]:
        states = np.asarray(states, dtype=np.float64)
        if states.shape[-1:] != (self.grid.ndim,):
            raise ValueError(f"states: expected shape (..., {self.grid.ndim}) with axes "
                             f"{self.axes}, got {states.shape}")
        return states.reshape(-1, self.grid.ndim), states.shape[:-1]

    def value(self, states: np.ndarray) -> np.ndarray:
        """Interpolated value ``(...)`` of ``states (..., ndim)``; <= 0: attackers win."""
        flat, lead = self._states(states)
        rows, stored_of = self._rows
        return self.grid.interpolate(rows, flat, stored_of).reshape(lead)

    def gradient(self, states: np.ndarray) -> np.ndarray:
        """Interpolated gradient ``(..., ndim)`` of the value (per map unit)."""
        flat, lead = self._states(states)
        rows, stored_of = self._rows
        gradient = self.grid.interpolate_gradient(rows, flat, stored_of)
        return gradient.reshape(*lead, self.grid.ndim)

    def value_and_gradient(self, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``value`` and ``gradient`` of ``states (..., ndim)`` in one lookup: ``(...)``
        and ``(..., ndim)``, equal to the two calls' results."""
        flat, lead = self._states(states)
        rows, stored_of = self._rows
        value, gradient = self.grid.interpolate_with_gradient(rows, flat, stored_of)
        return value.reshape(lead), gradient.reshape(*lead, self.grid.ndim)

    def attacker_wins(self, states: np.ndarray) -> np.ndarray:
        """Whether the attacker side wins from ``states`` (value <= 0)."""
        return self.value(states) <= 0.0

    def control(self, states: np.ndarray, player: str) -> np.ndarray:
        """The optimal heading ``(..., 2)`` of ``player``, a unit vector (times the speed for
        a velocity): ``-p / |p|`` for an attacker (minimiser), ``p / |p|`` for a defender,
        with ``p`` the value's gradient along the player's axes; zero where ``p`` vanishes.
        Only those two components of the gradient are computed."""
        k, axes = self._player_axes(player)
        flat, lead = self._states(states)
        rows, stored_of = self._rows
        gradient = self.grid.interpolate_gradient(rows, flat, stored_of, axes)
        return self._heading(gradient.reshape(*lead, 2), k)

    def value_and_control(self, states: np.ndarray, player: str
                          ) -> tuple[np.ndarray, np.ndarray]:
        """``value`` ``(...)`` and ``control`` ``(..., 2)`` of ``player`` at ``states
        (..., ndim)`` in one lookup, equal to the two calls' results."""
        k, axes = self._player_axes(player)
        flat, lead = self._states(states)
        rows, stored_of = self._rows
        value, gradient = self.grid.interpolate_with_gradient(rows, flat, stored_of, axes)
        return value.reshape(lead), self._heading(gradient.reshape(*lead, 2), k)

    def _player_axes(self, player: str) -> tuple[int, np.ndarray]:
        """``player``'s index and its two axes (int64)."""
        found = self._player_axis_table.get(player)
        if found is None:
            raise ValueError(f"player: expected one of {list(self._player_axis_table)}, got "
                             f"{player!r}")
        return found

    @cached_property
    def _player_axis_table(self) -> dict[str, tuple[int, np.ndarray]]:
        return {p.name: (k, np.array([2 * k, 2 * k + 1], dtype=np.int64))
                for k, p in enumerate(self.players)}

    def _heading(self, gradient: np.ndarray, k: int) -> np.ndarray:
        """Player ``k``'s optimal heading from the value's gradient along its axes
        ``(..., 2)``."""
        heading = unit_vectors(gradient, _GRADIENT_FLOOR)
        return -heading if self.players[k].role == "attacker" else heading

    def attacker_control(self, states: np.ndarray, attacker: int = 0) -> np.ndarray:
        """``control`` of the ``attacker``-th attacker (the paper's ``-p_A / |p_A|``)."""
        if not 0 <= attacker < self.num_attackers:
            raise ValueError(f"attacker: expected 0..{self.num_attackers - 1}, got {attacker}")
        return self.control(states, self.attackers[attacker].name)

    def defender_control(self, states: np.ndarray, defender: int = 0) -> np.ndarray:
        """``control`` of the ``defender``-th defender (the paper's ``p_D / |p_D|``)."""
        if not 0 <= defender < len(self.defenders):
            raise ValueError(f"defender: expected 0..{len(self.defenders) - 1}, got {defender}")
        return self.control(states, self.defenders[defender].name)

    def meta(self) -> dict[str, Any]:
        """The ``meta.json`` contents (design.md section 4), without the checksum."""
        return {
            "game": self.game,
            "axes": list(self.axes),
            "players": [[p.name, p.role, p.speed] for p in self.players],
            "symmetries": [list(g) for g in self.symmetries],
            "stored_shape": list(self.values.shape),
            "grid_min": list(self.grid.lo),
            "grid_max": list(self.grid.hi),
            "shape": list(self.grid.shape),
            "attacker_speed": self.attacker_speed,
            "defender_speed": self.defender_speed,
            "parameters": dict(self.parameters),
            "capture_radius": self.parameters.get("capture_radius"),
            "map": _map_dict(self.game_map),
            "solver": self.solver,
        }

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the directory ``path`` (``value.npy`` + ``meta.json``) and return it.

        Both files are written into a temporary sibling directory (``owned_temporaries``)
        that is then renamed into place, so an interrupted save leaves no partial directory
        behind; a failed write is an ``OSError`` naming ``path``. An existing ``path`` is
        replaced only when it is a value directory (``OutputPathError`` otherwise, naming
        it). When another process renames its entry into place first, theirs is kept when it
        holds the same values.
        """
        path = Path(os.path.abspath(path))   # "." has a name and a parent
        refuse_foreign(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        try:
            with owned_temporaries(path) as stem:
                temporary = stem.with_name(stem.name + ".tmp")
                temporary.mkdir(mode=0o777 & ~_umask())
                try:
                    with open(temporary / "value.npy", "wb") as handle:
                        np.save(handle, np.ascontiguousarray(self.values), allow_pickle=False)
                        handle.flush()
                        os.fsync(handle.fileno())
                    meta = self.meta() | {"checksum": checksum(self.values)}
                    (temporary / "meta.json").write_text(json.dumps(meta, indent=2) + "\n")
                    _move_into_place(temporary, path, meta, stem.with_name(stem.name + ".old"))
                finally:
                    shutil.rmtree(temporary, ignore_errors=True)
        except OSError as err:
            if err.filename is None:   # numpy's "N requested and M written" names no file
                raise OSError(err.errno or errno.EIO, err.strerror or str(err), str(path)) from None
            raise
        return path


@contextmanager
def owned_temporaries(path: Path) -> Iterator[Path]:
    """A fresh name stem ``.NAME.PID.RANDOM`` beside ``path`` for this process's temporaries
    (``STEM.tmp``, ``STEM.old``), guarded by an exclusive ``flock`` on ``STEM.lock`` held
    until they are gone: a lock another process can take marks them abandoned
    (``abandoned``), whichever machine or PID namespace wrote them. Plain ``flock``, not
    ``filelock``: the lock is a fresh name made by ``mkstemp`` (exclusive, mode 0600), and
    ``abandoned`` must probe a lock without ever creating one, as ``FileLock.acquire`` does."""
    handle, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.{os.getpid()}.",
                                    suffix=".lock")
    lock = Path(name)
    try:
        fcntl.flock(handle, fcntl.LOCK_EX)
        yield lock.with_suffix("")
    finally:
        lock.unlink(missing_ok=True)
        os.close(handle)


def abandoned(lock: Path) -> bool:
    """Whether the temporaries of ``lock`` (``owned_temporaries``) lost their owner: the lock
    can be taken. A lock that cannot be opened counts as held."""
    try:
        handle = os.open(lock, os.O_RDWR)
    except OSError:
        return False
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False
    finally:
        os.close(handle)
    return True


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def is_value_directory(path: Path) -> bool:
    """Whether ``path`` is a directory holding only what ``save`` writes."""
    if not path.is_dir():
        return False
    names = {p.name for p in path.iterdir()}
    if not names <= set(VALUE_FILES) or "meta.json" not in names:
        return False
    try:
        meta = _read_meta(path / "meta.json")
    except ValueFunctionError:
        return False
    return "game" in meta and "axes" in meta


def refuse_foreign(path: Path) -> None:
    """Raise ``OutputPathError`` unless ``path`` is absent, an empty folder or a value
    directory (what a save may replace)."""
    if not path.exists() and not path.is_symlink():
        return
    if path.is_dir() and not path.is_symlink() and not any(path.iterdir()):
        return
    if path.is_symlink() or not is_value_directory(path):
        raise OutputPathError(f"{path}: exists and is not a value directory (meta.json and "
                              "value.npy only); refusing to replace it")


def _move_into_place(temporary: Path, path: Path, meta: dict[str, Any], retired: Path) -> None:
    if path.is_dir() and not path.is_symlink() and not any(path.iterdir()):
        # an empty folder (perhaps the working directory) is filled, meta.json last
        for name in reversed(VALUE_FILES):
            os.replace(temporary / name, path / name)
        return
    if not path.exists():
        try:
            os.replace(temporary, path)
            return
        except OSError:
            if not path.exists():
                raise
    # someone else's entry is there (or appeared since the check): keep an identical one
    if _same_entry(path, meta):
        return
    refuse_foreign(path)
    os.replace(path, retired)
    os.replace(temporary, path)
    shutil.rmtree(retired, ignore_errors=True)


def _same_entry(path: Path, meta: dict[str, Any]) -> bool:
    """Whether ``path`` holds the same values and metadata (solver timings aside)."""
    try:
        theirs = _read_meta(path / "meta.json")
        size = (path / "value.npy").stat().st_size
    except (OSError, ValueFunctionError):
        return False
    ours = json.loads(json.dumps(meta))
    return (size > 0
            and {k: v for k, v in theirs.items() if k != "solver"}
            == {k: v for k, v in ours.items() if k != "solver"})


def checksum(values: np.ndarray) -> str:
    """A cheap checksum of float32 ``values``: their count and the wrapping sums of the raw
    32-bit words, plain and weighted by the chunk they fall in (catches edits, truncation
    and fills; not a cryptographic hash)."""
    words = np.asarray(values).reshape(-1).view(np.uint32)
    plain = weighted = 0
    for index, start in enumerate(range(0, words.size, _CHUNK)):
        part = int(words[start:start + _CHUNK].sum(dtype=np.uint64))
        plain += part
        weighted += (index + 1) * part
    return f"{words.size}:{plain % (1 << 64):016x}:{weighted % (1 << 64):016x}"


def all_finite(values: np.ndarray) -> bool:
    flat = np.asarray(values).reshape(-1)
    return all(np.isfinite(flat[s:s + _CHUNK]).all() for s in range(0, flat.size, _CHUNK))


def load_value_function(path: str | os.PathLike[str], game_map: GameMap | None = None,
                        verify: bool = False) -> ValueFunction:
    """Open a saved value function; ``value.npy`` is memory-mapped read-only.

    With ``game_map`` the file must have been solved on that map. With ``verify`` the
    values are read once: finite, and equal to the checksum in ``meta.json``. Raises
    ``ValueFunctionError`` naming the problem for a missing, truncated, corrupt or
    mismatched file, or one written by another solver version.
    """
    path = Path(path)
    meta_path, value_path = path / "meta.json", path / "value.npy"
    for required in (meta_path, value_path):
        if not required.is_file():
            raise ValueFunctionError(f"{path}: missing {required.name}")
    meta = _read_meta(meta_path)
    solver = meta.get("solver")
    version = solver.get("version") if isinstance(solver, dict) else None
    if version != SOLVER_VERSION:
        raise ValueFunctionError(f"{meta_path}: written by solver version {version}, this is "
                                 f"version {SOLVER_VERSION}")
    try:
        shape = tuple(int(n) for n in meta["shape"])
        stored_shape = tuple(int(n) for n in meta["stored_shape"])
        symmetries = tuple(tuple(str(n) for n in g) for g in meta["symmetries"])
        values = _open_values(value_path, stored_shape)
        _check_sizes(shape, stored_shape, symmetries)
        grid = Grid(tuple(meta["grid_min"]), tuple(meta["grid_max"]), shape)
        players = tuple(Player(str(n), role, float(v)) for n, role, v in meta["players"])
        stored_map = GameMap.from_dict(meta["map"])
        parameters = {str(k): float(v) for k, v in meta["parameters"].items()}
    except (KeyError, TypeError, AttributeError, ValueError, ScenarioError) as err:
        if isinstance(err, ValueFunctionError):
            raise
        raise ValueFunctionError(f"{meta_path}: malformed ({err})") from None
    if game_map is not None and meta["map"] != _map_dict(game_map):
        raise ValueFunctionError(f"{meta_path}: solved for another map ({meta['map']}), "
                                 f"not {_map_dict(game_map)}")
    if verify:
        if not all_finite(values):
            raise ValueFunctionError(f"{value_path}: holds NaN or infinite values")
        if checksum(values) != meta.get("checksum"):
            raise ValueFunctionError(f"{value_path}: checksum differs from meta.json (edited "
                                     "or corrupt)")
    try:
        return ValueFunction(values=values, grid=grid, game=str(meta["game"]), players=players,
                             game_map=stored_map, parameters=parameters, symmetries=symmetries,
                             solver=dict(meta.get("solver", {})))
    except ValueError as err:
        raise ValueFunctionError(f"{meta_path}: inconsistent ({err})") from None


def _read_meta(meta_path: Path) -> dict[str, Any]:
    """``meta.json`` as a dict, ``ValueFunctionError`` for anything else (too large, too
    deeply nested, not JSON)."""
    try:
        if meta_path.stat().st_size > _META_BYTES:
            raise ValueFunctionError(f"{meta_path}: over {_META_BYTES} bytes")
        meta = json.loads(meta_path.read_text())
    except (OSError, ValueError, RecursionError) as err:
        if isinstance(err, ValueFunctionError):
            raise
        reason = "nested too deeply" if isinstance(err, RecursionError) else err
        raise ValueFunctionError(f"{meta_path}: unreadable ({reason})") from None
    if not isinstance(meta, dict):
        raise ValueFunctionError(f"{meta_path}: not a JSON object")
    return meta


def _check_sizes(shape: tuple[int, ...], stored_shape: tuple[int, ...],
                 symmetries: tuple[tuple[str, ...], ...]) -> None:
    """Check ``meta.json``'s grid ``shape`` against the array on disk (``stored_shape``,
    already checked against the file) before anything is sized from it: whole, or stored
    rows of the last player's plane, at most one per ordering of each exchangeable group."""
    if len(shape) < 2 or min(shape) < 1 or len(stored_shape) != (2 if symmetries else len(shape)):
        raise ValueFunctionError(f"shape {shape} does not fit the stored {stored_shape}")
    if not symmetries:
        if shape != stored_shape:
            raise ValueFunctionError(f"shape {shape} differs from the stored {stored_shape}")
        return
    orderings = math.prod(math.factorial(len(group)) for group in symmetries)
    rows = math.prod(shape[:-2])
    if stored_shape[1] != shape[-2] * shape[-1] or rows > stored_shape[0] * orderings:
        raise ValueFunctionError(f"shape {shape} does not fit the stored rows {stored_shape}")


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

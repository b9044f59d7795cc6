"""On-disk cache of solved games: ``$REACHAVOID_CACHE_DIR`` (default ``~/.cache/reachavoid``).

An entry is a value-function directory named ``<game>-<grid>-<hash>.vf`` where the hash
covers everything that decides the values: the game, map, speeds, parameters, grid, the
value-relevant solver settings, the solver version and any lower game's value used. An
entry is trusted only after it loads and matches what was asked (every key field, the
solver version, finite values equal to their checksum); otherwise it is solved again and
replaced, with one line saying why. Opening the cache removes the temporaries
(``.NAME.PID.*.tmp`` / ``.old``) of processes that no longer run.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from reachavoid_env import GameMap
from solvers.hj.value import ValueFunction, ValueFunctionError, load_value_function

_TEMPORARY = re.compile(r"^\..+\.vf\.(?P<pid>\d+)\.[^.]+\.(tmp|old)$")


def cache_dir() -> Path:
    """The cache directory (not created here)."""
    configured = os.environ.get("REACHAVOID_CACHE_DIR")
    return Path(configured) if configured else Path.home() / ".cache" / "reachavoid"


def cache_key(parts: dict[str, Any]) -> str:
    """A short stable hash of JSON-serialisable ``parts``."""
    text = json.dumps(parts, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def cache_path(game: str, shape: tuple[int, ...], parts: dict[str, Any]) -> Path:
    """Where the entry for ``parts`` lives."""
    return cache_dir() / f"{game}-{shape[0]}-{cache_key(parts)}.vf"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def remove_stale_temporaries(folder: Path) -> list[Path]:
    """Remove the temporaries of dead processes in ``folder``; returns what was removed."""
    removed = []
    try:
        entries = list(folder.iterdir())
    except OSError:
        return removed
    for entry in entries:
        match = _TEMPORARY.match(entry.name)
        if match and int(match["pid"]) != os.getpid() and not _alive(int(match["pid"])):
            shutil.rmtree(entry, ignore_errors=True)
            removed.append(entry)
    return removed


def _mismatch(vf: ValueFunction, expected: Mapping[str, Any]) -> str | None:
    meta = vf.meta()
    for key, value in json.loads(json.dumps(expected)).items():
        if key == "scheme":
            if vf.solver.get("scheme") != value:
                return f"scheme {vf.solver.get('scheme')!r} instead of {value!r}"
        elif meta.get(key) != value:
            return f"{key} {meta.get(key)} instead of {value}"
    return None


def _warn(message: str) -> None:
    """One line on stderr (no source line: the warning is attributed to the cache)."""
    warnings.warn_explicit(message, RuntimeWarning, filename="reachavoid cache", lineno=0)


def cached(game: str, shape: tuple[int, ...], parts: dict[str, Any], expected: Mapping[str, Any],
           game_map: GameMap, solve: Callable[[], ValueFunction]) -> ValueFunction:
    """Load the cached solve of ``parts`` or run ``solve``, store it and return it.

    ``expected``: ``meta.json`` fields the entry must have (``ValueFunction.meta`` keys, and
    ``scheme``). The returned value function reads its values from the cache file
    (memory-mapped).
    """
    folder = cache_dir()
    remove_stale_temporaries(folder)
    path = cache_path(game, shape, parts)
    if path.exists():
        try:
            vf = load_value_function(path, game_map=game_map, verify=True)
            problem = _mismatch(vf, expected)
            if problem is None:
                return vf
        except ValueFunctionError as err:
            problem = str(err)
        _warn(f"cached value function {path} is unusable ({problem}); solving again")
        shutil.rmtree(path, ignore_errors=True)
    vf = solve()
    vf.save(path)
    return load_value_function(path, game_map=game_map)

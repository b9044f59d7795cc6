"""On-disk cache of solved games: ``$REACHAVOID_CACHE_DIR`` (default ``~/.cache/reachavoid``).

An entry is a value-function directory named ``<game>-<grid>-<hash>.vf`` where the hash
covers everything that decides the values: map, speeds, capture radius, grid, the
value-relevant solver settings, the solver version and, for 2 vs 1, the 1 vs 1 value used.
A cached entry that fails to load (truncated, mismatched) is solved again and replaced.
"""

from __future__ import annotations

import hashlib
import json
import os
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

from reachavoid_env import GameMap
from solvers.hj.value import ValueFunction, ValueFunctionError, load_value_function


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


def cached(game: str, shape: tuple[int, ...], parts: dict[str, Any], game_map: GameMap,
           solve: Callable[[], ValueFunction]) -> ValueFunction:
    """Load the cached solve of ``parts`` or run ``solve``, store it and return it.

    The returned value function reads its values from the cache file (memory-mapped).
    """
    path = cache_path(game, shape, parts)
    if path.exists():
        try:
            vf = load_value_function(path, game_map=game_map)
            if vf.grid.shape == tuple(shape):
                return vf
            problem = f"grid {vf.grid.shape} instead of {tuple(shape)}"
        except ValueFunctionError as err:
            problem = str(err)
        warnings.warn(f"cached value function {path} is unusable ({problem}); solving again",
                      RuntimeWarning, stacklevel=3)
    vf = solve()
    vf.save(path)
    return load_value_function(path, game_map=game_map)

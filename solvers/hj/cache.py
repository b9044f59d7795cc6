"""On-disk cache of solved games: ``$REACHAVOID_CACHE_DIR``, else the platform's user cache
folder (``platformdirs``: ``$XDG_CACHE_HOME/reachavoid``, by default ``~/.cache/reachavoid``,
on Linux; ``~/Library/Caches/reachavoid`` on macOS).

An entry is a value-function directory named ``<game>-<grid>-<hash>.vf`` where the hash
covers everything that decides the values: the game, map, speeds, parameters, grid, every
solver setting (``SolverSettings.to_dict``), the solver version and any lower game's value
used. An entry is trusted only after it loads and matches what was asked (every key field,
the solver version, finite values equal to their checksum); otherwise (whatever is there: an
edited ``meta.json``, a link, a plain file) it is removed, solved again and replaced, with
one line saying why. A cache that cannot be written is read, and new solves are not kept.
Storing an entry removes the temporaries (``.NAME.PID.RANDOM.tmp`` / ``.old``) whose
owner's lock (``value.owned_temporaries``) can be taken: their process is gone, whichever
machine or PID namespace it ran in. The generated kernels live in ``kernels/``
(``codegen.kernel_dir``). Numba's own cache of compiled code (pickled, so loading it runs
code) goes where ``$NUMBA_CACHE_DIR`` (or a ``.numba_config.yaml``) says only when that is a
folder of this user's that nobody else can write
(``reachavoid_env.jit_cache.check_numba_cache``), checked before any compiled function can
be loaded.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import time
import warnings
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import platformdirs

from reachavoid_env import GameMap
from reachavoid_env.files import UnsafeFolderError, private_folder
from reachavoid_env.jit_cache import CacheLocationError, check_numba_cache, location_error
from solvers.hj.value import ValueFunction, ValueFunctionError, abandoned, load_value_function

_TEMPORARY = re.compile(r"^(?P<stem>\..+\.vf\.\d+\.[^.]+)\.(tmp|old|lock)$")
UNLOCKED_AGE = 7 * 24 * 3600.0
"""Seconds after which a temporary without a lock file (written by an older version) is
removed: far above any solve."""


def cache_dir() -> Path:
    """The cache directory (not created here): ``$REACHAVOID_CACHE_DIR``, else the user
    cache folder (module docstring)."""
    configured = os.environ.get("REACHAVOID_CACHE_DIR")
    return Path(configured or platformdirs.user_cache_dir("reachavoid", appauthor=False))


def check_cache() -> bool:
    """Make the cache folder ready before any work: created (mode 0700) where missing.
    Returns whether solves can be stored there; ``CacheLocationError`` naming it and
    ``$REACHAVOID_CACHE_DIR`` when it cannot be a folder of this user's."""
    check_numba_cache()
    folder = cache_dir()
    if folder.exists() and not folder.is_dir():
        raise CacheLocationError(f"cache: {str(folder)!r} ($REACHAVOID_CACHE_DIR) is not a "
                                 "folder")
    try:
        if not folder.exists():
            private_folder(folder)
    except (OSError, UnsafeFolderError) as err:
        raise location_error("cannot create", folder, err) from None
    return os.access(folder, os.W_OK | os.X_OK)


@contextmanager
def failures_named() -> Iterator[None]:
    """An ``OSError`` naming no file while a game is solved and stored (numba saving the
    kernels it compiled, a tube's arrays: a full disk) names the folder written to: the
    cache (and ``$NUMBA_CACHE_DIR`` where set)."""
    try:
        yield
    except OSError as err:
        if err.filename is not None:
            raise
        numba = os.environ.get("NUMBA_CACHE_DIR")
        where = f"{cache_dir()}" + (f" (or $NUMBA_CACHE_DIR {numba})" if numba else "")
        raise OSError(err.errno, f"{err.strerror or err} (solving and storing a tube)",
                      where) from None


def cache_key(parts: dict[str, Any]) -> str:
    """A short stable hash of JSON-serialisable ``parts``."""
    text = json.dumps(parts, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def cache_path(game: str, shape: tuple[int, ...], parts: dict[str, Any]) -> Path:
    """Where the entry for ``parts`` lives."""
    return cache_dir() / f"{game}-{shape[0]}-{cache_key(parts)}.vf"


def remove_stale_temporaries(folder: Path) -> list[Path]:
    """Remove the abandoned temporaries in ``folder`` (module docstring); returns them."""
    removed = []
    try:
        entries = list(folder.iterdir())
    except OSError:
        return removed
    stems = {}
    for entry in entries:
        match = _TEMPORARY.match(entry.name)
        if match:
            stems.setdefault(match["stem"], []).append(entry)
    for stem, found in stems.items():
        lock = folder / f"{stem}.lock"
        if lock in found:
            gone = abandoned(lock)
        else:
            gone = all(_age(entry) > UNLOCKED_AGE for entry in found)
        if gone:
            for entry in sorted(found, key=lambda e: e == lock):   # the lock last
                _discard(entry)
                removed.append(entry)
    return removed


def _age(path: Path) -> float:
    try:
        return time.time() - path.lstat().st_mtime
    except OSError:
        return 0.0


def _discard(path: Path) -> None:
    """Remove the cache's own ``path`` (a folder, file or link); ``OSError`` if it stays."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        path.unlink(missing_ok=True)


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
    (memory-mapped), or from memory when the cache cannot be written.
    """
    folder = cache_dir()
    path = cache_path(game, shape, parts)
    writable = check_cache()
    if os.path.lexists(path):
        try:
            vf = load_value_function(path, game_map=game_map, verify=True)
            problem = _mismatch(vf, expected)
            if problem is None:
                return vf
        except (ValueFunctionError, OSError) as err:
            problem = str(err)
        _warn(f"cached value function {path} is unusable ({problem}); solving again")
        if writable:
            _discard(path)
    if not writable:
        _warn(f"cache {folder} ($REACHAVOID_CACHE_DIR) is not writable; this solve is not kept")
        return solve()
    remove_stale_temporaries(folder)
    vf = solve()
    vf.save(path)
    return load_value_function(path, game_map=game_map)

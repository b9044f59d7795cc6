"""Where numba may keep compiled code: the one check every module of cached numba functions
runs as it loads, and the error every cache location problem is reported with.

numba's cache holds pickled code, so loading it runs code: it goes where
``$NUMBA_CACHE_DIR`` (or a ``.numba_config.yaml`` in the working folder) says only when
that passes ``private_folder`` (a folder of this user's, mode 0700, not a link, under
folders only their owner can write). One rule wherever numba caches anything of ours:
the env's lidar kernels, the solvers' kernels and the policies' lookups all run it as
they load. A leaf of the ground floor (it imports ``files`` alone), so that every layer
can import it before anything else.
"""

from __future__ import annotations

import os
from pathlib import Path

from reachavoid_env.files import UnsafeFolderError, private_folder


class CacheLocationError(ValueError):
    """The cache folder cannot be a folder of this user's (reported in one line, exit 2)."""


def location_error(what: str, folder: Path, err: Exception) -> CacheLocationError:
    """``CacheLocationError``: ``what`` went wrong at ``folder`` because of ``err``."""
    reason = f"{err.filename}: {err.strerror}" if isinstance(err, OSError) else str(err)
    return CacheLocationError(f"cache: {what} {str(folder)!r} ({reason}); set "
                              "$REACHAVOID_CACHE_DIR to a folder of yours")


def _numba_cache_error(folder: str, err: Exception) -> CacheLocationError:
    reason = f"{err.filename}: {err.strerror}" if isinstance(err, OSError) else str(err)
    return CacheLocationError(f"cache: $NUMBA_CACHE_DIR {folder!r} is not a safe folder for "
                              f"compiled code ({reason}); unset it or set it to a folder of "
                              "yours with mode 700")


def check_numba_cache(folder: str | None = None) -> None:
    """Refuse a numba cache folder (``folder``, default ``$NUMBA_CACHE_DIR``; nothing when
    unset) that is not a folder of this user's closed to others (``private_folder``;
    created, mode 0700, where missing): numba loads pickled code from it.
    ``CacheLocationError`` naming ``$NUMBA_CACHE_DIR``."""
    folder = os.environ.get("NUMBA_CACHE_DIR") if folder is None else folder
    if not folder:
        return
    try:
        private_folder(folder)
    except (OSError, UnsafeFolderError) as err:
        raise _numba_cache_error(folder, err) from None


def check_numba_config() -> None:
    """``check_numba_cache`` of the folder numba itself reads (its environment or a
    ``.numba_config.yaml``): called by each module of cached numba functions as it loads,
    before any of them can be compiled or loaded."""
    from numba.core import config

    check_numba_cache(config.CACHE_DIR)

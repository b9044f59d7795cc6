"""Writing files so that nothing half-written is ever left at the destination, and folders
that only their owner can write, and files read as code checked the same way (README
"Files and failures").

A write lands on what its path names: through symbolic links on their target, a character
device or FIFO written directly (``/dev/null``, ``/dev/stdout``, a named pipe), ``-`` for
standard output where text is written. A regular file is written to a temporary name
beside it and renamed onto it when complete, keeping an existing file's permissions.

The overwrite rule holds until the end: a destination that was free when it was checked
(``expect_new``) is published with a hard link that fails if a file appeared there
meanwhile (``FileExistsError`` naming it; what appeared is kept), never renamed over it.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import stat
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

STDOUT = "-"
"""The path that means standard output (text outputs only)."""


class UnsafeFolderError(ValueError):
    """A folder (or a file read as code) that others could write to, a link, or one not
    ours: nothing is read from it."""


_EXPECTED_NEW: set[Path] = set()
"""Destinations checked to be free before the work (``expect_new``)."""


def expect_new(path: str | os.PathLike[str]) -> None:
    """Note that ``path``'s destination held no file when checked, so that publishing to
    it never replaces a file that appears there later (``install``)."""
    target = destination(path)
    if not os.path.lexists(target):
        _EXPECTED_NEW.add(target)


def forget_expected() -> None:
    """Drop every ``expect_new`` (a command's end)."""
    _EXPECTED_NEW.clear()


@contextmanager
def one_command() -> Iterator[None]:
    """A command's run: the ``expect_new`` notes made within are dropped at its end."""
    try:
        yield
    finally:
        forget_expected()


def _appeared(path: str | os.PathLike[str]) -> FileExistsError:
    return FileExistsError(errno.EEXIST, "a file appeared there while this ran and was kept "
                           "(pass --force to replace it)", str(path))


def _publish_new(temporary: Path, target: Path, path: str | os.PathLike[str]) -> None:
    """Put ``temporary`` at the free ``target``: a hard link, which fails where a file now
    is; where the filesystem has no hard links, a check right before the rename."""
    try:
        os.link(temporary, target)
    except FileExistsError:
        raise _appeared(path) from None
    except OSError as err:
        if err.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV,
                             errno.EMLINK, errno.ENOSYS):
            raise
        if os.path.lexists(target):
            raise _appeared(path) from None
        os.replace(temporary, target)


def destination(path: str | os.PathLike[str]) -> Path:
    """What a write to ``path`` lands on: the final target of any symbolic links (which
    need not exist yet), as an absolute path."""
    return Path(os.path.realpath(path))


def is_stream(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is standard output (``-``), a character device or a FIFO (written
    directly, never replaced)."""
    if str(path) == STDOUT:
        return True
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return False
    return stat.S_ISCHR(mode) or stat.S_ISFIFO(mode)


def install(temporary: Path, path: str | os.PathLike[str]) -> None:
    """Put the finished file ``temporary`` at ``path``: copied into a device or FIFO, else
    renamed onto the link target with the permissions of the file it replaces (the usual
    ``0666 & ~umask`` for a new one); to a destination of ``expect_new``, only while it is
    still free (``FileExistsError`` otherwise). ``temporary`` is gone afterwards either
    way."""
    try:
        if is_stream(path):   # opened by its own name: /dev/stdout may lead to "pipe:[N]"
            with open(temporary, "rb") as source, open(path, "wb") as sink:
                shutil.copyfileobj(source, sink)
            return
        target = destination(path)
        try:
            mode = stat.S_IMODE(os.stat(target).st_mode)
        except FileNotFoundError:
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o666 & ~umask
        os.chmod(temporary, mode)
        if target in _EXPECTED_NEW:
            _publish_new(temporary, target, path)
        else:
            os.replace(temporary, target)
    finally:
        temporary.unlink(missing_ok=True)


@contextmanager
def atomic_write(path: str | os.PathLike[str], mode: str = "w", **open_kwargs: Any) -> Iterator[IO]:
    """Open ``path`` for writing so that it holds its old contents or the whole new file.

    A regular file (new or existing, through links) is written to a temporary file beside
    it and renamed onto it on success (``install``); on any exception (Ctrl-C included) the
    temporary file is removed. A device or FIFO is written directly; ``-`` is standard
    output (text modes only).
    """
    if not any(flag in mode for flag in "wx"):
        raise ValueError(f"mode: expected a writing mode ('w', 'wb'), got {mode!r}")
    mode = mode.replace("x", "w")
    if str(path) == STDOUT:
        if "b" in mode:
            raise ValueError("path: '-' (standard output) takes text only")
        yield sys.stdout
        sys.stdout.flush()
        return
    if is_stream(path):
        try:
            with open(path, mode, **open_kwargs) as handle:
                yield handle
        except OSError as err:
            raise _named(err, path) from None
        return
    target = destination(path)
    if target.is_dir():
        raise IsADirectoryError(21, "Is a directory", str(path))
    handle, name = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.",
                                    suffix=".tmp")
    temporary = Path(name)
    try:
        with os.fdopen(handle, mode, **open_kwargs) as stream:
            yield stream
            stream.flush()
            os.fsync(stream.fileno())
        install(temporary, target)
    except OSError as err:
        temporary.unlink(missing_ok=True)
        raise _named(err, path) from None
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def _named(err: OSError, path: str | os.PathLike[str]) -> OSError:
    """``err`` naming ``path`` where it names no file (a full disk or device)."""
    if err.filename is not None:
        return err
    return OSError(err.errno, err.strerror or str(err), str(path))


def write_json(path: str | os.PathLike[str], data: Any, indent: int = 2) -> None:
    """Write ``data`` as JSON to ``path`` (``atomic_write``: whole or not at all)."""
    with atomic_write(path) as handle:
        json.dump(data, handle, indent=indent)


def _trusted(status: os.stat_result) -> bool:
    """A folder only its owner (us or root) can change, or a sticky one such as ``/tmp``."""
    return (status.st_uid in (os.geteuid(), 0)
            and (not status.st_mode & 0o022 or bool(status.st_mode & stat.S_ISVTX)))


def _check_above(part: Path) -> None:
    """Refuse ``part``, a folder above what is checked, unless it is a folder ``_trusted``."""
    status = os.stat(part)
    if not stat.S_ISDIR(status.st_mode):
        raise NotADirectoryError(20, "Not a directory", str(part))
    if not _trusted(status):
        raise UnsafeFolderError(f"{part}: others can write to this folder (owner uid "
                                f"{status.st_uid}, mode {stat.S_IMODE(status.st_mode):o})")


def trusted_file(path: str | os.PathLike[str]) -> Path:
    """``path``'s file (links resolved) if nobody but this user or root can change it: a
    regular file owned by one of them that its group and others cannot write, in folders
    only their owner (this user or root) can write, or sticky ones such as ``/tmp``. The
    rule of ``private_folder``'s folders, for a file that is read as code (a pickled model):
    checked before anything is read from it. ``UnsafeFolderError`` naming the file or
    folder and the reason; ``OSError`` when it cannot be looked at."""
    target = Path(os.path.realpath(path))
    for part in reversed(target.parents):
        _check_above(part)
    status = os.stat(target)
    if not stat.S_ISREG(status.st_mode):
        raise UnsafeFolderError(f"{target}: not a regular file")
    if status.st_uid not in (os.geteuid(), 0):
        raise UnsafeFolderError(f"{target}: owned by uid {status.st_uid}, not by this user "
                                f"({os.geteuid()}) or root")
    if status.st_mode & 0o022:
        raise UnsafeFolderError(f"{target}: mode {stat.S_IMODE(status.st_mode):o} lets "
                                "others change it")
    return target


def private_folder(path: str | os.PathLike[str]) -> Path:
    """``path`` as a folder only this user can write, created (mode 0700) where missing.

    Every folder created here, and ``path`` itself, must be a real folder (not a link),
    owned by this user and closed to others (``mode & 0o077 == 0`` for ``path``); every
    folder above (links resolved) must be writable by its owner (this user or root) alone,
    or sticky. So nobody else can put a file there or swap the folder. Raises
    ``UnsafeFolderError`` naming the folder and the reason, or ``OSError`` when it cannot
    be created.
    """
    absolute = Path(os.path.abspath(path))
    folder = Path(os.path.realpath(absolute.parent)) / absolute.name
    for part in reversed((folder, *folder.parents)):
        created = False
        if not os.path.lexists(part):
            try:
                os.mkdir(part, 0o700)
                created = True
            except FileExistsError:   # another process made it meanwhile: checked below
                pass
        if part != folder and not created:
            _check_above(part)
            continue
        status = os.lstat(part)
        if stat.S_ISLNK(status.st_mode):
            raise UnsafeFolderError(f"{part}: is a symbolic link")
        if not stat.S_ISDIR(status.st_mode):
            raise NotADirectoryError(20, "Not a directory", str(part))
        if status.st_uid != os.geteuid():
            raise UnsafeFolderError(f"{part}: owned by uid {status.st_uid}, not by this user "
                                    f"({os.geteuid()})")
        if stat.S_IMODE(status.st_mode) & (0o077 if part == folder else 0o022):
            raise UnsafeFolderError(f"{part}: mode {stat.S_IMODE(status.st_mode):o} lets "
                                    "others in (expected 700)")
    return folder

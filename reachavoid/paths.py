"""What the command line names, checked before any work: ``UsageError``, the one-line
error of a bad argument or input file (exit status 2), and the output paths under one rule
(docs/files-and-failures.md): an existing file is replaced only with ``--force``, and only
a regular file; a link is followed to its target; a device or FIFO is written directly."""

from __future__ import annotations

import os
from collections.abc import Collection, Sequence
from pathlib import Path

from reachavoid_env import checks
from reachavoid_env.files import STDOUT, destination, expect_new, is_stream

TEMPORARY_NAME_ROOM = 48
"""Characters an output's temporary names add to its file name (``.NAME.PID.RANDOM.tmp``)."""


class UsageError(checks.FieldError):
    """A bad argument or input file: reported in one line, exit status 2; ``field`` names
    the flag (or the input's field)."""


def reported(err: Exception) -> UsageError:
    """``err`` as a ``UsageError``: the same message and field."""
    return UsageError(str(err), getattr(err, "field", None))


def _check_name(target: Path, field: str, path: str) -> None:
    """Refuse a file name too long for its folder once temporary names are added to it."""
    try:
        limit = os.pathconf(target.parent, "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255
    if len(os.fsencode(target.name)) + TEMPORARY_NAME_ROOM > limit:
        raise UsageError(f"{field}: the name {target.name[:40]!r}... of {path!r} is too long "
                         f"(at most {limit - TEMPORARY_NAME_ROOM} bytes here)", field=field)


def writable_file(path: str, field: str, force: bool = False, text: bool = False) -> str:
    """``path`` if a file can be written there under the overwrite rule (module docstring),
    else ``UsageError`` naming ``field``. A link is followed to its target; a device or FIFO
    is written directly; ``-`` (standard output) only where ``text`` is written."""
    if path == STDOUT:
        if not text:
            raise UsageError(f"{field}: '-' (standard output) is for text outputs only",
                             field=field)
        return path
    if is_stream(path):
        return path
    target = destination(path)
    check_replace(target, field, force, path)
    folder = target.parent
    if not folder.is_dir():
        raise UsageError(f"{field}: folder {str(folder)!r} does not exist", field=field)
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UsageError(f"{field}: folder {str(folder)!r} is not writable", field=field)
    _check_name(target, field, path)
    return path


def check_replace(target: Path, field: str, force: bool, path: str) -> None:
    """The overwrite rule: an existing ``target`` is replaced only with ``force``, and only
    when it is a regular file; a link that never ends (a loop) is refused."""
    if target.is_symlink():   # links resolved (``destination``) and still one: a loop
        raise UsageError(f"{field}: {path!r} is a symbolic link that never ends (a loop)",
                         field=field)
    if target.is_dir():
        raise UsageError(f"{field}: {path!r} is a folder", field=field)
    if target.exists() and not target.is_file():
        raise UsageError(f"{field}: {path!r} is not a regular file, a device or a FIFO",
                         field=field)
    if target.exists() and not force:
        raise UsageError(f"{field}: {path!r} exists; pass --force to replace it", field=field)
    if not force:   # and stays so: a file that appears there meanwhile is not replaced
        expect_new(target)


def distinct_outputs(outputs: Sequence[tuple[str, str | None]]) -> None:
    """Refuse two of ``outputs`` (flag, path or None) that land on the same file, or both on
    standard output (``-``); a device or FIFO may take several."""
    seen: dict[Path | str, str] = {}
    for flag, path in outputs:
        if path is None or (path != STDOUT and is_stream(path)):
            continue
        where = STDOUT if path == STDOUT else destination(path)
        if where in seen:
            what = "standard output" if where == STDOUT else repr(path)
            raise UsageError(f"{flag}: {what} is also {seen[where]}'s output; give each "
                             "output its own file", field=flag)
        seen[where] = flag


def check_outputs(outputs: Sequence[tuple[str, str | os.PathLike[str] | None]], force: bool,
                  folder: Path | None = None, text: Collection[str] = ()) -> None:
    """Every output (flag, path or None) checked before any work, under one rule: a file
    in ``folder`` (an output folder checked by ``writable_folder``, made later where
    missing) new or, with ``force``, replaced (``check_replace``); a file elsewhere
    ``writable_file`` (``-``, standard output, for the flags in ``text`` only); no two on
    one file (``distinct_outputs``)."""
    named = [(flag, None if path is None else os.fspath(path)) for flag, path in outputs]
    distinct_outputs(named)
    for flag, path in named:
        if path is None:
            continue
        target = destination(path)
        if folder is not None and path != STDOUT and target.parent == destination(folder):
            check_replace(target, flag, force, path)
        else:
            writable_file(path, flag, force, text=flag in text)


def writable_folder(path: str, field: str) -> Path:
    """``path`` if it is a writable folder or can be created as one, else ``UsageError``."""
    target = Path(os.path.abspath(path))
    if target.exists() and not target.is_dir():
        raise UsageError(f"{field}: {path!r} exists and is not a folder", field=field)
    existing = target if target.exists() else next(p for p in target.parents if p.exists())
    if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
        raise UsageError(f"{field}: {str(existing)!r} is not a writable folder", field=field)
    _check_name(target, field, path)
    return target

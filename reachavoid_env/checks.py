"""The one set of number validators, for scenario files, env and wrapper arguments and the
command line alike.

Each checks one value, names its ``field`` and the accepted range in a one-line message,
and raises ``error`` (a ``FieldError`` subclass; ``ScenarioError`` for scenario files) whose
``field`` attribute is that field. Booleans are never numbers here, and every real must be
finite.
"""

from __future__ import annotations

import math
import numbers
import os
from typing import Any

import numpy as np


class FieldError(ValueError):
    """A bad value; ``field`` names where it was given (a dotted path in a scenario file, an
    argument, a command-line flag), or is ``None`` when the message names no field. The
    message is one line, and starts with the field where there is one: callers read the
    field from here, never from the message."""

    def __init__(self, message: str, field: str | None = None) -> None:
        super().__init__(message)
        self.field = field

    def renamed(self, field: str) -> str:
        """The message naming ``field`` in place of ``self.field`` (e.g. a command-line
        flag in place of an option's name); unchanged when it names no field."""
        message = str(self)
        if self.field is None or not message.startswith(self.field):
            return message
        return field + message[len(self.field):]


def available_memory() -> int:
    """Bytes the kernel reports as available (``MemAvailable``), or total RAM if unknown:
    what the memory checks before any work compare their needs with."""
    try:
        with open("/proc/meminfo") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def _text(bound: float) -> str:
    return str(int(bound)) if float(bound).is_integer() and abs(bound) < 1e16 else f"{bound:g}"


def _describe(low: float | None, high: float | None, low_open: bool) -> str:
    if low is None and high is None:
        return "a finite number"
    if high is None:
        return f"{'>' if low_open else '>='} {_text(low)}"
    if low is None:
        return f"<= {_text(high)}"
    return f"in {'(' if low_open else '['}{_text(low)}, {_text(high)}]"


def real(value: Any, field: str, low: float | None = None, high: float | None = None, *,
         low_open: bool = False, error: type[FieldError] = FieldError) -> float:
    """``value`` as a finite float in ``[low, high]`` (``(low, high]`` with ``low_open``)."""
    expected = _describe(low, high, low_open)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise error(f"{field}: expected a number {expected}, got {value!r}", field)
    number = float(value)
    if not math.isfinite(number) or (low is not None and (number < low or (
            low_open and number == low))) or (high is not None and number > high):
        raise error(f"{field}: must be {expected}, got {value!r}", field)
    return number


def positive(value: Any, field: str, high: float | None = None, *,
             error: type[FieldError] = FieldError) -> float:
    """``value`` as a finite float in ``(0, high]``."""
    return real(value, field, 0.0, high, low_open=True, error=error)


def integer(value: Any, field: str, low: int | None = None, high: int | None = None, *,
            error: type[FieldError] = FieldError) -> int:
    """``value`` as an int in ``[low, high]`` (numpy integers accepted, floats not)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise error(f"{field}: expected an integer {_describe(low, high, False)}, "
                    f"got {value!r}", field)
    number = int(value)
    if (low is not None and number < low) or (high is not None and number > high):
        raise error(f"{field}: must be an integer {_describe(low, high, False)}, got {value!r}",
                    field)
    return number


def flag(value: Any, field: str, *, error: type[FieldError] = FieldError) -> bool:
    """``value`` as a bool: ``True`` or ``False`` (numpy's too), nothing else."""
    if not isinstance(value, (bool, np.bool_)):
        raise error(f"{field}: expected True or False, got {value!r}", field)
    return bool(value)

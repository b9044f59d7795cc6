"""The one set of number validators, for scenario files, env and wrapper arguments and the
command line alike.

Each checks one value, names its ``field`` and the accepted range in a one-line message,
and raises ``error`` (a ``ValueError`` subclass; ``ScenarioError`` for scenario files).
Booleans are never numbers here, and every real must be finite.
"""

from __future__ import annotations

import math
import numbers
from typing import Any


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
         low_open: bool = False, error: type[ValueError] = ValueError) -> float:
    """``value`` as a finite float in ``[low, high]`` (``(low, high]`` with ``low_open``)."""
    expected = _describe(low, high, low_open)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise error(f"{field}: expected a number {expected}, got {value!r}")
    number = float(value)
    if not math.isfinite(number) or (low is not None and (number < low or (
            low_open and number == low))) or (high is not None and number > high):
        raise error(f"{field}: must be {expected}, got {value!r}")
    return number


def positive(value: Any, field: str, high: float | None = None, *,
             error: type[ValueError] = ValueError) -> float:
    """``value`` as a finite float in ``(0, high]``."""
    return real(value, field, 0.0, high, low_open=True, error=error)


def integer(value: Any, field: str, low: int | None = None, high: int | None = None, *,
            error: type[ValueError] = ValueError) -> int:
    """``value`` as an int in ``[low, high]`` (numpy integers accepted, floats not)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise error(f"{field}: expected an integer {_describe(low, high, False)}, "
                    f"got {value!r}")
    number = int(value)
    if (low is not None and number < low) or (high is not None and number > high):
        raise error(f"{field}: must be an integer {_describe(low, high, False)}, got {value!r}")
    return number

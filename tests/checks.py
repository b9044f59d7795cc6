"""Helpers shared by the test modules."""

from __future__ import annotations

import warnings


def checked(check, *args, **kwargs) -> None:
    """Run a PettingZoo or Gymnasium checker; any warning it raises (missing keys, revived
    agents; deprecations aside) fails the test."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check(*args, **kwargs)
    messages = [str(w.message) for w in caught if w.category is not DeprecationWarning]
    assert messages == []

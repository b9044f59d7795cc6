"""Helpers shared by the test modules."""

from __future__ import annotations

import importlib.util
import sys
import warnings
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]


def checked(check, *args, **kwargs) -> None:
    """Run a PettingZoo or Gymnasium checker; any warning it raises (missing keys, revived
    agents; deprecations aside) fails the test."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check(*args, **kwargs)
    messages = [str(w.message) for w in caught if w.category is not DeprecationWarning]
    assert messages == []


def example(name: str) -> ModuleType:
    """Import ``examples/<name>.py`` as the module ``example_<name>`` (in ``sys.modules``,
    so that its classes pickle)."""
    spec = importlib.util.spec_from_file_location(f"example_{name}",
                                                  ROOT / "examples" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module

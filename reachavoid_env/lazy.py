"""Loading on first use: package faces whose names load their modules when first read
(PEP 562), and work to do right after a library is imported.

Both keep ``import`` cheap: a package face can list its whole API while importing only
what the caller reads, and a registration with a library (PettingZoo, Gymnasium) can wait
until that library is loaded by someone who needs it.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
from collections.abc import Callable, Mapping
from types import ModuleType
from typing import Any


def attributes(package: str, names: Mapping[str, str]) -> tuple[Callable[[str], Any],
                                                                 Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for the face of ``package``: reading ``name`` imports
    the module ``names[name]`` and keeps its attribute ``name`` in the package; reading a
    submodule's name imports the submodule (as an eager face would have)."""

    def __getattr__(name: str) -> Any:
        if name in names:
            value = getattr(importlib.import_module(names[name]), name)
        elif not name.startswith("__") and importlib.util.find_spec(f"{package}.{name}"):
            value = importlib.import_module(f"{package}.{name}")
        else:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(names))

    return __getattr__, __dir__


_AFTER: dict[str, list[Callable[[ModuleType], None]]] = {}
"""Top-level module name -> what to call with the module once it is imported."""


def after_import(name: str, callback: Callable[[ModuleType], None]) -> None:
    """Call ``callback(module)`` once the top-level module ``name`` is imported: now if it
    is loaded already, else right after its import finishes (without importing it)."""
    if name in sys.modules:
        callback(sys.modules[name])
        return
    _AFTER.setdefault(name, []).append(callback)
    if not any(isinstance(finder, _AfterImport) for finder in sys.meta_path):
        sys.meta_path.insert(0, _AfterImport())


class _AfterImport(importlib.abc.MetaPathFinder):
    """Finds nothing itself: wraps the loader of a module ``after_import`` waits for so
    that the callbacks run once the module has executed."""

    def find_spec(self, name: str, path: Any = None,
                  target: Any = None) -> importlib.machinery.ModuleSpec | None:
        callbacks = _AFTER.pop(name, None)
        if callbacks is None:
            return None
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None:
            return spec
        execute = spec.loader.exec_module

        def execute_then_call(module: ModuleType) -> None:
            execute(module)
            for callback in callbacks:
                callback(module)

        spec.loader.exec_module = execute_then_call  # type: ignore[method-assign]
        return spec

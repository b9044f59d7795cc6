"""The floor plan: dependencies point one way, reachavoid -> policies -> solvers ->
reachavoid_env, and docs/design.md names every module of the tree."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ["reachavoid_env", "solvers", "policies", "reachavoid"]
"""Bottom first: a package may import only the packages before it in this list."""


def imported_packages(path: Path) -> set[str]:
    """Top-level names of everything ``path`` imports (any nesting, any branch)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def modules(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


@pytest.mark.parametrize("package", LAYERS)
def test_imports_point_down(package):
    forbidden = set(LAYERS[LAYERS.index(package) + 1:])
    upward = {str(path.relative_to(ROOT)): sorted(imported_packages(path) & forbidden)
              for path in modules(package)}
    assert {path: names for path, names in upward.items() if names} == {}


def test_the_check_sees_imports():
    cli = ROOT / "reachavoid" / "cli.py"
    assert {"policies", "solvers", "reachavoid_env"} <= imported_packages(cli)


def test_design_names_every_module_and_nothing_else():
    design = (ROOT / "docs" / "design.md").read_text()
    tree = {str(path.relative_to(ROOT)) for package in LAYERS for path in modules(package)
            if path.name != "__init__.py"}
    named = {word.strip("`,.;:()") for word in design.split()
             if word.strip("`,.;:()").endswith(".py")}
    missing = sorted(path for path in tree if path not in named)
    stale = sorted(path for path in named if "/" in path and path not in tree
                   and path.split("/")[0] in LAYERS)
    assert missing == [] and stale == []

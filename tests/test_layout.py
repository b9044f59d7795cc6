"""The floor plan: dependencies point one way, reachavoid -> policies -> solvers ->
reachavoid_env, docs/design.md names every module of the tree, and no module or class is
over the house's sizes."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
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


MAX_MODULE_LINES = 600
MAX_CLASS_LINES = 300
"""The house's sizes: a module (a room) of at most 600 lines, a class of at most 300."""


def oversized(path: Path) -> list[str]:
    """What in ``path`` is over the house's sizes: the module, or a class, with its lines."""
    text = path.read_text()
    lines = len(text.splitlines())
    found = [f"module {lines}"] if lines > MAX_MODULE_LINES else []
    found += [f"class {node.name} {node.end_lineno - node.lineno + 1}"
              for node in ast.walk(ast.parse(text, filename=str(path)))
              if isinstance(node, ast.ClassDef)
              and node.end_lineno - node.lineno + 1 > MAX_CLASS_LINES]
    return found


def test_rooms_and_classes_keep_the_house_sizes():
    paths = [path for folder in (*LAYERS, "benchmarks", "examples")
             for path in sorted((ROOT / folder).rglob("*.py"))]
    big = {str(path.relative_to(ROOT)): oversized(path) for path in paths}
    assert {path: found for path, found in big.items() if found} == {}


def test_the_size_check_sees_a_big_class(tmp_path):
    body = "\n".join(f"    x{k} = {k}" for k in range(MAX_CLASS_LINES))
    (tmp_path / "big.py").write_text(f"class Big:\n{body}\n")
    assert oversized(tmp_path / "big.py") == [f"class Big {MAX_CLASS_LINES + 1}"]


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


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


PROJECT = {module_name(path): path for package in LAYERS for path in modules(package)}
"""Every module of the project by dotted name (a package by its ``__init__``)."""


def imported_modules(path: Path) -> set[str]:
    """Project modules ``path`` imports (any nesting and branch, ``if TYPE_CHECKING:``
    blocks included: a type-only import is an edge too): ``from package import name``
    counts as importing ``package.name`` when that is a module, else the package."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.update(f"{node.module}.{alias.name}" if f"{node.module}.{alias.name}"
                         in PROJECT else node.module for alias in node.names)
    return {name for name in names if name in PROJECT}


def import_circles() -> list[list[str]]:
    """The strongly connected groups of two or more modules of the import graph (Tarjan)."""
    graph = {name: imported_modules(path) - {name} for name, path in PROJECT.items()}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    circles = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for child in graph[node]:
            if child not in index:
                visit(child)
                low[node] = min(low[node], low[child])
            elif child in stack:
                low[node] = min(low[node], index[child])
        if low[node] == index[node]:
            group = []
            while not group or group[-1] != node:
                group.append(stack.pop())
            if len(group) > 1:
                circles.append(sorted(group))

    for name in sorted(graph):
        if name not in index:
            visit(name)
    return circles


def test_no_import_circle():
    assert import_circles() == []


def test_the_circle_check_sees_imports():
    assert "reachavoid_env.game_map" in imported_modules(ROOT / "reachavoid_env" / "scenario.py")
    assert "reachavoid_env.scenario" in imported_modules(ROOT / "reachavoid_env" / "world.py")
    assert "reachavoid_env.game_map" in imported_modules(
        ROOT / "reachavoid_env" / "rules.py")  # for type checking only


def printed(code: str) -> str:
    """What ``python -c code`` prints, in a fresh interpreter on this tree."""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    return done.stdout.strip()


def loaded(statement: str, packages: tuple[str, ...]) -> str:
    """Which of ``packages`` are imported after ``statement``, as a printed sorted list."""
    return printed(f"import sys; {statement}; print(sorted(m for m in sys.modules "
                   f"if m.split('.')[0] in {packages!r}))")


def test_the_solver_stands_on_geometry_alone():
    """Importing the HJ solver loads neither the simulator nor its libraries."""
    assert loaded("import solvers.hj", ("pettingzoo", "gymnasium", "pymunk", "pygame")) == "[]"


def test_the_command_line_loads_no_learning_library():
    """``reachavoid`` and its parser (``exploit`` and its budget flags included) load
    neither torch nor Stable-Baselines3 nor matplotlib: the training modules import them
    when they run."""
    assert loaded("import reachavoid, reachavoid.cli; reachavoid.cli.build_parser()",
                  ("torch", "stable_baselines3", "matplotlib")) == "[]"


def test_the_env_registers_when_pettingzoo_is_imported_later():
    assert printed(
        "import sys, reachavoid_env; assert 'pettingzoo' not in sys.modules; "
        "import pettingzoo; env = pettingzoo.make('parallel', reachavoid_env.ENV_ID, "
        "scenario='paper_2v1'); print(type(env).__name__, env.possible_agents)"
    ) == "ReachAvoidEnv ['attacker_0', 'attacker_1', 'defender_0']"

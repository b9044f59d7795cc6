"""The documents: BENCHMARKS.md's figures against the result files, and the code in the docs.

Conventions (BENCHMARKS.md says them to the reader):

- ``BENCHMARKS.md`` opens with one table, the dashboard; each row's ``result`` cell names a
  file under ``benchmarks/results/`` and the keys (shell-style patterns) holding the row's
  figures. Every number of the ``figure`` cell must equal one of those values at the
  precision shown (a number glued to letters, ``8v4``, ``p50``, ``45^4``, is a name).
- In ``README.md`` and ``BENCHMARKS.md``, a figure quoted in prose is a link to its result
  file whose title is the key: ``[81.8%](benchmarks/results/defenders.json "KEY")``; a
  percentage or a rate written outside such a link (and outside code and the dashboard)
  is an error.
- Every ```` ```python ```` block of ``README.md`` and ``docs/*.md`` runs, the blocks of one
  page in order in one namespace, in a scratch folder (a block needing RLlib or BenchMARL
  is skipped where they are not installed). Shell commands are ```` ```bash ````.
- The site builds with ``mkdocs build --strict`` and not one warning (a link out of
  ``docs/``, to a result file, is a broken link there: the pages name result files in
  inline code).
"""

from __future__ import annotations

import fnmatch
import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
FRONT = ("README.md", "BENCHMARKS.md")
DASHBOARD_HEADER = ["what", "command", "figure", "machine", "date", "result"]

_NUMBER = re.compile(r"(?<![\w.^/])([+-]?\d[\d,]*(?:\.\d+)?)(?![\w^]|\.\d)")
_RESULT_LINK = re.compile(r"\[([^\]]+)\]\(benchmarks/results/([\w.-]+\.json)\s+\"([^\"]+)\"\)")
_LINK = re.compile(r"\[[^\]]*\]\([^)]*\)")
_UNLINKED = re.compile(
    r"(?<![\w.])\d[\d,]*(?:\.\d+)?\s?%(?!\s(?:normal|bootstrap|Wilson|interval|CI))"
    r"|\d[\d,]*(?:\.\d+)?\s+(?:agent |game |env )?(?:steps|frames|episodes)"
    r"(?:/s|\s+per\s+(?:CPU\s+)?second)")
_FENCE = re.compile(r"^```(\w*)\s*$")


def numbers(text: str) -> list[tuple[float, int]]:
    """Every figure in ``text`` with its number of decimals; names like 8v4 are skipped."""
    found = []
    for token in _NUMBER.findall(text):
        plain = token.replace(",", "")
        found.append((float(plain), len(plain.split(".")[1]) if "." in plain else 0))
    return found


def values(figures: dict, patterns: list[str]) -> list[float]:
    """Every number held under the keys matching any of ``patterns``."""
    keys = [key for key in figures if any(fnmatch.fnmatchcase(key, p) for p in patterns)]
    assert keys, f"no key matches {patterns}"
    held: list[float] = []
    for key in keys:
        value = figures[key]
        held.extend(value if isinstance(value, list) else [value])
    return held


def holds(number: float, decimals: int, held: list[float]) -> bool:
    """Whether ``number``, shown with ``decimals`` digits, is one of ``held`` so rounded."""
    return any(abs(abs(v) - abs(number)) <= 0.5 * 10.0 ** -decimals + 1e-9
               and (v >= 0) == (number >= 0 or v == 0) for v in held)


def result(name: str) -> dict:
    return json.loads((RESULTS / name).read_text())


def prose(text: str) -> str:
    """``text`` without fenced code, inline code and the dashboard's rows."""
    kept, fenced = [], False
    for line in text.splitlines():
        if _FENCE.match(line.strip()):
            fenced = not fenced
            continue
        if fenced or line.startswith("|"):
            continue
        kept.append(re.sub(r"`[^`]*`", "", line))
    return "\n".join(kept)


def dashboard() -> list[dict[str, str]]:
    """The rows of BENCHMARKS.md's first table, which must come before any other section."""
    text = (ROOT / "BENCHMARKS.md").read_text()
    before_table = text.split("\n|", 1)[0]
    assert before_table.count("\n## ") == 0, "the dashboard table is not the first thing"
    all_lines = text.splitlines()
    first = next(i for i, line in enumerate(all_lines) if line.startswith("|"))
    lines = []      # the first table only: the later tables of the file are not the dashboard
    for line in all_lines[first:]:
        if not line.startswith("|"):
            break
        lines.append(line)
    header = [cell.strip() for cell in lines[0].strip("|").split("|")]
    assert header == DASHBOARD_HEADER
    rows = []
    for line in lines[2:]:
        if not line.startswith("| "):
            break
        cells = [cell.strip() for cell in line.strip().strip("|").split(" | ")]
        assert len(cells) == len(header), line
        rows.append(dict(zip(header, cells, strict=True)))
    return rows


def test_result_files_follow_the_schema():
    files = sorted(RESULTS.glob("*.json"))
    assert files
    for path in files:
        data = json.loads(path.read_text())
        assert data["schema"] == 1, path.name
        for field in ("benchmark", "command", "machine", "date", "commit", "source"):
            assert isinstance(data[field], str) and data[field], (path.name, field)
        assert re.fullmatch(r"\d{4}-\d\d-\d\d", data["date"]), path.name
        assert data["figures"], path.name
        for key, value in data["figures"].items():
            flat = value if isinstance(value, list) else [value]
            assert all(isinstance(v, int | float) for v in flat), (path.name, key)
            assert key.split(".")[0] in data["units"], (path.name, key)


def test_every_dashboard_figure_is_held_by_its_result_file():
    rows = dashboard()
    assert len(rows) >= 10
    for row in rows:
        where = re.fullmatch(r"`([\w.-]+\.json)`: (.+)", row["result"])
        assert where, f"result cell names no file: {row['result']}"
        data = result(where[1])
        patterns = re.findall(r"`([^`]+)`", where[2])
        held = values(data["figures"], patterns)
        found = numbers(row["figure"])
        assert found, f"no figure in {row['figure']}"
        for number, decimals in found:
            assert holds(number, decimals, held), (
                f"{row['what']}: {number} is not in {where[1]} {patterns}")
        assert row["date"] == data["date"], row["what"]
        assert data["command"].startswith(row["command"].strip("`")), row["what"]


@pytest.mark.parametrize("name", FRONT)
def test_quoted_figures_are_held_by_their_result_files(name):
    text = (ROOT / name).read_text()
    links = _RESULT_LINK.findall(text)
    for shown, file, key in links:
        held = values(result(file)["figures"], [key])
        for number, decimals in numbers(shown):
            assert holds(number, decimals, held), f"{name}: {shown} is not {file} {key}"


@pytest.mark.parametrize("name", FRONT)
def test_no_figure_without_its_result_file(name):
    text = _LINK.sub("", prose((ROOT / name).read_text()))
    assert _UNLINKED.findall(text) == []


def test_sizes():
    assert len((ROOT / "README.md").read_text().splitlines()) <= 250
    assert len((ROOT / "BENCHMARKS.md").read_text().splitlines()) <= 400


def python_blocks(path: Path) -> list[tuple[int, str]]:
    """The ```` ```python ```` blocks of a markdown file with their first line numbers."""
    blocks, current, start, language = [], [], 0, None
    for number, line in enumerate(path.read_text().splitlines(), 1):
        fence = _FENCE.match(line.strip())
        if fence and language is None:
            language, start, current = fence[1] or "text", number + 1, []
        elif fence:
            if language == "python":
                blocks.append((start, "\n".join(current)))
            language = None
        elif language is not None:
            current.append(line)
    return blocks


PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
NOT_RUN = {"design.md": "an outline of the public API at the paper's grids (minutes of "
                        "solves, names left abstract); the lead owns the page"}
"""Pages whose python blocks are not run, and why (none but these)."""
PINNED = {"benchmarl", "ray"}
"""Libraries of the extras installed apart (``.venv-pinned``): a block needing one is
skipped where it is missing, as their tests are."""


@pytest.mark.parametrize("page", [p for p in PAGES if python_blocks(p) and p.name not in NOT_RUN],
                         ids=lambda p: p.relative_to(ROOT).as_posix())
def test_python_blocks_run(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__docs__"}
    for line, code in python_blocks(page):
        try:
            exec(compile(code, f"{page.name}:{line}", "exec"), namespace)
        except ModuleNotFoundError as err:
            if (err.name or "").split(".")[0] not in PINNED:
                raise
            pytest.skip(f"{page.name}:{line} needs {err.name}, an extra installed apart")


def test_every_page_is_in_the_site():
    nav = (ROOT / "mkdocs.yml").read_text()
    for page in sorted((ROOT / "docs").rglob("*.md")):
        assert page.relative_to(ROOT / "docs").as_posix() in nav, page.name


def test_readme_runs_the_tests_as_ci_does():
    readme, ci = (ROOT / "README.md").read_text(), (ROOT / ".ci" / "run").read_text()
    assert "bash .ci/run" in readme
    for install in re.findall(r"pip install -e '\.\[[\w,]+\]'", ci):
        assert install in readme, f"README does not say that .ci/run runs {install}"
    assert "mkdocs build --strict" in ci and "mkdocs build --strict" in readme


@pytest.mark.parametrize("package", ["reachavoid_env", "solvers", "policies", "reachavoid"])
def test_every_module_is_in_the_api_reference(package):
    page = (ROOT / "docs" / "api" / f"{package}.md").read_text()
    for path in sorted((ROOT / package).rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        dotted = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        if parts[-1] != "__main__":
            assert f"::: {dotted}\n" in page, f"add '::: {dotted}' to docs/api/{package}.md"


@pytest.mark.skipif(importlib.util.find_spec("mkdocs") is None,
                    reason="mkdocs is not installed (the docs extra: pip install -e '.[docs]')")
def test_the_site_builds_without_a_warning(tmp_path):
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                           str(tmp_path / "site")], cwd=ROOT, capture_output=True, text=True,
                          env=dict(os.environ, NO_MKDOCS_2_WARNING="1"), timeout=300)
    warnings = [line for line in (done.stdout + done.stderr).splitlines()
                if line.startswith(("WARNING", "ERROR"))]
    assert done.returncode == 0 and warnings == [], "\n".join(warnings) or done.stderr

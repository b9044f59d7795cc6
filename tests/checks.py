"""Helpers shared by the test modules."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, SDL_VIDEODRIVER="dummy", SDL_AUDIODRIVER="dummy")
"""The environment of the command's subprocesses: pygame draws offscreen."""
SIMPLE = ("--attackers", "straight", "--defenders", "greedy")
"""Policies that play without tubes: a quick ``play`` or ``bench``."""
SIMPLE_2V1 = ("--scenario", "paper_2v1", *SIMPLE)
BENCH = ("bench", "--scenario", "paper_2v1", "--config", "2v1", "--episodes", "2",
         "--defenders", "greedy", "--attackers", "straight")
"""A ``bench`` of two quick episodes."""


def fails_cleanly(capsys, args: list[str], message: str, status: int = 2) -> str:
    """``reachavoid ARGS`` ends with ``status``, nothing on standard output and one line on
    standard error that holds ``message``; returns that line."""
    from reachavoid.cli import main

    assert main(args) == status
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and message in err, err
    return err


def command(*args: str, **popen) -> subprocess.Popen:
    """``python -m reachavoid ARGS`` started (standard error piped, as text)."""
    return subprocess.Popen([sys.executable, "-m", "reachavoid", *args], env=ENV,
                            stderr=subprocess.PIPE, text=True, **popen)


def needs_root() -> None:
    if os.geteuid() != 0:
        pytest.skip("needs root")


def in_namespace(script: str, tmp_path: Path) -> subprocess.CompletedProcess:
    """Run ``script`` (bash) as root in a private mount namespace, or skip."""
    needs_root()
    if subprocess.run(["unshare", "-m", "true"], capture_output=True).returncode != 0:
        pytest.skip("no private mount namespace here")
    return subprocess.run(["unshare", "-m", "bash", "-ec", script], capture_output=True,
                          text=True, env=ENV, cwd=tmp_path, timeout=300)


def checked(check, *args, **kwargs) -> None:
    """Run a PettingZoo or Gymnasium checker; any warning it raises (missing keys, revived
    agents; deprecations aside) fails the test."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check(*args, **kwargs)
    messages = [str(w.message) for w in caught if w.category is not DeprecationWarning]
    assert messages == []


def run_example(name: str, *args: str, timeout: float = 600) -> list[str]:
    """Run ``examples/<name>.py ARGS`` as a command (examples are imported by nothing);
    it must succeed. Its standard output's lines."""
    done = subprocess.run([sys.executable, str(ROOT / "examples" / f"{name}.py"), *args],
                          capture_output=True, text=True, timeout=timeout, cwd=ROOT,
                          env={**ENV, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout.strip().splitlines()


def records(lines: list[str]) -> list[dict[str, float]]:
    """The lines ``key value, key value, ...`` of ``lines`` (what the training examples
    print per iteration or rollout) as dicts of numbers."""
    rows = []
    for line in lines:
        pairs = [item.rsplit(" ", 1) for item in line.split(", ")]
        try:
            rows.append({key: float(value) for key, value in pairs})
        except ValueError:
            continue
    return rows


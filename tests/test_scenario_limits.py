"""Scenario fields that would crash or stall the command far from the input: names with
control characters, names too long to draw one character at a time, player counts beyond
what the env can hold."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from checks import fails_cleanly

from reachavoid.cli import main
from reachavoid_env import ScenarioError, load_scenario
from reachavoid_env.scenario import MAX_PLAYERS

ROOT = Path(__file__).resolve().parents[1]
PAPER = (ROOT / "reachavoid_env" / "scenarios" / "paper_2v1.toml").read_text()
QUICK = ("--attackers", "straight", "--defenders", "greedy")


def _named(tmp_path: Path, name: str) -> Path:
    path = tmp_path / "named.toml"
    path.write_text(PAPER.replace('name = "paper_2v1"', f'name = "{name}"'))
    return path


def test_a_name_with_a_control_character_is_refused(tmp_path, capsys):
    path = _named(tmp_path, "bad\\u0000name")
    with pytest.raises(ScenarioError, match="^name: expected printable text"):
        load_scenario(path)
    fails_cleanly(capsys, ["play", "--scenario", str(path), *QUICK, "--preview",
                       str(tmp_path / "p.png")], "name: expected printable text")


def test_a_long_name_is_shortened_at_once(tmp_path, capsys):
    path = _named(tmp_path, "n" * 200_000)
    started = time.perf_counter()
    assert main(["play", "--scenario", str(path), *QUICK, "--preview",
                 str(tmp_path / "p.png")]) == 0
    assert time.perf_counter() - started < 60   # one character at a time: about 12 minutes


@pytest.mark.parametrize("role", ["attackers", "defenders"])
def test_player_counts_have_an_upper_bound(tmp_path, capsys, role):
    text = PAPER.replace(f"{role} = [[", f"{role} = {MAX_PLAYERS + 1}\n# [[")
    path = tmp_path / "many.toml"
    path.write_text(text)
    with pytest.raises(ScenarioError, match=f"players.{role}: at most {MAX_PLAYERS}"):
        load_scenario(path)
    fails_cleanly(capsys, ["play", "--scenario", str(path), *QUICK], f"at most {MAX_PLAYERS}")

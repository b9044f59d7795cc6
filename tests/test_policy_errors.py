"""Policies that cannot be loaded, or that fail while playing: one line naming the flag,
or the user's traceback with a line naming the policy, the step and the seed."""

from __future__ import annotations

import sys

import pytest
from checks import fails_cleanly

from reachavoid.cli import main

QUICK = ("--scenario", "paper_2v1", "--attackers", "straight")

FAILS = '''
import numpy as np


class Fails:
    """Raises on its third decision."""

    def __init__(self, scenario):
        self.calls = 0

    def reset(self, scenario):
        self.calls = 0

    def act(self, state):
        self.calls += 1
        if self.calls == 3:
            raise ZeroDivisionError("my bug")
        return {name: np.zeros(2) for name in state.defender_names}
'''


@pytest.mark.parametrize("spec", ["..:x", ".:x", "no_such_module_here:x"])
def test_a_module_that_cannot_be_imported_is_one_line(capsys, spec):
    fails_cleanly(capsys, ["play", *QUICK, "--defenders", spec], "--defenders: cannot import")


def test_sb3_without_stable_baselines3_is_one_line(tmp_path, monkeypatch, capsys):
    model = tmp_path / "model.zip"
    model.write_bytes(b"PK")
    monkeypatch.setitem(sys.modules, "stable_baselines3", None)
    fails_cleanly(capsys, ["play", "--scenario", "paper_2v1", "--defenders", "greedy",
                       "--attackers", f"sb3:{model}"], "needs Stable-Baselines3")


def test_an_error_in_ones_own_policy_names_the_policy_and_seed(tmp_path, monkeypatch):
    (tmp_path / "failing_policy.py").write_text(FAILS)
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(ZeroDivisionError, match="my bug") as raised:
        main(["play", *QUICK, "--defenders", "failing_policy:Fails", "--seed", "7"])
    notes = getattr(raised.value, "__notes__", [])
    assert any("defenders' policy failing_policy.Fails" in note and "step 2" in note
               and "seed 7" in note for note in notes), notes

"""Policies that cannot be loaded, or that fail while playing: one line naming the flag,
or the user's traceback with a line naming the policy, the step and the seed."""

from __future__ import annotations

import base64
import json
import os
import pickle
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from checks import ENV, ROOT, fails_cleanly, needs_root

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


@pytest.mark.parametrize("hidden", ["stable_baselines3", "torch"])
def test_sb3_that_does_not_import_is_one_line_status_2(tmp_path, hidden):
    """Stable-Baselines3 missing, or installed without what it imports (torch)."""
    model = tmp_path / "model.zip"
    model.write_bytes(b"PK")
    code = (f"import sys; sys.modules[{hidden!r}] = None\n"
            "from reachavoid.cli import main\n"
            "sys.exit(main(sys.argv[1:]))")
    done = subprocess.run([sys.executable, "-c", code, "play", "--scenario", "paper_2v1",
                           "--defenders", "greedy", "--attackers", "sb3:model.zip"],
                          capture_output=True, text=True, cwd=tmp_path, timeout=300,
                          env=dict(ENV, PYTHONPATH=str(ROOT)))
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "needs Stable-Baselines3" in done.stderr


def _planted_model(path: Path, marker: Path) -> None:
    """A zip that Stable-Baselines3 opens as a model, whose pickled ``policy_class`` makes
    ``marker`` when unpickled: what a model file can run."""
    payload = pickle.dumps(_Opens(str(marker)))
    data = {"policy_class": {":type:": "<class 'type'>",
                             ":serialized:": base64.b64encode(payload).decode()}}
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("data", json.dumps(data))


class _Opens:
    def __init__(self, path: str) -> None:
        self.path = path

    def __reduce__(self):
        return open, (self.path, "w")


@pytest.mark.parametrize("case", ["open folder", "open file", "another user's file"])
def test_a_model_file_others_can_change_is_not_read(tmp_path, capsys, case):
    """A model file is code: one in a folder others can write, one others can write, and
    one another user owns are refused before anything is read from them."""
    folder = tmp_path / "shared"
    folder.mkdir()
    model, marker = folder / "model.zip", tmp_path / "payload-ran"
    _planted_model(model, marker)
    if case == "open folder":
        folder.chmod(0o777)
    elif case == "open file":
        model.chmod(0o666)
    else:
        needs_root()
        os.chown(model, 65534, 65534)
    fails_cleanly(capsys, ["play", "--scenario", "paper_2v1", "--defenders", "greedy",
                           "--attackers", f"sb3:{model}"], "a model file is code")
    assert not marker.exists()


def test_a_model_with_weights_not_finite_is_one_line(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    import torch
    from stable_baselines3 import PPO

    from reachavoid.training.views import make_attacker_env

    model = PPO("MlpPolicy", make_attacker_env("paper_1v1", defenders="greedy"),
                device="cpu")
    with torch.no_grad():
        next(model.policy.parameters()).fill_(float("nan"))
    model.save(tmp_path / "nan.zip")
    fails_cleanly(capsys, ["play", "--scenario", "paper_1v1", "--defenders", "greedy",
                           "--attackers", f"sb3:{tmp_path / 'nan.zip'}"], "not finite")


def test_an_error_in_ones_own_policy_names_the_policy_and_seed(tmp_path, monkeypatch):
    (tmp_path / "failing_policy.py").write_text(FAILS)
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(ZeroDivisionError, match="my bug") as raised:
        main(["play", *QUICK, "--defenders", "failing_policy:Fails", "--seed", "7"])
    notes = getattr(raised.value, "__notes__", [])
    assert any("defenders' policy failing_policy.Fails" in note and "step 2" in note
               and "seed 7" in note for note in notes), notes

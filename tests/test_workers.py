"""Workers of a sweep: what they import, how their death is reported, and the command's
signal handlers while Ray runs (a fake ``ray`` module stands in where Ray is missing)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import types
from pathlib import Path

import pytest
from checks import BENCH, ENV, fails_cleanly

from reachavoid import sweep

ROOT = Path(__file__).resolve().parents[1]
DIES = '''
import os

import numpy as np


class Dies:
    """Stands still; its process ends abruptly on seed 1 (as a crashing extension would)."""

    def __init__(self, scenario, seed=0):
        self.seed = seed

    def reset(self, scenario):
        pass

    def act(self, state):
        if self.seed == 1:
            os._exit(3)
        return {name: np.zeros(2, dtype=np.float32) for name in state.defender_names}
'''


def test_worker_path_leaves_out_the_working_folder_and_open_folders(tmp_path, monkeypatch):
    ours, open_, sticky = (tmp_path / name for name in ("ours", "open", "sticky"))
    for folder, mode in ((ours, 0o755), (open_, 0o777), (sticky, 0o1777)):
        folder.mkdir()
        folder.chmod(mode)
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("PYTHONPATH", raising=False)
    monkeypatch.setattr(sys, "path", ["", str(tmp_path), str(ours), str(open_), str(sticky),
                                      str(tmp_path / "missing"), str(ours)])
    assert sweep.worker_path() == [str(ours)]
    monkeypatch.setenv("PYTHONPATH", str(tmp_path))   # named on purpose: kept
    assert sweep.worker_path() == [str(tmp_path), str(ours)]
    monkeypatch.delenv("PYTHONPATH")
    monkeypatch.setattr(sweep, "PROGRAM_HOME", tmp_path)   # run from its source folder: kept
    assert sweep.worker_path() == [str(tmp_path), str(ours)]


class _Crashed(Exception):
    pass


def _fake_ray(record: dict, crash_on: int | None = None) -> types.ModuleType:
    """Just enough of Ray's API for ``sweep._ray``, run in this process."""
    ray = types.ModuleType("ray")
    ray.exceptions = types.SimpleNamespace(WorkerCrashedError=_Crashed)
    state = {"up": False}

    def init(**options):
        record.update(cwd=os.getcwd(), listing=os.listdir("."), options=options)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)   # as Ray's own handlers do
        signal.signal(signal.SIGHUP, signal.SIG_DFL)
        state["up"] = True

    def remote(function):
        return types.SimpleNamespace(remote=lambda task, item: (function, task, item))

    def get(ref):
        function, task, item = ref
        if item == crash_on:
            raise _Crashed("the worker died")
        return function(task, item)

    ray.init = init
    ray.is_initialized = lambda: state["up"]
    ray.remote = remote
    ray.put = lambda value: value
    ray.wait = lambda pending, num_returns: (pending[:1], pending[1:])
    ray.get = get
    ray.cancel = lambda ref, force: None
    ray.shutdown = lambda: state.update(up=False)
    return ray


def _twice(x: int) -> int:
    return 2 * x


def test_ray_starts_away_from_the_working_folder_and_keeps_our_handlers(tmp_path, monkeypatch):
    monkeypatch.delenv("PYTHONPATH", raising=False)
    record: dict = {}
    monkeypatch.setitem(sys.modules, "ray", _fake_ray(record))
    monkeypatch.chdir(tmp_path)
    (tmp_path / "pymunk.py").write_text("raise SystemExit('planted')\n")
    mine = signal.getsignal(signal.SIGTERM)

    def handler(signum, frame):
        raise KeyboardInterrupt

    previous = {s: signal.signal(s, handler) for s in (signal.SIGTERM, signal.SIGHUP)}
    try:
        assert list(sweep.run_tasks(_twice, [1, 2, 3], "ray")) == [2, 4, 6]
        assert signal.getsignal(signal.SIGTERM) is handler
        assert signal.getsignal(signal.SIGHUP) is handler
    finally:
        for signum, old in previous.items():
            signal.signal(signum, old)
    assert mine is not handler
    assert record["cwd"] != str(tmp_path) and record["listing"] == []
    assert os.getcwd() == str(tmp_path)
    path = record["options"]["runtime_env"]["env_vars"]["PYTHONPATH"].split(os.pathsep)
    assert str(tmp_path) not in path and "" not in path


def test_a_ray_worker_that_dies_is_one_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", _fake_ray({}, crash_on=2))
    with pytest.raises(sweep.WorkerDied, match="after 1 of 3 task"):
        list(sweep.run_tasks(_twice, [1, 2, 3], "ray"))


def test_a_process_pool_worker_that_dies_ends_the_command(tmp_path):
    (tmp_path / "tmpmod.py").write_text(DIES)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), str(ROOT)]))
    done = subprocess.run(
        [sys.executable, "-m", "reachavoid", "bench", "--scenario", "paper_2v1", "--config",
         "2v1", "--episodes", "4", "--defenders", "tmpmod:Dies", "--attackers", "straight",
         "--backend", "process", "--workers", "2", "--csv", str(tmp_path / "rows.csv")],
        capture_output=True, text=True, env=env, cwd=tmp_path, timeout=120)
    assert done.returncode == 1 and done.stderr.count("\n") == 1, done.stderr
    assert "worker process died" in done.stderr
    assert not (tmp_path / "rows.csv").exists()


PLANTED = '''
import os
import pathlib

pathlib.Path(__file__).with_name(f"ran-{os.getpid()}").touch()
raise SystemExit("planted")
'''
LAUNCHER = '''
import sys

from reachavoid.cli import main

if __name__ == "__main__":   # as a console script: spawned workers import it as __mp_main__
    sys.exit(main())
'''


def test_process_pool_workers_import_nothing_planted_in_the_working_folder(tmp_path):
    """From a sticky folder others can write, holding another user's ``selectors.py``
    (imported by every Python process that uses sockets): neither the pool's workers nor
    its resource tracker import it."""
    work, bin_ = tmp_path / "work", tmp_path / "bin"
    work.mkdir(), bin_.mkdir()
    (work / "selectors.py").write_text(PLANTED)
    if os.geteuid() == 0:
        os.chown(work / "selectors.py", 65534, 65534)
    work.chmod(0o1777)
    (bin_ / "reachavoid").write_text(LAUNCHER)
    done = subprocess.run(
        [sys.executable, str(bin_ / "reachavoid"), *BENCH, "--backend", "process",
         "--workers", "2"], capture_output=True, text=True, cwd=work, timeout=300,
        env=dict(ENV, PYTHONPATH=str(ROOT)))
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in work.iterdir()) == ["selectors.py"]


def _killed(task, items, backend, workers, address):
    yield from ()
    raise sweep.WorkerDied("a worker process died (the process pool broke: killed, out of "
                           "memory, or os._exit in a policy) after 1 of 2 task(s)")


def test_a_dead_worker_does_not_claim_the_cache_was_left_untouched(monkeypatch, capsys):
    """``solve --defenders`` stores each map's tubes as it goes: after a worker's death the
    line says what was kept, not "nothing was written"."""
    import reachavoid.solve

    monkeypatch.setattr(reachavoid.solve, "run_tasks", _killed)
    err = fails_cleanly(capsys, ["solve", "--scenario", "paper_2v1", "--defenders", "greedy",
                                 "--backend", "process"], "worker process died", status=1)
    assert "nothing was written" not in err and "stay in the cache" in err


def test_sigterm_while_ray_waits_is_one_line_and_143(tmp_path, monkeypatch, capsys):
    """Ray turns the command's ``Terminated``, raised in its wait, into a plain
    ``KeyboardInterrupt``: the command still says "terminated", status 143."""
    monkeypatch.delenv("PYTHONPATH", raising=False)
    ray = _fake_ray({})

    def wait(pending, num_returns):
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            signal.sigtimedwait([], 0.1)   # the handler runs here
        except BaseException:
            raise KeyboardInterrupt from None   # as Ray's wait reports any signal
        return pending[:1], pending[1:]

    ray.wait = wait
    monkeypatch.setitem(sys.modules, "ray", ray)
    fails_cleanly(capsys, [*BENCH, "--backend", "ray"], "terminated", status=143)


def test_ray_missing_is_one_line_before_any_work(tmp_path, monkeypatch, capsys):
    if sys.modules.get("ray") is None:
        monkeypatch.setitem(sys.modules, "ray", None)   # import ray fails, as uninstalled
    else:
        pytest.skip("Ray is installed")
    monkeypatch.setenv("REACHAVOID_CACHE_DIR", str(tmp_path / "cache"))
    fails_cleanly(capsys, ["bench", "--scenario", "paper_2v1", "--config", "2v1", "--episodes",
                           "2", "--backend", "ray"], "needs Ray")
    assert not list((tmp_path / "cache").glob("*.vf"))


def test_pool_size_is_capped_by_episodes_and_memory(monkeypatch):
    from reachavoid import sweep

    assert sweep.pool_size(4096, 1) == 1
    monkeypatch.setattr(sweep, "available_memory", lambda: 5 * sweep.WORKER_BYTES + 1)
    assert sweep.pool_size(4096, 100) == 5
    assert sweep.pool_size(None, 100) <= 5

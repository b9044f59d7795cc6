"""Test-wide settings: pygame draws offscreen (PettingZoo's render_test opens "human")."""

import atexit
import os
import shutil
import tempfile
from pathlib import Path

import pytest

from solvers.hj.cache import cache_dir

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
# Tubes that tests solve through the cache go to a throwaway folder, never ~/.cache: one per
# test session, made by the first process (pytest-xdist's controller) and shared by its
# workers, so that a kernel one worker compiled the others load.
_SHARED = "REACHAVOID_TEST_SESSION_CACHE"
if os.environ.get("PYTEST_XDIST_WORKER") and os.environ.get(_SHARED):
    SESSION_CACHE = Path(os.environ[_SHARED])
else:
    SESSION_CACHE = Path(tempfile.mkdtemp(prefix="reachavoid-test-cache-"))
    # The kernels compiled before (by this user) are copied in: numba finds them by file stamp.
    _KERNELS = cache_dir() / "kernels"
    if _KERNELS.is_dir() and not _KERNELS.is_symlink() and _KERNELS.stat().st_uid == os.geteuid():
        shutil.copytree(_KERNELS, SESSION_CACHE / "kernels", symlinks=True)
    os.environ[_SHARED] = str(SESSION_CACHE)
    atexit.register(shutil.rmtree, SESSION_CACHE, ignore_errors=True)
os.environ["REACHAVOID_CACHE_DIR"] = str(SESSION_CACHE)


@pytest.fixture
def cache_in_tmp(tmp_path, monkeypatch):
    """A cache of this test's own (``$REACHAVOID_CACHE_DIR`` at ``tmp_path / "cache"``, not
    yet made)."""
    monkeypatch.setenv("REACHAVOID_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


def _copy_present(source: str, destination: str) -> None:
    """``shutil.copy2`` that skips a file gone meanwhile (a worker's temporary)."""
    try:
        shutil.copy2(source, destination)
    except FileNotFoundError:
        pass


@pytest.fixture
def new_cache(monkeypatch):
    """A function that makes a folder this test's cache (``$REACHAVOID_CACHE_DIR``, mode 0700)
    holding a copy of the kernels this session compiled, so that solving there does not
    compile them again (numba finds them by file stamp, which the copy keeps)."""
    def make(folder: Path) -> Path:
        folder.mkdir(mode=0o700, parents=True)
        kernels = SESSION_CACHE / "kernels"
        if kernels.is_dir():
            shutil.copytree(kernels, folder / "kernels", symlinks=True,
                            copy_function=_copy_present)
        monkeypatch.setenv("REACHAVOID_CACHE_DIR", str(folder))
        return folder

    return make


@pytest.fixture(scope="session")
def paper_map():
    """The paper's built-in map."""
    import reachavoid_env

    return reachavoid_env.builtin_map("paper")


@pytest.fixture(scope="session")
def vf11():
    """The paper map's 1 vs 1 tube at 25^4 (paper speeds and radius), solved once per test
    session without touching the on-disk cache."""
    import reachavoid_env
    from solvers.hj import solve_1v1

    scenario = reachavoid_env.builtin_scenario("paper_2v1")
    return solve_1v1(scenario.map, (scenario.attacker_speed, scenario.defender_speed),
                     scenario.capture_radius, 25, cache=False, progress=False)


@pytest.fixture(scope="session")
def coarse_tubes(vf11):
    """The paper map's 1 vs 1 (25^4, ``vf11``) and 2 vs 1 (13^6) tubes, solved once per test
    session without touching the on-disk cache (about 10 s on 2 cores)."""
    import reachavoid_env
    from solvers.hj import solve_2v1

    game_map = reachavoid_env.builtin_scenario("paper_2v1").map
    return vf11, solve_2v1(game_map, vf11, 13, cache=False, progress=False)

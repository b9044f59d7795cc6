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
# Tubes that tests solve through the cache go to a throwaway folder, never ~/.cache.
_CACHE = tempfile.mkdtemp(prefix="reachavoid-test-cache-")
# The kernels compiled before (by this user) are copied in: numba finds them by file stamp.
_KERNELS = cache_dir() / "kernels"
if _KERNELS.is_dir() and not _KERNELS.is_symlink() and _KERNELS.stat().st_uid == os.geteuid():
    shutil.copytree(_KERNELS, Path(_CACHE, "kernels"), symlinks=True)
os.environ["REACHAVOID_CACHE_DIR"] = _CACHE
atexit.register(shutil.rmtree, _CACHE, ignore_errors=True)


@pytest.fixture
def cache_in_tmp(tmp_path, monkeypatch):
    """A cache of this test's own (``$REACHAVOID_CACHE_DIR`` at ``tmp_path / "cache"``, not
    yet made)."""
    monkeypatch.setenv("REACHAVOID_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


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

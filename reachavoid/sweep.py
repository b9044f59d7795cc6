"""Sweeps: many seeded episodes of chosen policies, serially, on a process pool or on Ray.

Every episode is a pure function of ``(scenario, policies, seed)``: ``play_seed`` builds
(or reuses, within one process) the env and the policies, and a policy that takes a seed
gets the episode's. So the three backends give the same results for the same seeds, bit
for bit, whatever the number of workers or the order in which episodes finish. Policies
travel as ``policies.registry.PolicySpec`` values: each worker resolves the spec itself
(imports a ``pkg.module:factory``, loads an entry point), so a policy of your own needs
its module importable where the workers run (``PYTHONPATH``; the workers of a process pool
and of a local Ray instance get ``worker_path``).

Tubes: the driver builds the policies once before dispatching, which solves any missing
tube into the cache (``$REACHAVOID_CACHE_DIR``); every worker then memory-maps it from
there. On one machine the workers share the page cache. A multi-machine Ray cluster needs
the cache folder on a shared filesystem (the same path on every node; it is passed to the
workers in ``runtime_env``), or a cache filled on each node beforehand.

Workers import from the driver's ``sys.path`` less its working folder (unless
``$PYTHONPATH`` names it) and any folder another user can write (``worker_path``): Ray's
through their ``PYTHONPATH`` (Ray's own "add the driver's working folder" is pointed at an
empty private folder), the process pool's and its resource tracker's by starting with
``$PYTHONSAFEPATH`` (``-c`` adds no working folder) and ``worker_path`` as the
``sys.path`` handed to a spawned worker. A worker
that dies (killed, out of memory, ``os._exit`` in a policy) ends the sweep with
``WorkerDied`` saying how many tasks had finished; the command's signal handlers stay in
place while Ray runs.
"""

from __future__ import annotations

import atexit
import itertools
import os
import signal
import stat
import sys
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from multiprocessing import resource_tracker
from multiprocessing.context import SpawnContext, SpawnProcess
from pathlib import Path
from typing import Any, TypeVar

from tqdm import tqdm

import reachavoid_env
from policies.registry import Factory, PolicySpec, policy_specs
from reachavoid.rollout import EpisodeResult, run_episode
from reachavoid_env import Policy, Scenario
from solvers.hj.reach_avoid import available_memory

BACKENDS = ("serial", "process", "ray")
RAY_MISSING = "backend: 'ray' needs Ray (pip install 'reachavoid[ray]')"


class WorkerDied(RuntimeError):
    """A worker process ended without returning its task (killed, out of memory,
    ``os._exit`` in a policy): reported in one line, exit status 1."""
PROGRAM_HOME = Path(__file__).resolve().parents[1]
"""The folder this program's packages are imported from (site-packages, or a source
folder)."""
WORKER_BYTES = 200 << 20
"""Memory one pool worker holds (interpreter, numpy, numba, env, policies: about 190 MB)."""


def pool_size(workers: int | None, episodes: int) -> int:
    """Processes of a pool (or CPUs of a local Ray instance) for ``episodes`` episodes:
    ``workers`` (default: the CPU count), at most one per episode and no more than the
    available memory holds."""
    by_memory = available_memory() // WORKER_BYTES
    return max(1, min(workers or os.cpu_count() or 1, episodes, by_memory))


@dataclass(frozen=True)
class Sweep:
    """What to play: ``scenario`` with ``attackers`` against ``defenders``, one episode per
    seed (the env is reset with it; seeded policies get it too)."""

    scenario: Scenario
    attackers: PolicySpec
    defenders: PolicySpec
    seeds: tuple[int, ...]


_BUILT: dict[tuple[Scenario, PolicySpec], Policy] = {}
_ENVS: dict[Scenario, Any] = {}
"""One env per scenario and process, kept between episodes; emptied at exit, while pymunk
can still free the envs' spaces (at interpreter teardown its module is gone first)."""
atexit.register(_ENVS.clear)


def _policy(spec: PolicySpec, scenario: Scenario, seed: int, progress: bool = False) -> Policy:
    """``spec`` for this episode: rebuilt when seeded, else built once per process."""
    if spec.seeded:
        return spec(scenario, seed=seed, progress=progress)
    key = (scenario, spec)
    if key not in _BUILT:
        _BUILT[key] = spec(scenario, seed=seed, progress=progress)
    return _BUILT[key]


def play_seed(sweep: Sweep, seed: int) -> EpisodeResult:
    """One episode of ``sweep`` (the task every backend runs)."""
    scenario = sweep.scenario
    if scenario not in _ENVS:
        _ENVS[scenario] = reachavoid_env.parallel_env(scenario=scenario)
    return run_episode(_ENVS[scenario], _policy(sweep.attackers, scenario, seed),
                       _policy(sweep.defenders, scenario, seed), seed=seed)


Task = tuple[int, Sweep, int]
Item = TypeVar("Item")
Result = TypeVar("Result")


def _play_task(task: Task) -> tuple[int, EpisodeResult]:
    index, sweep, seed = task
    return index, play_seed(sweep, seed)


def run_sweeps(sweeps: Sequence[Sweep], backend: str = "serial", workers: int | None = None,
               address: str | None = None, progress: bool = False,
               description: str = "") -> list[list[EpisodeResult]]:
    """Play every seed of every sweep on ``backend`` (one pool or Ray instance for all of
    them) and return each sweep's results in seed order.

    ``workers``: processes of the pool (``pool_size``); ``address``: an existing Ray
    cluster (default: a local instance, started here and shut down after). Ctrl-C
    cancels the episodes not yet played and stops the workers.
    """
    check_backend(backend)
    for sweep in sweeps:   # solves missing tubes once, here, with progress when asked
        _policy(sweep.attackers, sweep.scenario, sweep.seeds[0], progress)
        _policy(sweep.defenders, sweep.scenario, sweep.seeds[0], progress)
    tasks = [(index, sweep, seed) for index, sweep in enumerate(sweeps) for seed in sweep.seeds]
    results: list[dict[int, EpisodeResult]] = [{} for _ in sweeps]
    with tqdm(total=len(tasks), desc=description, unit="episode", disable=not progress,
              leave=False) as bar:
        for index, result in run_tasks(_play_task, tasks, backend, workers, address):
            results[index][result.seed] = result
            bar.update(1)
    return [[done[seed] for seed in sweep.seeds] for done, sweep in zip(results, sweeps,
                                                                        strict=True)]


def run_sweep(sweep: Sweep, backend: str = "serial", workers: int | None = None,
              address: str | None = None, progress: bool = False,
              description: str = "") -> list[EpisodeResult]:
    """``run_sweeps`` of one sweep: its results in seed order."""
    return run_sweeps([sweep], backend, workers, address, progress, description)[0]


def check_backend(backend: str) -> None:
    """``ValueError`` naming ``backend`` unless it is one of ``BACKENDS`` and, for Ray,
    Ray can be imported (checked before any work)."""
    if backend not in BACKENDS:
        raise ValueError(f"backend: expected one of {', '.join(BACKENDS)}, got {backend!r}")
    if backend == "ray":
        try:
            import ray  # noqa: F401
        except ImportError:
            raise ValueError(RAY_MISSING) from None


def _died(finished: int, total: int, how: str) -> WorkerDied:
    return WorkerDied(f"a worker process died ({how}: killed, out of memory, or os._exit in "
                      f"a policy) after {finished} of {total} task(s)")


def run_tasks(task: Callable[[Item], Result], items: Sequence[Item], backend: str = "serial",
              workers: int | None = None, address: str | None = None) -> Iterator[Result]:
    """``task(item)`` for every item on ``backend``, yielded as each finishes (in the items'
    order only serially): the one pool of the sweeps and the tube libraries. ``task`` must be
    picklable (a module-level function or a ``functools.partial`` of one) for the process
    pool and Ray; ``workers`` is capped by ``pool_size``."""
    check_backend(backend)
    play = {"serial": _serial, "process": _process_pool, "ray": _ray}[backend]
    yield from play(task, items, workers=workers, address=address)


def _serial(task: Callable[[Item], Result], items: Sequence[Item],
            **_: Any) -> Iterator[Result]:
    for item in items:
        yield task(item)


def _process_pool(task: Callable[[Item], Result], items: Sequence[Item], workers: int | None,
                  **_: Any) -> Iterator[Result]:
    """The items on a pool of spawned processes, at most a few tasks ahead per worker; a
    worker that dies breaks the pool (``WorkerDied``) instead of losing its task."""
    size = pool_size(workers, len(items))
    with _clean_start():   # the resource tracker: a process of its own, started once
        resource_tracker.ensure_running()
    pool = ProcessPoolExecutor(size, mp_context=_CleanSpawnContext(),
                               initializer=_start_worker,
                               initargs=(max(1, (os.cpu_count() or 1) // size),))
    waiting = iter(items)
    pending: set[Future] = {pool.submit(task, item)
                            for item in itertools.islice(waiting, 4 * size)}
    finished = 0
    try:
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                result = future.result()
                finished += 1
                pending.update(pool.submit(task, item) for item in itertools.islice(waiting, 1))
                yield result
    except BrokenProcessPool:
        _stop(pool)
        raise _died(finished, len(items), "the process pool broke") from None
    except BaseException:
        _stop(pool)   # Ctrl-C or SIGTERM: no worker outlives the work
        raise
    pool.shutdown(wait=True)


@contextmanager
def _clean_start() -> Iterator[None]:
    """While a process is started: its interpreter puts no working folder on its path
    (``$PYTHONSAFEPATH``: a ``selectors.py`` planted where the command runs is not imported
    as the interpreter starts), and a spawned worker is handed ``worker_path`` as its
    ``sys.path``."""
    path, safe = sys.path[:], os.environ.get("PYTHONSAFEPATH")
    sys.path[:] = worker_path()
    os.environ["PYTHONSAFEPATH"] = "1"
    try:
        yield
    finally:
        sys.path[:] = path
        if safe is None:
            del os.environ["PYTHONSAFEPATH"]
        else:
            os.environ["PYTHONSAFEPATH"] = safe


class _CleanSpawnProcess(SpawnProcess):
    """A spawned process started under ``_clean_start``."""

    def start(self) -> None:
        with _clean_start():
            super().start()


class _CleanSpawnContext(SpawnContext):
    """The spawn start method, its processes started under ``_clean_start`` (the process
    pool's workers)."""

    Process = _CleanSpawnProcess


def _stop(pool: ProcessPoolExecutor) -> None:
    """End ``pool`` now: its workers terminated, its waiting tasks dropped."""
    for process in list((pool._processes or {}).values()):
        process.terminate()
    pool.shutdown(wait=True, cancel_futures=True)


def _start_worker(threads: int) -> None:
    """Workers leave Ctrl-C (sent to the terminal's whole process group) to the driver,
    which stops them; their (hidden) tqdm bars take a thread lock instead of tqdm's
    multiprocessing one, which a stopped worker would leave registered (resource_tracker's
    "leaked semaphore" warnings); and they share the CPUs: ``threads`` numba threads each
    (a parallel HJ solve in every worker would otherwise oversubscribe them)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    tqdm.set_lock(threading.RLock())
    import numba

    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))


def _call(task: Callable[[Item], Result], item: Item) -> Result:
    return task(item)


def _closed(entry: str) -> bool:
    """Whether ``entry`` (a folder or archive on ``sys.path``) exists and only its owner,
    this user or root, can write it (a sticky folder such as ``/tmp`` is not enough: anyone
    can add a module there)."""
    try:
        status = os.stat(entry)
    except OSError:
        return False
    return status.st_uid in (os.geteuid(), 0) and not stat.S_IMODE(status.st_mode) & 0o022


def worker_path() -> list[str]:
    """The driver's ``sys.path`` for the workers (Ray's and the process pool's): without
    its working folder (``''`` or its path: a module planted where the command runs must
    not shadow a library), unless ``$PYTHONPATH`` names it or this program was imported
    from it (run from its source folder: the driver already runs what is there), and
    without any folder another user can write (``_closed``)."""
    here = os.path.realpath(os.getcwd())
    named = {os.path.realpath(entry)
             for entry in os.environ.get("PYTHONPATH", "").split(os.pathsep) if entry}
    named.add(str(PROGRAM_HOME))
    return [entry for entry in dict.fromkeys(sys.path)
            if entry and (os.path.realpath(entry) != here or here in named) and _closed(entry)]


def ray_runtime_env() -> dict[str, Any]:
    """What a local Ray instance's workers are given: the cache folder and ``worker_path``
    as ``PYTHONPATH``."""
    from solvers.hj.cache import cache_dir

    return {"env_vars": {"REACHAVOID_CACHE_DIR": str(cache_dir()),
                         "PYTHONPATH": os.pathsep.join(worker_path())}}


STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


def _ray_init(ray: Any, **options: Any) -> None:
    """``ray.init(**options)`` from a private folder of ours that holds no module (Ray adds
    the driver's working folder to its workers' ``sys.path``, and the workers keep it as
    their working folder, so it must outlive the call: ``ray-workdir`` in the cache
    folder), keeping this process's signal handlers (Ray replaces SIGTERM's and SIGHUP's
    with its own)."""
    from reachavoid_env.files import private_folder
    from solvers.hj.cache import cache_dir

    handlers = {signum: signal.getsignal(signum) for signum in STOP_SIGNALS}
    here = os.getcwd()
    os.chdir(private_folder(Path(cache_dir(), "ray-workdir")))
    try:
        ray.init(**options)
    finally:
        os.chdir(here)
        for signum, handler in handlers.items():
            if handler is not None:
                signal.signal(signum, handler)


def _ray(task: Callable[[Item], Result], items: Sequence[Item], workers: int | None,
         address: str | None, **_: Any) -> Iterator[Result]:
    try:
        import ray
    except ImportError:
        raise ValueError(RAY_MISSING) from None
    started = not ray.is_initialized()
    if started:
        _ray_init(ray, address=address,
                  num_cpus=None if address else pool_size(workers, len(items)),
                  include_dashboard=False, log_to_driver=False,
                  runtime_env=ray_runtime_env())
    died = tuple(getattr(ray.exceptions, name) for name in
                 ("WorkerCrashedError", "OutOfMemoryError", "NodeDiedError", "ActorDiedError")
                 if hasattr(ray.exceptions, name))
    remote = ray.remote(_call)
    shared = ray.put(task)
    pending = [remote.remote(shared, item) for item in items]
    try:
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            try:
                result = ray.get(done[0])
            except died as err:
                raise _died(len(items) - len(pending) - 1, len(items),
                            type(err).__name__) from None
            yield result
    except BaseException:
        for ref in pending:
            ray.cancel(ref, force=True)
        raise
    finally:
        if started:
            ray.shutdown()


def sweeps_of(scenario: Scenario, methods: Sequence[str | Factory], attackers: str | Factory,
              seeds: Sequence[int], options: Mapping[str, Any],
              names: Mapping[str, str] | None = None) -> list[Sweep]:
    """One sweep per defender method against the same attackers on the same seeds; each
    policy gets the ``options`` it takes, and one that no policy takes is an error
    (named as ``names[option]`` when given)."""
    attacker_spec, *defender_specs = policy_specs(
        [("attackers", attackers), *(("defenders", method) for method in methods)],
        options, names)
    return [Sweep(scenario, attacker_spec, spec, tuple(seeds)) for spec in defender_specs]


def sweep_of(scenario: Scenario, defenders: str | Factory, attackers: str | Factory,
             seeds: Sequence[int], **options: Any) -> Sweep:
    """The sweep of two policies (specs or factories) with the ``options`` each takes."""
    return sweeps_of(scenario, [defenders], attackers, seeds, options)[0]

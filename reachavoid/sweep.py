"""Sweeps: many seeded episodes of named policies, serially, on a process pool or on Ray.

Every episode is a pure function of ``(scenario, policies, seed)``: ``play_seed`` builds
(or reuses, within one process) the env and the policies, and a policy that takes a seed
gets the episode's. So the three backends give the same results for the same seeds, bit
for bit, whatever the number of workers or the order in which episodes finish.

Tubes: the driver builds the defenders once before dispatching, which solves any missing
tube into the cache (``$REACHAVOID_CACHE_DIR``); every worker then memory-maps it from
there. On one machine the workers share the page cache. A multi-machine Ray cluster needs
the cache folder on a shared filesystem (the same path on every node; it is passed to the
workers in ``runtime_env``), or a cache filled on each node beforehand.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import reachavoid_env
from policies.registry import accepted_options, make_policy, named_policy

if TYPE_CHECKING:
    from reachavoid.rollout import EpisodeResult
    from reachavoid_env import Policy, Scenario

BACKENDS = ("serial", "process", "ray")


@dataclass(frozen=True)
class PolicySpec:
    """A named policy (``policies.registry``) and its options, as a picklable value."""

    side: str
    name: str
    options: tuple[tuple[str, Any], ...] = ()

    @classmethod
    def of(cls, side: str, name: str, **available: Any) -> PolicySpec:
        """The policy ``name`` with whichever of ``available`` it accepts (a ``seed`` among
        them is replaced by each episode's seed)."""
        options = accepted_options(side, name, **available)
        options.pop("seed", None)
        return cls(side, name, tuple(sorted(options.items())))

    @property
    def seeded(self) -> bool:
        return "seed" in named_policy(self.side, self.name).options

    def build(self, scenario: Scenario, seed: int) -> Policy:
        extra = {"seed": seed} if self.seeded else {}
        return make_policy(self.side, self.name, scenario, **dict(self.options), **extra)


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


def _policy(spec: PolicySpec, scenario: Scenario, seed: int) -> Policy:
    """``spec`` for this episode: rebuilt when seeded, else built once per process."""
    if spec.seeded:
        return spec.build(scenario, seed)
    key = (scenario, spec)
    if key not in _BUILT:
        _BUILT[key] = spec.build(scenario, seed)
    return _BUILT[key]


def play_seed(sweep: Sweep, seed: int) -> EpisodeResult:
    """One episode of ``sweep`` (the task every backend runs)."""
    scenario = sweep.scenario
    if scenario not in _ENVS:
        _ENVS[scenario] = reachavoid_env.parallel_env(scenario=scenario)
    from reachavoid.rollout import run_episode

    return run_episode(_ENVS[scenario], _policy(sweep.attackers, scenario, seed),
                       _policy(sweep.defenders, scenario, seed), seed=seed)


def run_sweep(sweep: Sweep, backend: str = "serial", workers: int | None = None,
              address: str | None = None, progress: bool = False,
              description: str = "") -> list[EpisodeResult]:
    """Play every seed of ``sweep`` on ``backend`` and return the results in seed order.

    ``workers``: processes of the pool (default: the CPU count); ``address``: an existing
    Ray cluster (default: a local instance, started here and shut down after). Ctrl-C
    cancels the episodes not yet played and stops the workers.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend: expected one of {', '.join(BACKENDS)}, got {backend!r}")
    _policy(sweep.defenders, sweep.scenario, sweep.seeds[0])   # solves missing tubes once
    results = {}
    from tqdm import tqdm

    with tqdm(total=len(sweep.seeds), desc=description, unit="episode", disable=not progress,
              leave=False) as bar:
        play = {"serial": _serial, "process": _process_pool, "ray": _ray}[backend]
        for result in play(sweep, workers=workers, address=address):
            results[result.seed] = result
            bar.update(1)
    return [results[seed] for seed in sweep.seeds]


def _serial(sweep: Sweep, **_: Any) -> Iterator[EpisodeResult]:
    for seed in sweep.seeds:
        yield play_seed(sweep, seed)


def _process_pool(sweep: Sweep, workers: int | None, **_: Any) -> Iterator[EpisodeResult]:
    import multiprocessing

    pool = multiprocessing.get_context("spawn").Pool(workers or os.cpu_count())
    try:
        yield from pool.imap_unordered(functools.partial(play_seed, sweep), sweep.seeds)
    except BaseException:
        pool.terminate()   # Ctrl-C or SIGTERM: no worker outlives the sweep
        raise
    pool.close()
    pool.join()


def _ray(sweep: Sweep, workers: int | None, address: str | None,
         **_: Any) -> Iterator[EpisodeResult]:
    from solvers.hj.cache import cache_dir

    try:
        import ray
    except ImportError:
        raise ValueError("backend: 'ray' needs Ray (pip install 'reachavoid[ray]')") from None
    started = not ray.is_initialized()
    if started:
        ray.init(address=address, num_cpus=None if address else workers,
                 include_dashboard=False, log_to_driver=False,
                 runtime_env={"env_vars": {"REACHAVOID_CACHE_DIR": str(cache_dir())}})
    task = ray.remote(play_seed)
    shared = ray.put(sweep)
    pending = [task.remote(shared, seed) for seed in sweep.seeds]
    try:
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            yield ray.get(done[0])
    except BaseException:
        for ref in pending:
            ray.cancel(ref, force=True)
        raise
    finally:
        if started:
            ray.shutdown()


def sweep_of(scenario: Scenario, defenders: str, attackers: str, seeds: Sequence[int],
             **options: Any) -> Sweep:
    """The sweep of named policies with whichever of ``options`` each accepts."""
    return Sweep(scenario, PolicySpec.of("attackers", attackers, **options),
                 PolicySpec.of("defenders", defenders, **options), tuple(seeds))

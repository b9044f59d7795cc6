"""Many episodes and their statistics: capture rates with 95% confidence intervals.

``compare_defenders`` is ``reachavoid bench``: every defender method plays the same seeded
random starts (``sweep``: serially, on a process pool or on Ray). ``run_episodes`` plays
policy objects of your own. The benchmarks and the tests use the same functions.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from pettingzoo.utils.env import ParallelEnv
from tqdm import tqdm

from reachavoid.rollout import EpisodeResult, run_episode
from reachavoid.sweep import run_sweep, sweep_of
from reachavoid_env import Policy, Scenario, checks
from reachavoid_env.files import atomic_write

Z95 = 1.959963984540054


def run_episodes(env: ParallelEnv, attackers: Policy, defenders: Policy, episodes: int,
                 seed: int = 0, progress: bool = False,
                 description: str = "") -> list[EpisodeResult]:
    """Play ``episodes`` episodes; episode ``k`` resets the env with seed ``seed + k``.

    The same ``seed`` gives the same starts to every pair of policies, so methods are
    compared on identical games.
    """
    if episodes < 1:
        raise ValueError(f"episodes: must be a positive integer, got {episodes}")
    results = []
    for k in tqdm(range(episodes), desc=description, unit="episode", disable=not progress,
                  leave=False):
        results.append(run_episode(env, attackers, defenders, seed=seed + k))
    return results


def wilson_interval(successes: int, trials: int) -> tuple[float, float]:
    """95% Wilson score interval of a binomial proportion."""
    if trials == 0:
        return (0.0, 1.0)
    p = successes / trials
    denominator = 1 + Z95**2 / trials
    centre = (p + Z95**2 / (2 * trials)) / denominator
    half = Z95 * math.sqrt(p * (1 - p) / trials + Z95**2 / (4 * trials**2)) / denominator
    return (max(0.0, centre - half), min(1.0, centre + half))


def bootstrap_interval(samples: Sequence[float], resamples: int = 4000,
                       seed: int = 0) -> tuple[float, float]:
    """95% percentile bootstrap interval of the mean of ``samples``."""
    data = np.asarray(samples, dtype=np.float64)
    if len(data) < 2:
        value = float(data.mean()) if len(data) else 0.0
        return (value, value)
    rng = np.random.default_rng(seed)
    means = data[rng.integers(0, len(data), size=(resamples, len(data)))].mean(axis=1)
    low, high = np.percentile(means, [2.5, 97.5])
    return (float(low), float(high))


@dataclass(frozen=True)
class CaptureSummary:
    """Capture statistics of one method over many episodes.

    ``capture_rate``: the mean over episodes of the fraction of attackers captured, with a
    95% bootstrap interval (episodes are the independent units). ``all_captured_rate``:
    the fraction of episodes in which every attacker was captured, with a 95% Wilson
    interval. ``guaranteed_initial``: mean guaranteed (certified) captures at the first
    decision, ``nominal_initial`` the same with the paper's rule (defenders that report
    them). ``guarantee_violations``: episodes with any violation; ``arrivals_beyond_promise``:
    episodes where more attackers arrived than a guarantee allowed (the rest of the
    violations are falls of the count, ``EpisodeResult.guarantee_falls``).
    """

    label: str
    episodes: int
    attackers: int
    capture_rate: float
    capture_rate_ci: tuple[float, float]
    all_captured_rate: float
    all_captured_ci: tuple[float, float]
    mean_captured: float
    mean_arrived: float
    guaranteed_initial: float | None
    nominal_initial: float | None
    guarantee_violations: int
    arrivals_beyond_promise: int

    def to_dict(self) -> dict[str, Any]:
        return {key: (list(value) if isinstance(value, tuple) else value)
                for key, value in self.__dict__.items()}


def summarize(label: str, results: Sequence[EpisodeResult], attackers: int) -> CaptureSummary:
    """Capture statistics of ``results`` (each with ``attackers`` attackers)."""
    if not results:
        raise ValueError("results: need at least one episode")
    fractions = [r.captured_count / attackers for r in results]
    everyone = sum(r.captured_count == attackers for r in results)
    guaranteed = [r.guarantees[0] for r in results if r.guarantees]
    nominal = [r.nominal_guarantees[0] for r in results if r.nominal_guarantees]
    return CaptureSummary(
        label=label,
        episodes=len(results),
        attackers=attackers,
        capture_rate=float(np.mean(fractions)),
        capture_rate_ci=bootstrap_interval(fractions),
        all_captured_rate=everyone / len(results),
        all_captured_ci=wilson_interval(everyone, len(results)),
        mean_captured=float(np.mean([r.captured_count for r in results])),
        mean_arrived=float(np.mean([r.arrived_count for r in results])),
        guaranteed_initial=float(np.mean(guaranteed)) if guaranteed else None,
        nominal_initial=float(np.mean(nominal)) if nominal else None,
        guarantee_violations=sum(r.guarantee_violations > 0 for r in results),
        arrivals_beyond_promise=sum(r.arrivals_beyond_promise > 0 for r in results),
    )


def write_csv(path: str | os.PathLike[str], rows: Sequence[dict[str, Any]]) -> None:
    """Write ``rows`` (dicts with the same keys) as CSV, via a temporary name."""
    if not rows:
        raise ValueError("rows: nothing to write")
    with atomic_write(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


@dataclass(frozen=True)
class Comparison:
    """``compare_defenders``' answer: one summary per method and one row per episode."""

    scenario: Scenario
    summaries: tuple[CaptureSummary, ...]
    rows: tuple[dict[str, Any], ...]


def compare_defenders(scenario: Scenario, methods: Sequence[str], attackers: str,
                      episodes: int, seed: int = 0, backend: str = "serial",
                      workers: int | None = None, address: str | None = None,
                      progress: bool = False, **options: Any) -> Comparison:
    """Play ``episodes`` seeded starts of ``scenario`` with each defender method (names of
    ``policies.registry``) against the ``attackers`` policy; every method gets the same
    starts (seeds ``seed .. seed + episodes - 1``). ``options`` (``grid1``, ``grid2``...)
    go to whichever policy accepts them; ``backend``, ``workers`` and ``address`` as
    ``sweep.run_sweep`` (the results do not depend on them)."""
    checks.integer(episodes, "episodes", 1)
    seeds = range(seed, seed + episodes)
    summaries, rows = [], []
    for method in methods:
        sweep = sweep_of(scenario, method, attackers, seeds, progress=progress, **options)
        results = run_sweep(sweep, backend,
                            workers=workers, address=address, progress=progress,
                            description=method)
        summaries.append(summarize(method, results, scenario.num_attackers))
        rows.extend({"defenders": method, "attackers": attackers, **r.to_dict()}
                    for r in results)
    return Comparison(scenario, tuple(summaries), tuple(rows))

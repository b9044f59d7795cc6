"""Many episodes and their statistics: capture rates with 95% intervals, paired differences.

``compare_defenders`` is ``reachavoid bench``: every defender method (a name, a
``pkg.module:factory`` spec or a factory) plays the same seeded starts (``sweep``:
serially, on a process pool or on Ray), and each method's capture rate is compared with a
baseline's seed by seed (``paired_difference``). ``run_episodes`` plays policy objects of
your own. Intervals are honest about small samples (``mean_interval``): a proportion gets
the Wilson interval, a mean the bootstrap only with ``MIN_BOOTSTRAP`` varied episodes.
"""

from __future__ import annotations

import csv
import math
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from tqdm import tqdm

from policies.registry import Factory
from reachavoid.rollout import EpisodeResult, run_episode
from reachavoid.sweep import Sweep, run_sweeps, sweeps_of
from reachavoid_env import Policy, Scenario, checks
from reachavoid_env.files import atomic_write

if TYPE_CHECKING:
    from pettingzoo.utils.env import ParallelEnv

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


MIN_BOOTSTRAP = 30
"""Episodes needed before a mean gets a bootstrap interval (fewer: the Wilson bound)."""


class Interval(NamedTuple):
    """A 95% interval and how it was made: ``"wilson"`` (a proportion's Wilson score
    interval), ``"wilson-bound"`` (a bounded mean's Wilson interval at the largest variance
    its mean allows: wider than needed, never too narrow) or ``"bootstrap"`` (percentile
    bootstrap over episodes)."""

    low: float
    high: float
    method: str


def wilson_interval(successes: float, trials: int) -> tuple[float, float]:
    """95% Wilson score interval of a binomial proportion ``successes / trials``.

    A fractional ``successes`` (a mean of values in [0, 1] times ``trials``) gives the
    interval at the Bernoulli variance ``p (1 - p)``, the largest that mean allows.
    Ours, not ``scipy.stats.binomtest(...).proportion_ci("wilson")``: that takes whole
    successes only, and the Wilson bound needs a fractional count."""
    if trials == 0:
        return (0.0, 1.0)
    p = successes / trials
    denominator = 1 + Z95**2 / trials
    centre = (p + Z95**2 / (2 * trials)) / denominator
    half = Z95 * math.sqrt(p * (1 - p) / trials + Z95**2 / (4 * trials**2)) / denominator
    return (min(p, max(0.0, centre - half)), max(p, min(1.0, centre + half)))  # p inside


def bootstrap_interval(samples: Sequence[float], resamples: int = 4000,
                       seed: int = 0) -> tuple[float, float]:
    """95% percentile bootstrap interval of the mean of ``samples`` (no judgement of
    whether there are enough: ``mean_interval`` makes it)."""
    from scipy import stats  # heavy: only where intervals are made

    data = np.asarray(samples, dtype=np.float64)
    if len(data) < 2:
        value = float(data.mean()) if len(data) else 0.0
        return (value, value)
    found = stats.bootstrap((data,), np.mean, n_resamples=resamples, method="percentile",
                            rng=np.random.default_rng(seed)).confidence_interval
    return (float(found.low), float(found.high))


def mean_interval(samples: Sequence[float], low: float = 0.0, high: float = 1.0) -> Interval:
    """95% interval of the mean of ``samples``, one per episode.

    Values all ``low`` or ``high``: a proportion, the Wilson interval. Otherwise the
    bootstrap when there are at least ``MIN_BOOTSTRAP`` samples and they are not all equal,
    else the Wilson bound (the values rescaled to [0, 1]): so one episode, or many equal
    ones, never give an interval of zero width.

    Args:
        samples: the per-episode values, each in ``[low, high]``.
        low, high: the bounds of a value (capture fractions: 0 and 1; paired differences
            of fractions: -1 and 1).

    Returns:
        ``Interval(low, high, method)`` in the units of the samples.
    """
    data = np.asarray(samples, dtype=np.float64)
    if len(data) == 0:
        raise ValueError("samples: need at least one")
    width = high - low
    unit = (data - low) / width
    if np.all((unit == 0.0) | (unit == 1.0)):
        lo, hi = wilson_interval(float(unit.sum()), len(unit))
        return Interval(low + width * lo, low + width * hi, "wilson")
    if len(data) >= MIN_BOOTSTRAP and np.ptp(data) > 0:
        return Interval(*bootstrap_interval(data), "bootstrap")
    lo, hi = wilson_interval(float(unit.sum()), len(unit))
    return Interval(low + width * lo, low + width * hi, "wilson-bound")


@dataclass(frozen=True)
class CaptureSummary:
    """Capture statistics of one method over many episodes.

    ``capture_rate``: the mean over episodes of the fraction of attackers captured, with a
    95% interval made by ``capture_rate_method`` (``mean_interval``: Wilson for a
    proportion, the bootstrap with enough varied episodes, else the Wilson bound; episodes
    are the independent units). ``all_captured_rate``: the fraction of episodes in which
    every attacker was captured, with a 95% Wilson interval. ``guaranteed_initial``: mean
    guaranteed (certified) captures at the first decision, ``nominal_initial`` the same
    with the paper's rule (defenders that report them). ``guarantee_violations``: episodes
    with any violation; ``arrivals_beyond_promise``: episodes where more attackers arrived
    than a guarantee allowed (the rest of the violations are falls of the count,
    ``EpisodeResult.guarantee_falls``).
    """

    label: str
    episodes: int
    attackers: int
    capture_rate: float
    capture_rate_ci: tuple[float, float]
    capture_rate_method: str
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


def _attackers(results: Sequence[EpisodeResult]) -> int:
    """The attacker count the results carry (one count for all, else ``ValueError``)."""
    counts = {r.num_attackers for r in results}
    if len(counts) != 1:
        raise ValueError(f"results: need episodes with one attacker count, got "
                         f"{sorted(counts) or 'none'}")
    return counts.pop()


def capture_fractions(results: Sequence[EpisodeResult]) -> np.ndarray:
    """Per episode, the fraction of its attackers captured."""
    return np.array([r.captured_count / r.num_attackers for r in results])


def arrival_fractions(results: Sequence[EpisodeResult]) -> np.ndarray:
    """Per episode, the fraction of its attackers that arrived."""
    return np.array([r.arrived_count / r.num_attackers for r in results])


def summarize(label: str, results: Sequence[EpisodeResult]) -> CaptureSummary:
    """Capture statistics of ``results`` (episodes of one game size)."""
    attackers = _attackers(results)
    fractions = capture_fractions(results)
    everyone = sum(r.captured_count == attackers for r in results)
    guaranteed = [r.guarantees[0] for r in results if r.guarantees]
    nominal = [r.nominal_captures[0] for r in results if r.nominal_captures]
    rate = mean_interval(fractions)
    return CaptureSummary(
        label=label,
        episodes=len(results),
        attackers=attackers,
        capture_rate=float(np.mean(fractions)),
        capture_rate_ci=(rate.low, rate.high),
        capture_rate_method=rate.method,
        all_captured_rate=everyone / len(results),
        all_captured_ci=wilson_interval(everyone, len(results)),
        mean_captured=float(np.mean([r.captured_count for r in results])),
        mean_arrived=float(np.mean([r.arrived_count for r in results])),
        guaranteed_initial=float(np.mean(guaranteed)) if guaranteed else None,
        nominal_initial=float(np.mean(nominal)) if nominal else None,
        guarantee_violations=sum(r.guarantee_violations > 0 for r in results),
        arrivals_beyond_promise=sum(r.arrivals_beyond_promise > 0 for r in results),
    )


@dataclass(frozen=True)
class PairedDifference:
    """``label``'s capture rate minus ``baseline``'s on the same seeds: the mean of the
    per-seed differences of the captured fractions (in [-1, 1]), with a 95% interval made
    by ``method`` (``mean_interval``). An interval that excludes 0 is a difference."""

    label: str
    baseline: str
    episodes: int
    difference: float
    ci: tuple[float, float]
    method: str

    def to_dict(self) -> dict[str, Any]:
        return {key: (list(value) if isinstance(value, tuple) else value)
                for key, value in self.__dict__.items()}


def paired_difference(label: str, results: Sequence[EpisodeResult], baseline: str,
                      baseline_results: Sequence[EpisodeResult]) -> PairedDifference:
    """``label`` minus ``baseline`` on the same seeds (a ``ValueError`` when they differ)."""
    seeds = [r.seed for r in results]
    if seeds != [r.seed for r in baseline_results]:
        raise ValueError(f"results: {label!r} and {baseline!r} were not played on the same "
                         f"seeds")
    differences = capture_fractions(results) - capture_fractions(baseline_results)
    interval = mean_interval(differences, -1.0, 1.0)
    return PairedDifference(label, baseline, len(differences), float(differences.mean()),
                            (interval.low, interval.high), interval.method)


def write_csv(path: str | os.PathLike[str], rows: Sequence[dict[str, Any]]) -> None:
    """Write ``rows`` as CSV, via a temporary name: the columns are every key of any row,
    in order of appearance (a row without one leaves it empty)."""
    if not rows:
        raise ValueError("rows: nothing to write")
    with atomic_write(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(dict.fromkeys(k for row in rows
                                                                      for k in row)))
        writer.writeheader()
        writer.writerows(rows)


class OneStartWarning(UserWarning):
    """Every episode of a comparison starts from the same positions (a scenario with fixed
    starts): its intervals cover the policies' randomness only, not the starts."""


def one_start(scenario: Scenario) -> bool:
    """Whether every seed of ``scenario`` starts from the same positions."""
    return scenario.attackers is not None and scenario.defenders is not None


def score(labels: Sequence[str], results: Sequence[Sequence[EpisodeResult]],
          baseline: str | None = None
          ) -> tuple[tuple[CaptureSummary, ...], tuple[PairedDifference, ...]]:
    """Each method's ``summarize`` and, with a ``baseline`` among ``labels``, every other
    method's ``paired_difference`` from it (``results[k]``: method ``labels[k]``'s episodes,
    the same seeds in the same order for every method)."""
    summaries = tuple(summarize(label, played) for label, played in zip(labels, results,
                                                                          strict=True))
    if baseline is None:
        return summaries, ()
    if baseline not in labels:
        raise ValueError(f"baseline: {baseline!r} is not among the methods "
                         f"({', '.join(labels)})")
    reference = results[list(labels).index(baseline)]
    return summaries, tuple(paired_difference(label, played, baseline, reference)
                            for label, played in zip(labels, results, strict=True)
                            if label != baseline)


@dataclass(frozen=True)
class Comparison:
    """``compare_defenders``' answer: one summary per method, the paired differences of
    every other method against ``baseline`` (none without one), and one row per
    episode."""

    scenario: Scenario
    attackers: str
    summaries: tuple[CaptureSummary, ...]
    differences: tuple[PairedDifference, ...]
    rows: tuple[dict[str, Any], ...]


def compare(scenario: Scenario, sweeps: Sequence[Sweep], results: Sequence[Sequence[EpisodeResult]],
            baseline: str | None = None) -> Comparison:
    """The ``Comparison`` of played sweeps (one per defender method, same attackers and
    seeds)."""
    labels = [sweep.defenders.label for sweep in sweeps]
    attackers = sweeps[0].attackers.label
    summaries, differences = score(labels, results, baseline)
    rows = tuple({"defenders": label, "attackers": attackers, **r.to_dict()}
                 for label, played in zip(labels, results, strict=True) for r in played)
    return Comparison(scenario, attackers, summaries, differences, rows)


def compare_defenders(scenario: Scenario, methods: Sequence[str | Factory],
                      attackers: str | Factory, episodes: int, seed: int = 0,
                      backend: str = "serial", workers: int | None = None,
                      address: str | None = None, progress: bool = True,
                      baseline: str | None = None, **options: Any) -> Comparison:
    """Play ``episodes`` seeded starts of ``scenario`` with each defender method against
    ``attackers``; every method gets the same starts (seeds ``seed .. seed + episodes -
    1``).

    Methods and attackers are specs of ``policies.registry`` (a name, an installed name,
    ``pkg.module:factory``) or factories. ``options`` (``grid1``, ``grid2``...) go to each
    policy that takes them; one that no policy takes is a ``ValueError``. ``baseline``: a
    method to take paired differences against. ``progress`` shows bars (a missing tube is
    solved first, which takes minutes at the paper's grids). ``backend``, ``workers`` and
    ``address`` as ``sweep.run_sweeps`` (the results do not depend on them). A scenario
    with fixed starts plays every episode from them: an ``OneStartWarning``.
    """
    checks.integer(episodes, "episodes", 1)
    sweeps = sweeps_of(scenario, methods, attackers, range(seed, seed + episodes), options)
    if episodes > 1 and one_start(scenario):
        warnings.warn(f"{scenario.name}: every episode starts from the scenario's fixed "
                      f"starts; the intervals cover the policies' randomness only",
                      OneStartWarning, stacklevel=2)
    results = run_sweeps(sweeps, backend, workers=workers, address=address,
                         progress=progress, description=scenario.name)
    return compare(scenario, sweeps, results, baseline)

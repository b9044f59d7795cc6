"""What ``bench`` and ``paper`` print: a table per suite cell and per pooled attacker
policy (capture rates with their 95% intervals, paired differences), and the paper's
table beside ours."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from reachavoid.evaluation import MIN_BOOTSTRAP, CaptureSummary, PairedDifference
from reachavoid.suite import SuiteResult

if TYPE_CHECKING:
    from reachavoid.paper import PaperRow


INTERVALS = ("95% intervals: a proportion (every value 0 or 1) gets the Wilson interval; "
             f"a mean the percentile bootstrap over episodes when there are >= {MIN_BOOTSTRAP} "
             "and they vary, else the Wilson bound (never too narrow); differences are "
             "per seed, against the baseline")


def percent(value: float, interval: tuple[float, float], method: str = "") -> str:
    tag = {"wilson": " W", "wilson-bound": " Wb", "bootstrap": " B", "": ""}[method]
    return f"{value:6.1%} [{interval[0]:.1%}, {interval[1]:.1%}]{tag}"


def bench_tables(result: SuiteResult, seconds: float) -> str:
    """A table per cell, then per pooled attacker policy: each method's capture rates, then
    its paired difference."""
    suite = result.suite
    width = max(10, *(len(m) for m in result.methods))
    title = (f"suite {suite.name} v{suite.version}, {len(suite.cells)} cells"
             if suite.version else suite.name)
    lines = [f"{title}; defenders {', '.join(result.methods)}; baseline {result.baseline}; "
             f"{seconds:.0f} s wall time", INTERVALS + " (W Wilson, Wb Wilson bound, "
             "B bootstrap)"]
    for cell in result.cells:
        comparison = cell.comparison
        episodes = comparison.summaries[0].episodes
        lines += ["", f"{cell.cell.label}: {episodes} episode(s), seeds {suite.seed}.."
                      f"{suite.seed + episodes - 1}" + (" (all from one start)"
                                                        if cell.one_start else "")]
        lines += _method_rows(comparison.summaries, comparison.differences, width,
                              cell.seconds_per_episode)
    for pooled in result.pooled:
        lines += ["", f"pooled / {pooled.attackers}: {pooled.cells} maps, "
                      f"{pooled.summaries[0].episodes} episodes (differences paired by map "
                      f"and seed)"]
        lines += _method_rows(pooled.summaries, pooled.differences, width)
    return "\n".join(lines)


def _method_rows(summaries: Sequence[CaptureSummary], differences: Sequence[PairedDifference],
                 width: int, seconds: dict[str, float] | None = None) -> list[str]:
    """A header, a row per method's summary (``seconds`` per episode when given), then a
    row per paired difference."""
    lines = [f"  {'defenders':<{width}} {'capture rate [95% CI]':<29} "
             f"{'all captured [95% CI]':<26} {'guaranteed':>10} {'nominal':>8} "
             f"{'violations':>10}" + (f" {'s/episode':>9}" if seconds else "")]
    for s in summaries:
        guaranteed, nominal = ("-" if x is None else f"{x:.2f}"
                               for x in (s.guaranteed_initial, s.nominal_initial))
        rate = percent(s.capture_rate, s.capture_rate_ci, s.capture_rate_method)
        lines.append(f"  {s.label:<{width}} {rate:<29} "
                     f"{percent(s.all_captured_rate, s.all_captured_ci):<26} "
                     f"{guaranteed:>10} {nominal:>8} {s.guarantee_violations:>10}"
                     + (f" {seconds[s.label]:>9.2f}" if seconds else ""))
    for d in differences:
        lines.append(f"  {d.label} - {d.baseline}: capture rate {d.difference:+.1%} "
                     f"[{d.ci[0]:+.1%}, {d.ci[1]:+.1%}] ({d.method}, {d.episodes} "
                     f"paired seed(s))")
    return lines


def paper_lines(rows: Sequence[PaperRow], grid1: int, grid2: int, attackers: str,
                out: Path) -> str:
    """``paper``'s table: the attackers captured in each game, ours beside the paper's, for
    the HJ + MIP defenders and the matching baseline."""
    lines = [f"Attackers captured (grids {grid1}^4 and {grid2}^6; {attackers} attackers)",
             f"  {'game':<10} {'ours':>6} {'paper':>6} {'baseline':>9} {'paper':>6}"]
    for row in rows:
        ours, baseline = row.measured["paper"], row.measured["matching"]
        lines.append(f"  {row.scenario.split('_')[-1]:<10} {ours['captured_count']:>6} "
                     f"{row.reported['paper']:>6} {baseline['captured_count']:>9} "
                     f"{row.reported['matching']:>6}")
    lines.append(f"  videos, table.json and tubes.png in {out}/")
    return "\n".join(lines)

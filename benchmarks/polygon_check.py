"""Polygon validation time at the vertex cap (``MAX_POLYGON_VERTICES``, issue 21 item 8).

Builds a simple star-shaped ring of N vertices (no two edges meet, so every pair is
checked: the worst case) and times ``Polygon(...)``, which runs the self-intersection
check, against the pairwise loop it replaced (``_edges_meet`` on every pair of edges).
Each figure is the best of ``--repeats`` runs (the machine is shared).

    .venv/bin/python benchmarks/polygon_check.py [--vertices 250 500 1000] [--repeats 3]
        [--json benchmarks/results/polygon_check.json]
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

import numpy as np
from harness import WALL, timed
from result_file import write_result

from reachavoid_env.shapes import MAX_POLYGON_VERTICES, Polygon, _edges_meet


def star(vertices: int) -> tuple[tuple[float, float], ...]:
    """A simple ring: radius 1 + 0.3 sin(7 t), counter-clockwise."""
    angles = np.linspace(0.0, 2.0 * np.pi, vertices, endpoint=False)
    radius = 1.0 + 0.3 * np.sin(7.0 * angles)
    return tuple(map(tuple, np.stack([radius * np.cos(angles), radius * np.sin(angles)], 1)))


def pairwise(v: np.ndarray) -> bool:
    """The check before issue 21: every pair of edges, one ``_edges_meet`` call each."""
    n = len(v)
    return any(_edges_meet(v[i], v[(i + 1) % n], v[j], v[(j + 1) % n],
                           j == i + 1 or (i == 0 and j == n - 1))
               for i in range(n) for j in range(i + 1, n))


def best(run: Callable[[], object], repeats: int) -> float:
    """The fewest wall seconds of ``repeats`` runs (``harness.timed``)."""
    def work() -> None:
        run()

    return min(timed(work, repeats, clock=WALL).seconds)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vertices", type=int, nargs="+",
                        default=[250, 500, MAX_POLYGON_VERTICES])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    args = parser.parse_args()
    figures: dict[str, float] = {"vertices": max(args.vertices)}
    print(f"{'vertices':>8} {'Polygon() s':>12} {'pairwise s':>11}")
    for n in args.vertices:
        ring = star(n)
        now = best(lambda ring=ring: Polygon(ring), args.repeats)
        before = best(lambda ring=ring: pairwise(np.asarray(ring)), 1)
        print(f"{n:>8} {now:>12.3f} {before:>11.2f}")
        figures |= {f"seconds.{n}.now": now, f"seconds.{n}.before": before}
    if args.json:
        write_result(args.json, "polygon_check", figures,
                     {"seconds": "Polygon() on a simple ring of that many vertices, best of "
                                 "--repeats (now) and the pairwise loop it replaced (before)",
                      "vertices": "the largest ring measured"})


if __name__ == "__main__":
    main()

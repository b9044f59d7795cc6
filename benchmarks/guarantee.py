"""Benchmark: how often Algorithm 1's guarantee breaks (BENCHMARKS.md, "The guarantee").

Seeded random starts of 4v2, 6v2 and 8v4 on the paper map and of 6v4 on the equal-speed
scenario (``paper_6v4_equal``; ``--configs`` picks, ``2v1`` among them), against
shortest-path, random and HJ attackers (``--attackers``: a comma-separated choice,
``hj-pairs`` among them, or a trained team ``sb3:MODEL.zip`` for the configs it plays); the
defenders (``--defenders``, default the reference ``hj``; ``hj-pairs`` also plays the
equal-speed scenario) report their certified ``guaranteed_captures`` every step. An
episode *violates* the guarantee when captured-so-far plus guaranteed-from-now falls
(``EpisodeResult.guarantee_falls``: the certificate gave a game up) or when more attackers
arrive than a guarantee allowed (``arrivals_beyond_promise``, the broken promise itself).
``--margin-cells 0`` reads the tubes as the paper does (the "before"); the default is the
policy's certificate. Every method plays the same starts (``reachavoid.compare_defenders``):

    python benchmarks/guarantee.py --episodes 84 --backend process            # 1,008 episodes
    python benchmarks/guarantee.py --episodes 84 --backend process --margin-cells 0
    python benchmarks/guarantee.py --episodes 84 --attackers hj-pairs       # pairs that split
    python benchmarks/guarantee.py --configs 2v1 --grid1 31 --grid2 15 --episodes 500 \
        --attackers sb3:runs/team_2v1_pairs_ppo/model.zip   # the trained 2 vs 1 team

``--json PATH`` writes the totals and the certified counts at the start as a result record
(``benchmarks/result_file.py``).
"""

from __future__ import annotations

import argparse
import time

from result_file import write_result

import reachavoid_env
from policies.learned import SB3_PREFIX
from policies.strategy import CERTIFICATE_CELLS
from reachavoid import compare_defenders
from reachavoid.sweep import BACKENDS

CONFIGS = {"2v1": ("paper_2v1", 2, 1), "4v2": ("paper_2v1", 4, 2), "6v2": ("paper_2v1", 6, 2),
           "8v4": ("paper_2v1", 8, 4), "6v4_equal": ("paper_6v4_equal", 6, 4)}
DEFAULT_CONFIGS = ("4v2", "6v2", "8v4", "6v4_equal")
ATTACKERS = ("shortest-path", "random", "hj", "hj-pairs")
DEFAULT_ATTACKERS = ATTACKERS[:3]
PAIRS_ON = "paper_6v4_equal"
"""``hj-pairs`` (when asked for) plays the scenario where teams matter."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid1", type=int, default=45)
    parser.add_argument("--grid2", type=int, default=30)
    parser.add_argument("--episodes", type=int, default=20,
                        help="per configuration and attacker (seeds 0..N-1)")
    parser.add_argument("--defenders", default="hj,hj-pairs",
                        help="comma-separated methods (hj-pairs on the equal-speed scenario)")
    parser.add_argument("--attackers", default=",".join(DEFAULT_ATTACKERS),
                        help="comma-separated attackers, each against every method "
                             "(default: %(default)s)")
    parser.add_argument("--configs", default=",".join(DEFAULT_CONFIGS),
                        help=f"comma-separated, some of {', '.join(CONFIGS)} "
                             "(default: %(default)s)")
    parser.add_argument("--margin-cells", type=float, default=CERTIFICATE_CELLS)
    parser.add_argument("--backend", choices=BACKENDS, default="serial")
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    args = parser.parse_args()
    methods = [m.strip() for m in args.defenders.split(",") if m.strip()]
    attacker_teams = [a.strip() for a in args.attackers.split(",") if a.strip()]
    unknown = [a for a in attacker_teams if a not in ATTACKERS and not a.startswith(SB3_PREFIX)]
    if unknown or not attacker_teams:
        parser.error(f"--attackers: expected some of {', '.join(ATTACKERS)} or "
                     f"{SB3_PREFIX}MODEL.zip, got {args.attackers!r}")
    if sum(a.startswith(SB3_PREFIX) for a in attacker_teams) > 1:
        parser.error("--attackers: one sb3:MODEL.zip team per run (their records share the "
                     "key 'trained')")
    configs = [c.strip() for c in args.configs.split(",") if c.strip()]
    if not configs or any(c not in CONFIGS for c in configs):
        parser.error(f"--configs: expected some of {', '.join(CONFIGS)}, got {args.configs!r}")

    print(f"tubes {args.grid1}^4 / {args.grid2}^6, margin {args.margin_cells:g} cells, "
          f"{args.episodes} episodes per configuration and attacker (seeds 0.."
          f"{args.episodes - 1}), backend {args.backend}")
    print("| config | attackers | defenders | violated | arrived beyond promise | "
          "guaranteed at start | nominal at start | stopped | captured |")
    print("|---|---|---|---|---|---|---|---|---|")
    totals: dict[str, list[int]] = {m: [0, 0, 0] for m in methods}
    figures: dict[str, float] = {}
    started = time.perf_counter()
    for name, m, n in (CONFIGS[c] for c in configs):
        scenario = reachavoid_env.builtin_scenario(name).with_players(m, n)
        here = [x for x in methods if x != "hj-pairs" or name == PAIRS_ON]
        for attackers in attacker_teams:
            try:
                comparison = compare_defenders(scenario, here, attackers, args.episodes,
                                               backend=args.backend, workers=args.workers,
                                               grid1=args.grid1, grid2=args.grid2,
                                               margin_cells=args.margin_cells)
            except reachavoid_env.PolicyMismatch as error:   # a model trained on other teams
                parser.error(f"--attackers: {error}")
            for s in comparison.summaries:
                totals[s.label] = [a + b for a, b in zip(
                    totals[s.label], (s.guarantee_violations, s.arrivals_beyond_promise,
                                      s.episodes), strict=True)]
                print(f"| {m}v{n}{' equal' if name == PAIRS_ON else ''} | {attackers} | "
                      f"{s.label} | {s.guarantee_violations} / {s.episodes} | "
                      f"{s.arrivals_beyond_promise} | {s.guaranteed_initial:.2f} | "
                      f"{s.nominal_initial:.2f} | {m - s.mean_arrived:.2f} | "
                      f"{s.mean_captured:.2f} |", flush=True)
                method = "" if s.label == "hj" else "." + s.label.replace("-", "_")
                config = f"{m}v{n}{'_equal' if name == PAIRS_ON else ''}"
                figures[f"guaranteed_at_start.{config}{method}"] = s.guaranteed_initial
                figures[f"nominal_at_start.{config}{method}"] = s.nominal_initial
                team = ("trained" if attackers.startswith(SB3_PREFIX)
                        else attackers.replace("-", "_"))
                figures[f"arrived.{config}.{team}{method}"] = s.mean_arrived
    for method, (violated, beyond, episodes) in totals.items():
        print(f"{method}: violated in {violated} / {episodes} episodes "
              f"({violated / max(episodes, 1):.1%}), arrivals beyond the promise in {beyond}")
        key = method.replace("-", "_")
        figures |= {f"episodes.{key}": episodes, f"violated.{key}": violated,
                    f"violated_percent.{key}": 100 * violated / max(episodes, 1),
                    f"arrived_beyond_promise.{key}": beyond}
    wall = time.perf_counter() - started
    print(f"wall time {wall:.0f} s")
    if args.json:
        write_result(args.json, "guarantee", figures | {"wall_s": wall}, {
            "episodes": f"episodes played, tubes {args.grid1}^4 / {args.grid2}^6, margin "
                        f"{args.margin_cells:g} cells",
            "violated": "episodes whose guarantee fell or saw an arrival beyond it",
            "violated_percent": "the same, percent of the episodes played",
            "arrived_beyond_promise": "arrivals beyond what the guarantee allowed",
            "guaranteed_at_start": "mean certified captures at the first decision (hj unless "
                                   "a method is named)",
            "nominal_at_start": "mean captures the tubes read as the paper does (no margin) "
                                "promise at the first decision",
            "arrived": "mean attackers that reached the target per episode, by attackers "
                       "(trained: an sb3:MODEL.zip team)",
            "wall_s": "wall seconds of the whole run"})


if __name__ == "__main__":
    main()

"""v2's defaults, measured (``reach_avoid_v2`` states them; BENCHMARKS.md quotes this).

In one run, on ``--scenario`` (``paper_2v1``) with v2's defaults unless told otherwise:

- **random play**: ``--episodes`` episodes (seeds 0..) of uniformly random actions for
  every agent at every decision: the share of episodes that meet a capture or an arrival
  (with its Wilson 95% interval) and the mean decisions per episode;
- **shortest path against idle defenders**: the same seeds, ``shortest-path`` attackers
  against ``idle`` defenders: the share of episodes with an arrival and the decision of
  the first arrival (mean and largest);
- **throughput** on one core: random-action parallel ``step`` calls per second of v2 and
  of v1 (``paper_2v1``, both egocentric), and the physics steps per second of v2
  (decisions times ``decision_steps``), each the best of ``--repeats`` wall-clock rounds
  (the envs interleaved in every round, ``harness.alternate``) of ``--steps`` decisions
  (v1 and MPE: as many physics steps); with ``mpe2`` installed also MPE2
  ``simple_tag_v3`` (its default 1 good agent, 3 adversaries, 2 obstacles, continuous
  actions) in the same rounds.

    taskset -c 0 python benchmarks/v2_defaults.py --json benchmarks/results/v2_defaults.json
"""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Callable
from typing import Any

import numpy as np
from harness import WALL, alternate
from result_file import write_result

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

from policies import IdleDefender, ShortestPathAttacker  # noqa: E402
from reachavoid_env import reach_avoid_v1, reach_avoid_v2  # noqa: E402
from reachavoid_env.decisions import DECISION_STEPS, MAX_DECISIONS  # noqa: E402

Z95 = 1.959964


def wilson(successes: int, n: int) -> list[float]:
    """``[share, low, high]``: the share with its Wilson 95% interval."""
    p = successes / n
    centre = (p + Z95 ** 2 / (2 * n)) / (1 + Z95 ** 2 / n)
    half = Z95 * math.sqrt(p * (1 - p) / n + Z95 ** 2 / (4 * n * n)) / (1 + Z95 ** 2 / n)
    return [p, centre - half, centre + half]


def random_play(env_kwargs: dict[str, Any], episodes: int) -> dict[str, Any]:
    """Random actions for every agent: the share of episodes with an event, mean length."""
    env = reach_avoid_v2.parallel_env(**env_kwargs)
    met, lengths = 0, []
    for seed in range(episodes):
        env.reset(seed=seed)
        for agent in env.possible_agents:
            env.action_space(agent).seed(seed)
        decisions, event = 0, False
        while env.agents:
            _, _, _, _, infos = env.step({a: env.action_space(a).sample() for a in env.agents})
            decisions += 1
            event = event or any(info["captured"] or info["arrived"] for info in infos.values())
        met += event
        lengths.append(decisions)
    return {"event_share": wilson(met, episodes), "mean_decisions": float(np.mean(lengths))}


def shortest_path(env_kwargs: dict[str, Any], episodes: int) -> dict[str, Any]:
    """Shortest-path attackers, idle defenders: arrival share and first-arrival decision."""
    env = reach_avoid_v2.parallel_env(**env_kwargs)
    attackers, defenders = ShortestPathAttacker(), IdleDefender()
    firsts, arrived = [], 0
    for seed in range(episodes):
        env.reset(seed=seed)
        attackers.reset(env.scenario)
        defenders.reset(env.scenario)
        decisions, first = 0, None
        while env.agents:
            state = env.game_state()
            actions = {**attackers.act(state), **defenders.act(state)}
            _, _, _, _, infos = env.step({a: actions[a] for a in env.agents})
            decisions += 1
            if first is None and any(info["arrived"] for info in infos.values()):
                first = decisions
        if first is not None:
            arrived += 1
            firsts.append(first)
    return {"arrival_share": wilson(arrived, episodes),
            "first_arrival_mean": float(np.mean(firsts)),
            "first_arrival_max": float(np.max(firsts))}


def stepper(make: Callable[[], Any], steps: int) -> Callable[[], int]:
    """A harness work: ``steps`` parallel steps of one env (made once) with random actions
    drawn beforehand (resets included); returns ``steps``."""
    env = make()
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    samples = {a: [env.action_space(a).sample() for _ in range(64)]
               for a in env.possible_agents}

    def run() -> int:
        for i in range(steps):
            if not env.agents:
                env.reset(seed=int(rng.integers(1 << 30)))
            env.step({a: samples[a][i % 64] for a in env.agents})
        return steps

    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenario", default="paper_2v1")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--decision-steps", type=int, default=DECISION_STEPS)
    parser.add_argument("--max-cycles", type=int, default=MAX_DECISIONS)
    parser.add_argument("--steps", type=int, default=2000, help="steps per throughput run")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", help="write the result record here")
    args = parser.parse_args()
    kwargs = {"scenario": args.scenario, "decision_steps": args.decision_steps,
              "max_cycles": args.max_cycles}
    figures: dict[str, Any] = {}
    for key, value in random_play(kwargs, args.episodes).items():
        figures[f"random.{key}"] = value
    for key, value in shortest_path(kwargs, args.episodes).items():
        figures[f"shortest_path.{key}"] = value
    works = {
        "v2_decisions_per_s": stepper(lambda: reach_avoid_v2.parallel_env(**kwargs),
                                      args.steps),
        "v1_steps_per_s": stepper(lambda: reach_avoid_v1.parallel_env(scenario=args.scenario),
                                  args.steps * args.decision_steps)}
    try:
        from mpe2 import simple_tag_v3
    except ImportError:
        print("mpe2 is not installed: no MPE2 figure")
    else:
        works["mpe2_simple_tag_steps_per_s"] = stepper(
            lambda: simple_tag_v3.parallel_env(continuous_actions=True, max_cycles=1000),
            args.steps * args.decision_steps)
    rates = {name: timing.best
             for name, timing in alternate(works, args.repeats, clock=WALL).items()}
    rates["v2_physics_steps_per_s"] = rates["v2_decisions_per_s"] * args.decision_steps
    figures.update({f"throughput.{key}": value for key, value in rates.items()})
    for key, value in figures.items():
        print(f"{key}: {value}")
    if args.json:
        write_result(args.json, "v2_defaults", figures, {
            "random": "random play, every agent uniformly random each decision: "
                      "event_share [share, low, high] of episodes with a capture or arrival "
                      "(Wilson 95%); mean_decisions per episode",
            "shortest_path": "shortest-path attackers vs idle defenders: arrival_share "
                             "[share, low, high]; decision of the first arrival (mean, max)",
            "throughput": "parallel step calls per second, random actions, best of repeats; "
                          "v2 physics steps = decisions x decision_steps"})


if __name__ == "__main__":
    main()

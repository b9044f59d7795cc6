"""The single-game attacker-only view with ``hj`` defenders, timed: game steps per second
of ``make_attackers_parallel_env`` on paper_8v4 with random attacker actions (drawn
beforehand), 1000-step episodes, resets included. Kept apart from
``vector_throughput.py`` so that a checkout older than the vector env runs it too
(``vector_throughput.py --baseline``): every name it uses exists since 803c18f.

    PYTHONPATH=CHECKOUT python benchmarks/single_view.py STEPS WARMUP   # prints the rate
"""

from __future__ import annotations

import json
import sys

from harness import WALL, timed, training_views

SCENARIO = "paper_8v4"
EPISODE_STEPS = 1000
GRIDS = {"grid1": 31, "grid2": 15}      # the training recipes' tubes


def single_view_rate(steps: int, warmup: int) -> float:
    """Game steps per second of the single-game attacker-only view with ``hj``, timed over
    ``steps`` game steps after ``warmup`` untimed ones (every name it uses exists since
    803c18f, so an earlier checkout runs it too; ``harness.training_views``)."""
    env = training_views().make_attackers_parallel_env(
        SCENARIO, defenders="hj", defender_options=GRIDS, max_cycles=EPISODE_STEPS)
    return parallel_rate(env, steps, warmup)


def parallel_rate(env: object, steps: int, warmup: int = 0) -> float:
    """Steps per second of a PettingZoo parallel ``env`` over ``steps`` steps after
    ``warmup`` untimed ones (actions drawn beforehand; a new episode where one ended)."""
    env.reset(seed=0)
    for i, name in enumerate(env.possible_agents):
        env.action_space(name).seed(i)
    drawn = [{name: env.action_space(name).sample() for name in env.possible_agents}
             for _ in range(8)]
    done = [0]

    def play(count: int) -> int:
        for _ in range(count):
            if not env.agents:
                env.reset()
            env.step({name: drawn[done[0] % 8][name] for name in env.agents})
            done[0] += 1
        return count

    play(warmup)
    return timed(lambda: play(steps), clock=WALL).median


if __name__ == "__main__":
    print(json.dumps(single_view_rate(int(sys.argv[1]), int(sys.argv[2]))))

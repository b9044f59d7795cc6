"""Vector env throughput: K copies of paper_8v4 stepped together, against the single env
and MPE2's simple_tag (8 good agents, 4 adversaries), in one run; and the attacker-only
training view at K copies with the ``hj`` and ``greedy`` defenders (batched) against the
single-env attacker-only view with ``hj``.

Game steps per second (one game step = one step of one copy) with random actions drawn
beforehand, resets included (autoreset in the vector env, ``reset()`` at the end of an
episode in the single envs), for both observations (v1's egocentric default, v0's global
vector). Each figure is the median of ``--repeats`` timed runs. Pin it to one core:

    taskset -c 0 .venv/bin/python benchmarks/vector_throughput.py --views --floors \
        --baseline 803c18f --json out.json

``--views``: the views are timed in their steady state, after ``--view-warmup`` vector
steps (a training run's copies are at every stage of their episodes, and an episode's
first steps, every attacker in play, are its dearest), for ``--view-steps`` vector steps;
the single-env view runs ``--single-view-steps`` game steps after the same warm-up in
game steps. ``--baseline CHECKOUT`` also times the single-env view with ``hj`` of another
checkout (a folder, e.g. a ``git worktree`` of an earlier commit, or a revision:
``harness.checkout``), in a fresh process with that checkout first on the path
(``harness.Job`` of ``single_view.single_view_rate``), in every repeat: the vector view
against the single env as it was. Every rate is timed by ``harness.timed`` (wall clock).

``--floors`` splits the K-copy step where the issue's goals meet what cannot be made
cheaper without changing the game or the method: the vector env's time inside the pymunk
world (``World.step``: every player's body steps in Chipmunk, and a body taken out of
the space and put back moves differently from one left in it, so no player can skip the
space without changing the dynamics) and the ``hj`` view's time inside the assignment
program on CP-SAT (``solvers.assignment.solve_assignment``, solved where a copy's tables
changed), with the number of programs solved per vector step, and inside its tube lookups.
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
from collections.abc import Callable
from pathlib import Path

import numpy as np
from harness import WALL, Job, checkout, once, timed, training_views
from single_view import EPISODE_STEPS, GRIDS, SCENARIO, parallel_rate, single_view_rate

import reachavoid_env
from reachavoid_env.observations import GLOBAL, ObservationConfig
from reachavoid_env.vector import vector_env

OBSERVATIONS = {"v1": ObservationConfig(), "v0": GLOBAL}


def vector_rate(copies: int, steps: int, observation: ObservationConfig) -> float:
    """Game steps per second of ``copies`` copies over ``steps`` vector steps."""
    env = vector_env(SCENARIO, num_envs=copies, max_cycles=EPISODE_STEPS,
                     observation=observation)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = [{name: rng.uniform(-1, 1, (copies, 2)) for name in env.possible_agents}
               for _ in range(8)]

    def play() -> int:
        for i in range(steps):
            env.step(actions[i % 8])
        return copies * steps

    return timed(play, clock=WALL).median


def single_rate(steps: int, observation: ObservationConfig) -> float:
    env = reachavoid_env.parallel_env(scenario=SCENARIO, starts="random",
                                      max_cycles=EPISODE_STEPS, observation=observation)
    return parallel_rate(env, steps)


def mpe_rate(steps: int) -> float:
    from mpe2 import simple_tag_v3

    env = simple_tag_v3.parallel_env(num_good=8, num_adversaries=4, num_obstacles=2,
                                     continuous_actions=True, max_cycles=EPISODE_STEPS)
    return parallel_rate(env, steps)


def _view(defenders: str, copies: int, warmup: int) -> tuple[object, np.ndarray]:
    """The attacker-only vector view after ``warmup`` vector steps, and its actions."""
    view = training_views().make_attackers_vector_env(
        SCENARIO, defenders=defenders, num_envs=copies,
        defender_options=GRIDS if defenders == "hj" else None, max_cycles=EPISODE_STEPS)
    view.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (8, copies, len(view.learners), 2))
    for i in range(warmup):
        view.step(actions[i % 8])
    return view, actions


def view_rate(defenders: str, copies: int, steps: int, warmup: int) -> float:
    """Game steps per second of the attacker-only vector view (random attacker actions),
    timed over ``steps`` vector steps after ``warmup`` untimed ones."""
    view, actions = _view(defenders, copies, warmup)

    def play() -> int:
        for i in range(steps):
            view.step(actions[i % 8])
        return copies * steps

    return timed(play, clock=WALL).median


def _timed(owner: type, name: str, spent: list[float]) -> Callable[[], None]:
    """Wrap ``owner.name`` so that every call adds its seconds to ``spent[0]`` and one to
    ``spent[1]``; returns the function that puts the original back."""
    inner = getattr(owner, name)

    def counted(*args: object, **kwargs: object) -> object:
        result, seconds = once(lambda: inner(*args, **kwargs))
        spent[0] += seconds
        spent[1] += 1
        return result

    setattr(owner, name, counted)
    return lambda: setattr(owner, name, inner)


def floors(copies: int, steps: int, warmup: int) -> dict[str, float]:
    """Milliseconds per vector step of ``copies`` copies: the vector env's step and its
    pymunk world (random actions, v1), the ``hj`` view's step, its CP-SAT programs (with
    programs per step) and its tube lookups (the 1 vs 1 values, and the decision tables
    and controls, which read the 2 vs 1 tube: numba kernels), the ``greedy`` view's step;
    each after ``warmup`` steps."""
    import policies.batch_defenders
    import solvers.assignment
    from reachavoid_env.world import World
    from solvers.hj import ValueFunction

    env = vector_env(SCENARIO, num_envs=copies, max_cycles=EPISODE_STEPS)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = [{name: rng.uniform(-1, 1, (copies, 2)) for name in env.possible_agents}
               for _ in range(8)]
    for i in range(warmup):
        env.step(actions[i % 8])
    world = [0.0, 0]
    restore = _timed(World, "step", world)

    def play(stepped: Callable[[int], object], moves: list) -> int:
        for i in range(steps):
            stepped(moves[i % 8])
        return steps

    try:
        total = once(lambda: play(env.step, actions))[1]
    finally:
        restore()
    view, view_actions = _view("hj", copies, warmup)
    program, lookups = [0.0, 0], [0.0, 0]
    restores = [_timed(solvers.assignment, "solve_assignment", program),
                *(_timed(owner, name, lookups) for owner, name in (
                    (policies.batch_defenders, "batch_decision_tables"),
                    (policies.batch_defenders, "batch_decision_controls"),
                    (ValueFunction, "value")))]
    try:
        hj_step = once(lambda: play(view.step, view_actions))[1] / steps
    finally:
        for restore in restores:
            restore()
    greedy_rate = view_rate("greedy", copies, steps, warmup)
    return {"vector_step_ms": 1e3 * total / steps,
            "pymunk_ms": 1e3 * world[0] / steps,
            "hj_view_step_ms": 1e3 * hj_step,
            "cpsat_ms": 1e3 * program[0] / steps,
            "cpsat_programs_per_step": program[1] / steps,
            "hj_lookups_ms": 1e3 * lookups[0] / steps,
            "greedy_view_step_ms": 1e3 * copies / greedy_rate}


def measure(args: argparse.Namespace, baseline: Path | None) -> dict[str, float]:
    """Every row the options ask for, ``--repeats`` times (rows alternating); the figures
    of the result record (medians over the repeats). ``baseline``: the tree of
    ``--baseline``."""
    rows: dict[str, list[float]] = {}
    k = args.view_copies
    for _ in range(args.repeats):
        if args.views:
            rows.setdefault("attackers view hj, single env", []).append(
                single_view_rate(args.single_view_steps, args.view_warmup))
            if baseline is not None:
                rows.setdefault("attackers view hj, single env, baseline", []).append(
                    Job(baseline, "single_view:single_view_rate",
                        (args.single_view_steps, args.view_warmup)).run())
            for defenders in ("hj", "greedy"):
                rows.setdefault(f"attackers view {defenders} K={k}", []).append(
                    view_rate(defenders, k, args.view_steps, args.view_warmup))
        rows.setdefault("mpe2 simple_tag 8+4", []).append(mpe_rate(args.steps))
        for label, config in OBSERVATIONS.items():
            rows.setdefault(f"parallel_env {label}", []).append(single_rate(args.steps, config))
            for copies in args.copies:
                vector_steps = max(20, args.steps // copies)
                rows.setdefault(f"vector {label} K={copies}", []).append(
                    vector_rate(copies, vector_steps, config))
        if args.floors:
            for name, value in floors(k, args.view_steps, args.view_warmup).items():
                rows.setdefault(f"floor {name}", []).append(value)
    medians = {label: statistics.median(values) for label, values in rows.items()}
    figures: dict[str, float] = {}
    for label, rate in medians.items():
        if label.startswith("floor "):
            figures[f"ms_per_vector_step.k{k}.{label.removeprefix('floor ')}"] = rate
        else:
            figures[f"game_steps_per_s.{_key(label)}"] = rate
    for label in OBSERVATIONS:
        for copies in args.copies:
            figures[f"vector_over_single.{label}.k{copies}"] = (
                medians[f"vector {label} K={copies}"] / medians[f"parallel_env {label}"])
        figures[f"single_over_mpe.{label}"] = (medians[f"parallel_env {label}"]
                                               / medians["mpe2 simple_tag 8+4"])
    if args.views:
        view = medians[f"attackers view hj K={k}"]
        figures["view_hj_over_greedy"] = view / medians[f"attackers view greedy K={k}"]
        figures["view_hj_over_single_hj"] = view / medians["attackers view hj, single env"]
        if args.baseline:
            figures["view_hj_over_baseline_single_hj"] = (
                view / medians["attackers view hj, single env, baseline"])
    if args.floors:
        # What the goals allow per vector step of k copies: 10 times the single env's
        # steps/s (v1), and hj at 0.7 times greedy's view.
        figures[f"budget_ms.k{k}.vector_at_10x_single"] = (
            1e3 * k / (10 * medians["parallel_env v1"]))
        figures[f"budget_ms.k{k}.hj_view_at_07x_greedy"] = (
            medians["floor greedy_view_step_ms"] / 0.7)
    return figures


def _key(label: str) -> str:
    """A row label as a dotted key: ``vector v1 K=64`` -> ``vector.v1.k64``."""
    return (label.replace("K=", "k").replace(",", "").replace("mpe2 simple_tag 8+4", "mpe")
            .replace(" ", "."))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--copies", type=int, nargs="+", default=[1, 16, 64, 256])
    parser.add_argument("--steps", type=int, default=4000,
                        help="game steps per timed run (vector runs: steps / K vector steps)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--views", action="store_true",
                        help="also time the attacker-only views (hj and greedy defenders)")
    parser.add_argument("--view-copies", type=int, default=64)
    parser.add_argument("--view-steps", type=int, default=200,
                        help="vector steps per timed run of a view (default: %(default)s)")
    parser.add_argument("--view-warmup", type=int, default=300,
                        help="untimed steps before a view's timed ones: vector steps, game "
                             "steps for the single-env view (default: %(default)s)")
    parser.add_argument("--single-view-steps", type=int, default=3000,
                        help="game steps per timed run of the single-env view")
    parser.add_argument("--baseline", metavar="CHECKOUT",
                        help="also time the single-env hj view of this checkout, a folder or "
                             "a revision (--views)")
    parser.add_argument("--floors", action="store_true",
                        help="time the pymunk world, the CP-SAT programs and the tube lookups "
                             "in a step")
    parser.add_argument("--json", type=Path, help="write the figures here")
    args = parser.parse_args()
    with contextlib.ExitStack() as stack:
        baseline = stack.enter_context(checkout(args.baseline)) if args.baseline else None
        figures = measure(args, baseline)
    for key, value in figures.items():
        print(f"{key:<52} {value:>12,.2f}")
    if args.json:
        from result_file import write_result

        write_result(args.json, "vector_throughput", figures, {
            "game_steps_per_s": f"{SCENARIO}, random actions, game steps (one step of one copy) "
                                f"per second, median of the repeats; views with hj / greedy "
                                f"defenders at grids {GRIDS['grid1']}/{GRIDS['grid2']}, in "
                                f"their steady state (after the warm-up); baseline: the "
                                f"single-env view of --baseline",
            "vector_over_single": "the vector env's game steps/s over parallel_env's, same "
                                  "observation",
            "single_over_mpe": "parallel_env's steps/s over MPE2 simple_tag 8+4's",
            "view_hj_over_greedy": "attacker-only vector view: hj's game steps/s over "
                                   "greedy's",
            "view_hj_over_single_hj": "attacker-only vector view with hj over the single-env "
                                      "attacker-only view with hj",
            "view_hj_over_baseline_single_hj": "attacker-only vector view with hj over the "
                                               "--baseline checkout's single-env view with hj",
            "ms_per_vector_step": "milliseconds per vector step (median of the repeats): "
                                  "the vector env's and its pymunk World.step (v1), the hj "
                                  "view's, its CP-SAT programs (solve_assignment) with "
                                  "programs solved per step and its tube lookups (numba), "
                                  "the greedy view's",
            "budget_ms": "milliseconds per vector step the goals allow: the vector env at "
                         "10 times parallel_env's v1 steps/s, the hj view at 0.7 times the "
                         "greedy view's"})


if __name__ == "__main__":
    main()

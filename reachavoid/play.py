"""The ``play`` and ``validate`` commands: one scenario (or a map library) played once,
its first frame drawn (``--preview``) or its video written, and the outcome printed in the
words of its frames (``--json``: one object); ``validate`` loads scenario files (or map
libraries) and resets an env on each scenario, as ``play`` would."""

from __future__ import annotations

import argparse
import functools
import json
import sys
from pathlib import Path
from typing import Any

import reachavoid_env
from reachavoid.arguments import EXIT_USAGE, checked, chosen_specs, load_many
from reachavoid.paths import UsageError, reported, writable_file
from reachavoid.rollout import EpisodeResult, episode_title, first_frame, run_episode
from reachavoid.solve import DEFAULT_GRID
from reachavoid_env import Scenario, ScenarioError, checks
from reachavoid_env.files import atomic_write
from reachavoid_env.maps import load_library

GIF_MAX_FPS = 50.0
"""The highest video rates accepted (frames per second); a GIF's frame delay is counted in
hundredths of a second and players slow down delays under two."""


def play(args: argparse.Namespace) -> int:
    """``play``: one episode, its video or first frame, and what it came to."""
    if args.preview is not None:
        if args.video is not None:
            raise UsageError("--preview: draws the first frame without playing; drop --video",
                             field="--preview")
        if Path(args.preview).suffix.lower() != ".png":
            raise UsageError(f"--preview: {args.preview!r} must end in .png", field="--preview")
        writable_file(args.preview, "--preview", args.force)
    scenarios = load_many(args.scenario)
    scenario = drawn_map(scenarios, args.seed)
    _check_video_options(args, scenario)
    attacker_spec, defender_spec = chosen_specs([("attackers", args.attackers),
                                                 ("defenders", args.defenders)], args)
    try:
        if len(scenarios) == 1:
            attackers = attacker_spec(scenario, seed=args.seed, progress=args.progress)
            defenders = defender_spec(scenario, seed=args.seed, progress=args.progress)
        else:   # a library: the seed draws the map; the policies are built for it
            from reachavoid_env import PerMapPolicy

            attackers, defenders = (
                PerMapPolicy(functools.partial(spec, seed=args.seed, progress=args.progress),
                             side)
                for spec, side in ((attacker_spec, "attackers"), (defender_spec, "defenders")))
    except ValueError as err:   # a policy that does not fit the scenario (a model's players)
        raise reported(err) from None
    drawn = args.video is not None or args.preview is not None
    env = reachavoid_env.parallel_env(
        scenario=scenarios, render_mode="rgb_array" if drawn else None,
        render_width=args.width)
    title = episode_title(scenario.name, args.defenders, args.attackers, args.seed)
    try:
        if args.preview is not None:
            return _preview(env, attackers, defenders, title, args)
        result = run_episode(env, attackers, defenders, seed=args.seed, video=args.video,
                             fps=args.fps, every=args.every, title=title,
                             progress=args.video is not None and not args.json
                             and args.progress)
    finally:
        env.close()
    if args.json:
        print(json.dumps(_json_report(result, args)))
    else:
        print(_summary(result, args))
    return 0


def _check_video_options(args: argparse.Namespace, scenario: Scenario) -> None:
    """Check --video, --fps, --every, --realtime and --width; settle ``args.every`` and
    ``args.fps`` (--realtime: the rate at which video time is game time)."""
    from reachavoid_env.video import FPS_RANGE, check_video_path, realtime_every, realtime_fps

    if args.video is not None:
        try:
            check_video_path(args.video)
        except ValueError as err:
            raise reported(err) from None
        writable_file(args.video, "--video", args.force)
    if args.realtime and args.fps is not None:
        raise UsageError("--realtime: sets the fps itself; drop --fps", field="--realtime")
    if args.fps is not None:
        checked(checks.real, args.fps, "--fps", *FPS_RANGE)
    if args.every is not None:
        checked(checks.integer, args.every, "--every", 1, 1_000_000)
    checked(checks.integer, args.width, "--width", 16, 4096)
    rate = reachavoid_env.ReachAvoidEnv.metadata["render_fps"]
    if args.realtime:
        args.every = args.every or realtime_every(scenario.dt, rate)
        args.fps = realtime_fps(scenario.dt, args.every)
        most = GIF_MAX_FPS if str(args.video).lower().endswith(".gif") else FPS_RANGE[1]
        if args.fps > most:
            raise UsageError(f"--realtime: --every {args.every} with {scenario.dt * 1e3:g} ms "
                             f"steps needs {args.fps:g} fps, above this format's {most:g}; use "
                             f"--every {realtime_every(scenario.dt, most)} or more",
                             field="--realtime")
    args.every = args.every or 1
    args.fps = args.fps or rate


def drawn_map(scenarios: tuple[Scenario, ...], seed: int) -> Scenario:
    """The map an env over ``scenarios`` plays after ``reset(seed=seed)``: the first draw
    of the env's generator seeded with ``seed`` (``ReachAvoidEnv.reset``)."""
    if len(scenarios) == 1:
        return scenarios[0]
    from gymnasium.utils import seeding

    generator, _ = seeding.np_random(seed)
    return scenarios[int(generator.integers(len(scenarios)))]


def _preview(env: Any, attackers: Any, defenders: Any, title: str,
             args: argparse.Namespace) -> int:
    """``play --preview``: the first frame as a PNG, written atomically."""
    import imageio.v3 as iio

    frame = first_frame(env, attackers, defenders, seed=args.seed, title=title)
    with atomic_write(args.preview, "wb") as handle:
        iio.imwrite(handle, frame, extension=".png")
    if args.json:
        print(json.dumps({"preview": args.preview, "width": frame.shape[1],
                          "height": frame.shape[0]}))
    else:
        print(f"{title}\n  first frame: {args.preview} ({frame.shape[1]}x{frame.shape[0]})")
    return 0


def _json_report(result: EpisodeResult, args: argparse.Namespace) -> dict[str, object]:
    report = result.to_dict()
    report.update(defenders=args.defenders, attackers=args.attackers, video=args.video)
    order = ("scenario", "defenders", "attackers", "seed", "steps", "captured", "arrived",
             "captured_count", "arrived_count", "seconds", "game_time", "video",
             "guaranteed_captures_initial", "guaranteed_captures_final",
             "guarantee_violations", "guarantee_falls", "arrivals_beyond_promise",
             "nominal_captures_initial")
    return {key: report[key] for key in order if key in report}


def _summary(result: EpisodeResult, args: argparse.Namespace) -> str:
    """What the episode came to, in the words its frames showed."""
    lines = [episode_title(result.scenario, args.defenders, args.attackers, result.seed)]
    for word, names in (("captured", result.captured), ("arrived ", result.arrived)):
        lines.append(f"  {word} {len(names)}" + (f": {', '.join(names)}" if names else ""))
    lines.append(f"  {result.steps} steps, {result.game_time:.3f} s of game time, "
                 f"{result.seconds:.2f} s wall clock")
    lines.append(f"  outcome: {result.outcome}")
    for when, shown in (("start", result.first_lines), ("end", result.last_lines)):
        if shown:
            lines.append(f"  overlay at the {when}: {'; '.join(shown)}")
    if result.guarantees:
        lines.append(f"  captured so far + guaranteed: {result.guarantees[0]} at the first "
                     f"decision, {result.guarantees[-1]} at the last")
    if args.video is not None:
        speed = args.fps * args.every * result.game_time / max(result.steps, 1)
        lines.append(f"  video: {args.video} ({result.frames} frames at {args.fps:g} fps, "
                     f"{_speed_words(speed)})")
    return "\n".join(lines)


def _speed_words(speed: float) -> str:
    """A playback ``speed`` (game seconds per video second) in words."""
    if abs(speed - 1.0) < 1e-6:
        return "real time"
    return f"{1 / speed:.3g}x slow motion" if speed < 1 else f"{speed:.3g}x fast"


def validate(args: argparse.Namespace) -> int:
    """``validate``: each file (a scenario, or every map of a map library) loaded and an env
    reset on it; one line per scenario."""
    bad = 0
    for source in args.files:
        try:
            scenarios = load_library(source)
            for scenario in scenarios:
                reachavoid_env.parallel_env(scenario=scenario).reset(seed=0)
                _playable(scenario)
        except (ScenarioError, ValueError, OSError) as err:
            bad += 1
            words = getattr(err, "strerror", None) or str(err)
            if getattr(err, "field", None) != source:   # the message names the file
                words = f"{source}: {words}"
            print(f"reachavoid validate: error: {words}", file=sys.stderr)
            continue
        for scenario in scenarios:
            where = source if len(scenarios) == 1 else f"{source}: {scenario.name}"
            starts = "given starts" if scenario.attackers is not None else "random starts"
            print(f"{where}: ok ({scenario.name}: {scenario.num_attackers} attackers, "
                  f"{scenario.num_defenders} defenders, {starts})")
    return EXIT_USAGE if bad else 0


def _playable(scenario: Scenario) -> None:
    """What ``play`` with its default policies would find wrong with ``scenario`` before
    playing: the shortest-path field's grid and the tubes' grids must see the target."""
    from reachavoid_env.geodesic import distance_field
    from solvers.hj.games import check_tube_grids

    distance_field(scenario.map, scenario.player_radius)
    check_tube_grids(scenario.map, DEFAULT_GRID["1v1"], DEFAULT_GRID["2v1"])

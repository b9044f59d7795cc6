"""The episode loop shared by the command line, the examples, the benchmarks and the tests.

Policies are duck-typed (``reset(scenario)``, ``act(state)``, optional ``overlay()``, as
``policies.base.Policy``); this module does not import ``policies``.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from pettingzoo.utils.env import ParallelEnv
from tqdm import tqdm

from reachavoid_env.game_state import GameState, Overlay
from reachavoid_env.scenario import Scenario
from reachavoid_env.video import VideoWriter, check_video_path


class PolicyLike(Protocol):
    def reset(self, scenario: Scenario) -> None: ...

    def act(self, state: GameState) -> dict[str, np.ndarray]: ...


@dataclass(frozen=True)
class EpisodeResult:
    """How one episode ended.

    ``steps`` and ``game_time`` (seconds of game time) count to the end of the episode;
    ``captured`` / ``arrived`` list attacker names in name order; ``seconds`` is the wall
    clock time of the whole loop (video encoding included); ``frames`` the video frames
    written (0 without a video). ``num_attackers`` is the number of attackers in the game.

    ``guarantees`` is filled when the defenders report a ``guaranteed_captures`` count (the
    HJ + MIP defenders do): after each decision, the attackers captured so far plus those
    guaranteed never to reach the target from then on. The paper's Algorithm 1 promises
    that this never decreases and that at least that many attackers never arrive. A
    reach-avoid win of the defender keeps its attacker out of the target, by capture or by
    delaying it indefinitely, so an attacker still held off when the episode is truncated
    counts as stopped (``stopped_count``), not as a broken guarantee.
    """

    scenario: str
    seed: int | None
    num_attackers: int
    steps: int
    game_time: float
    captured: tuple[str, ...]
    arrived: tuple[str, ...]
    seconds: float
    frames: int = 0
    guarantees: tuple[int, ...] = ()

    @property
    def captured_count(self) -> int:
        return len(self.captured)

    @property
    def arrived_count(self) -> int:
        return len(self.arrived)

    @property
    def stopped_count(self) -> int:
        """Attackers that never reached the target (captured, or held off to the end)."""
        return self.num_attackers - self.arrived_count

    @property
    def guarantee_violations(self) -> int:
        """Decisions whose guarantee was broken: it fell below an earlier one, or more
        attackers arrived than it allowed."""
        trace = np.asarray(self.guarantees, dtype=np.int64)
        if len(trace) == 0:
            return 0
        fell = int(np.sum(trace < np.maximum.accumulate(trace)))
        return fell + int(np.sum(trace > self.stopped_count))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields (design.md section 6, without the policy names)."""
        return {
            "scenario": self.scenario,
            "seed": self.seed,
            "num_attackers": self.num_attackers,
            "steps": self.steps,
            "game_time": self.game_time,
            "captured": list(self.captured),
            "arrived": list(self.arrived),
            "captured_count": self.captured_count,
            "arrived_count": self.arrived_count,
            "seconds": self.seconds,
        } | ({"guaranteed_captures_initial": self.guarantees[0],
              "guaranteed_captures_final": self.guarantees[-1],
              "guarantee_violations": self.guarantee_violations} if self.guarantees else {})


def merged_overlay(*policies: object) -> Overlay | None:
    """The union of the policies' overlays (edges and text lines), ``None`` if none draws."""
    overlays = []
    for policy in policies:
        overlay = getattr(policy, "overlay", None)
        if callable(overlay) and (drawn := overlay()) is not None:
            overlays.append(drawn)
    if not overlays:
        return None
    return Overlay(edges=tuple(e for o in overlays for e in o.edges),
                   lines=tuple(line for o in overlays for line in o.lines))


def run_episode(env: ParallelEnv, attackers: PolicyLike, defenders: PolicyLike, *,
                seed: int | None = None, video: str | os.PathLike[str] | None = None,
                fps: float | None = None, every: int = 1,
                progress: bool = False) -> EpisodeResult:
    """Play one episode of ``env`` with ``attackers`` against ``defenders``.

    The env is reset with ``seed``, both policies with the scenario in play; each step
    every live agent gets its side's action and the policies' overlay is handed to the
    renderer. With ``video`` (``.mp4`` or ``.gif``; the env's ``render_mode`` must be
    ``"rgb_array"``) the frame after reset, every ``every``-th step and the last one are
    written at ``fps`` (default ``env.metadata["render_fps"]``); Ctrl-C leaves no file. A
    ``"human"`` env draws its window itself on every reset and step. ``progress`` shows a
    tqdm bar over steps.
    """
    if every < 1:
        raise ValueError(f"every: must be a positive integer, got {every}")
    if video is not None:
        check_video_path(video)
        if env.render_mode != "rgb_array":
            raise ValueError(f"video: needs an env with render_mode='rgb_array', got "
                             f"{env.render_mode!r}")
    game = env.unwrapped
    started = time.perf_counter()
    env.reset(seed=seed)
    scenario: Scenario = game.scenario
    attackers.reset(scenario)
    defenders.reset(scenario)
    rate = fps if fps is not None else env.metadata.get("render_fps", 30)
    writer = VideoWriter(video, rate) if video is not None else None

    def show() -> None:
        if writer is not None:
            writer.append(env.render())

    bar = tqdm(total=scenario.max_steps, unit="step", disable=not progress, leave=False)
    guarantees: list[int] = []
    try:
        state = game.game_state()
        while env.agents:
            live = set(env.agents)
            actions = {**attackers.act(state), **defenders.act(state)}
            guaranteed = getattr(defenders, "guaranteed_captures", None)
            if guaranteed is not None:
                guarantees.append(len(state.captured) + guaranteed)
            game.set_overlay(merged_overlay(attackers, defenders))
            if state.step % every == 0:
                show()
            env.step({agent: a for agent, a in actions.items() if agent in live})
            bar.update(1)
            state = game.game_state()
        show()
        if writer is not None:
            writer.close()
    except BaseException:
        if writer is not None:
            writer.abort()
        raise
    finally:
        bar.close()
    return EpisodeResult(
        scenario=scenario.name,
        seed=seed,
        num_attackers=len(state.attacker_status),
        steps=state.step,
        game_time=state.time,
        captured=tuple(state.captured),
        arrived=tuple(state.arrived),
        seconds=time.perf_counter() - started,
        frames=writer.frames if writer is not None else 0,
        guarantees=tuple(guarantees),
    )

"""The one episode loop of scripted policies: ``play``, ``bench`` and ``paper``, the sweeps,
the recording example and the guarantee and sweep benchmarks play through ``run_episode``.
The training wrappers and the learning examples step the env for their learners, and the
throughput benchmarks step it directly to time the env alone.

Policies follow ``reachavoid_env.Policy``. Defenders that certify captures (the paper's
Algorithm 1) also report ``guaranteed_captures`` (``CertifiesCaptures``); the loop records
it after every decision.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np
from tqdm import tqdm

from reachavoid_env import GameState, Overlay, Policy, Scenario, checks, merged_overlay
from reachavoid_env.overlay import outcome_line

if TYPE_CHECKING:
    from pettingzoo.utils.env import ParallelEnv


@runtime_checkable
class CertifiesCaptures(Protocol):
    """Defenders that say, after each ``act``, how many of the attackers still in play they
    are guaranteed to stop, and how many the paper's rule (every value > 0 a defender
    win) counts (both ``None`` before the first decision and once no attacker is left)."""

    @property
    def guaranteed_captures(self) -> int | None: ...

    @property
    def nominal_captures(self) -> int | None: ...


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
    counts as stopped (``stopped_count``), not as a broken guarantee. ``guaranteed_captures``
    is the certified count (values clear the tubes' error margin); ``nominal_captures``
    holds the same sums with the paper's rule (value > 0), a count and no promise, when
    the defenders report one.

    ``first_lines`` / ``last_lines`` are the policies' overlay text at the first and the
    last decision: the lines on the video's first and last frames.
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
    nominal_captures: tuple[int, ...] = ()
    first_lines: tuple[str, ...] = ()
    last_lines: tuple[str, ...] = ()

    @property
    def outcome(self) -> str:
        """How the episode ended, in the words of the video's last-frame banner."""
        return outcome_line(self.num_attackers, self.captured_count, self.arrived_count)

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
        return self.guarantee_falls + int(np.sum(trace > self.stopped_count))

    @property
    def guarantee_falls(self) -> int:
        """Decisions whose guarantee fell below an earlier one (a certified game was given
        up: the certificate flickered, whether or not an attacker then arrived)."""
        trace = np.asarray(self.guarantees, dtype=np.int64)
        return int(np.sum(trace < np.maximum.accumulate(trace))) if len(trace) else 0

    @property
    def arrivals_beyond_promise(self) -> int:
        """Attackers that arrived although a guarantee had promised they would not: the
        largest guarantee minus the attackers stopped, if positive."""
        return max(0, max(self.guarantees, default=0) - self.stopped_count)

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
              "guarantee_violations": self.guarantee_violations,
              "guarantee_falls": self.guarantee_falls,
              "arrivals_beyond_promise": self.arrivals_beyond_promise} if self.guarantees
             else {}
             ) | ({"nominal_captures_initial": self.nominal_captures[0]}
                  if self.nominal_captures else {})


def episode_title(scenario: str, defenders: str, attackers: str, seed: int | None) -> str:
    """The title line of an episode's frames: the scenario, the policies and the seed."""
    return f"{scenario}: {defenders} defenders vs {attackers} attackers, seed {seed}"


def _start(env: ParallelEnv, attackers: Policy, defenders: Policy, seed: int | None,
           title: str | None) -> Scenario:
    """Reset ``env`` with ``seed`` and both policies with the scenario in play; give the
    frames their title (default: the policies' class names)."""
    raw = env.unwrapped
    env.reset(seed=seed)
    scenario: Scenario = raw.scenario
    attackers.reset(scenario)
    defenders.reset(scenario)
    raw.set_caption(title or episode_title(scenario.name, type(defenders).__name__,
                                           type(attackers).__name__, seed))
    return scenario


def _decide(env: ParallelEnv, state: GameState, attackers: Policy, defenders: Policy,
            seed: int | None) -> tuple[dict[str, np.ndarray], Overlay | None]:
    """Both sides' actions at ``state``; their overlay goes to the env's next frames. An
    exception of a policy gets a note naming the policy, the step and the seed."""
    actions = {}
    for side, policy in (("attackers", attackers), ("defenders", defenders)):
        try:
            actions.update(policy.act(state))
        except Exception as err:
            err.add_note(f"reachavoid: raised by the {side}' policy "
                         f"{type(policy).__module__}.{type(policy).__qualname__} at step "
                         f"{state.step} of the episode with seed {seed}")
            raise
    overlay = merged_overlay(attackers, defenders)
    env.unwrapped.set_overlay(overlay)
    return actions, overlay


def first_frame(env: ParallelEnv, attackers: Policy, defenders: Policy, *,
                seed: int | None = None, title: str | None = None) -> np.ndarray:
    """The first frame of the episode ``run_episode`` would play with the same arguments
    (the start, the first decision's overlay), without playing it: ``(height, width, 3)``
    uint8. The env's ``render_mode`` must be ``"rgb_array"``."""
    if getattr(env, "render_mode", None) != "rgb_array":
        raise ValueError(f"first_frame needs render_mode='rgb_array', got "
                         f"{getattr(env, 'render_mode', None)!r}")
    _start(env, attackers, defenders, seed, title)
    _decide(env, env.unwrapped.game_state(), attackers, defenders, seed)
    return env.render()


def run_episode(env: ParallelEnv, attackers: Policy, defenders: Policy, *,
                seed: int | None = None, video: str | os.PathLike[str] | None = None,
                fps: float | None = None, every: int = 1, title: str | None = None,
                progress: bool = False) -> EpisodeResult:
    """Play one episode of ``env`` with ``attackers`` against ``defenders``.

    The env is reset with ``seed``, both policies with the scenario in play; each step
    every live agent gets its side's action and the policies' overlay is handed to the
    renderer, so that every frame from the first to the last carries it. With ``video``
    (``.mp4`` or ``.gif``; the env's ``render_mode`` must be ``"rgb_array"``) the episode
    is recorded through ``RecordEpisode``: the start, every ``every``-th step and the last
    one, at ``fps`` (default ``env.metadata["render_fps"]``; ``realtime_fps`` plays in game
    time); an exception (Ctrl-C included) leaves no file. ``title`` heads every frame
    (default: ``episode_title`` with the policies' class names). A ``"human"`` env draws
    its window itself. ``progress`` shows a tqdm bar over steps.
    """
    checks.integer(every, "every", 1)
    raw = env.unwrapped
    if video is not None:
        from reachavoid_env.video import RecordEpisode
    recorder = RecordEpisode(env, video, fps, every=every) if video is not None else None
    played = recorder if recorder is not None else env
    started = time.perf_counter()
    certifies = isinstance(defenders, CertifiesCaptures)
    guarantees: list[int] = []
    nominals: list[int] = []
    first_lines: tuple[str, ...] | None = None
    last_lines: tuple[str, ...] = ()
    bar = tqdm(total=raw.max_cycles, unit="step", disable=not progress, leave=False)
    try:
        scenario = _start(played, attackers, defenders, seed, title)
        state = raw.game_state()
        while played.agents:
            live = set(played.agents)
            actions, overlay = _decide(played, state, attackers, defenders, seed)
            if certifies and defenders.guaranteed_captures is not None:
                guarantees.append(len(state.captured) + defenders.guaranteed_captures)
                nominal = defenders.nominal_captures
                if nominal is not None:
                    nominals.append(len(state.captured) + nominal)
            last_lines = overlay.lines if overlay is not None else ()
            if first_lines is None:
                first_lines = last_lines
            played.step({agent: a for agent, a in actions.items() if agent in live})
            bar.update(1)
            state = raw.game_state()
        if recorder is not None:
            recorder.finish()
    except BaseException:
        if recorder is not None:
            recorder.abort()
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
        frames=recorder.frames if recorder is not None else 0,
        guarantees=tuple(guarantees), nominal_captures=tuple(nominals),
        first_lines=first_lines or (), last_lines=last_lines,
    )

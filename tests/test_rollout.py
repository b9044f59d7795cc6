"""run_episode: the one episode loop (results, overlays, videos, interruption)."""

from __future__ import annotations

import imageio.v3 as iio
import numpy as np
import pytest

import reachavoid_env
from policies import GreedyDefender, IdleDefender, RandomAttacker, StraightAttacker
from reachavoid.rollout import EpisodeResult, run_episode
from reachavoid_env import Overlay, merged_overlay, palette
from reachavoid_env.render import Renderer


def make_env(scenario="paper_2v1", **kwargs):
    return reachavoid_env.parallel_env(scenario=scenario, **kwargs)


def test_result_matches_the_final_game_state():
    env = make_env("paper_6v2")
    result = run_episode(env, StraightAttacker(), GreedyDefender(), seed=0)
    final = env.unwrapped.game_state()
    assert isinstance(result, EpisodeResult)
    assert not env.agents
    assert result.steps == final.step and result.game_time == pytest.approx(final.time)
    assert list(result.captured) == final.captured and list(result.arrived) == final.arrived
    assert result.captured_count + result.arrived_count == 6  # nobody left at the end
    assert result.scenario == "paper_6v2" and result.seed == 0 and result.frames == 0
    report = result.to_dict()
    assert report["captured_count"] == len(report["captured"])
    assert report["seconds"] > 0


def test_straight_attackers_beat_idle_defenders_on_paper_2v1():
    # Both straight lines to the target centre (0.7, 0.2) pass the idle defender at
    # (0.3, -0.3) farther than the capture radius.
    result = run_episode(make_env(), StraightAttacker(), IdleDefender(), seed=0)
    assert result.arrived == ("attacker_0", "attacker_1") and result.captured == ()
    # the first to arrive, attacker_1, covers its distance at speed 1
    assert result.game_time >= np.hypot(0.6, 0.5) - 0.01


def test_truncation_ends_the_loop():
    env = make_env(max_cycles=30)
    result = run_episode(env, RandomAttacker(1), IdleDefender(), seed=0)
    assert result.steps == 30 and not env.agents


def test_seeded_episodes_repeat():
    first = run_episode(make_env("paper_6v2"), RandomAttacker(5), GreedyDefender(), seed=3)
    again = run_episode(make_env("paper_6v2"), RandomAttacker(5), GreedyDefender(), seed=3)
    assert (first.steps, first.captured, first.arrived) == (again.steps, again.captured,
                                                            again.arrived)


def test_overlays_reach_the_env(monkeypatch):
    env = make_env()
    given = []
    monkeypatch.setattr(env.unwrapped, "set_overlay", given.append)
    result = run_episode(env, StraightAttacker(), GreedyDefender(), seed=0)
    assert len(given) == result.steps
    assert given[0].edges == (("defender_0", "attacker_0"),)


def test_merged_overlay():
    class Draws:
        def __init__(self, overlay):
            self._overlay = overlay

        def overlay(self):
            return self._overlay

    a = Draws(Overlay(edges=(("defender_0", "attacker_1"),), lines=("one",)))
    b = Draws(Overlay(edges=(("defender_1", "attacker_0"),), lines=("two",)))
    merged = merged_overlay(a, IdleDefender(), b, Draws(None))
    assert merged.edges == (("defender_0", "attacker_1"), ("defender_1", "attacker_0"))
    assert merged.lines == ("one", "two")
    assert merged_overlay(IdleDefender(), StraightAttacker()) is None


def test_two_second_mp4_of_paper_2v1(tmp_path):
    path = tmp_path / "paper_2v1.mp4"
    env = make_env(max_cycles=99, render_mode="rgb_array")
    result = run_episode(env, RandomAttacker(0), GreedyDefender(), seed=0, video=path, fps=50)
    frames = iio.imread(path)
    assert result.frames == 100 and len(frames) == 100  # the reset and 99 steps
    assert iio.immeta(path)["duration"] == pytest.approx(2.0, abs=0.05)
    assert frames.shape[1:] == env.render().shape
    assert np.abs(frames[0].astype(int) - frames[-1]).mean() > 0.1
    assert sum(np.array_equal(frames[k], frames[k + 1]) for k in range(99)) < 5


class Says(GreedyDefender):
    """Greedy defenders that also write a line of text on every frame."""

    def overlay(self) -> Overlay:
        return Overlay(edges=super().overlay().edges, lines=("greedy: chasing",))


def overlay_line_ink(frame: np.ndarray, renderer: Renderer) -> int:
    """Dark pixels in the first overlay text row of ``frame``."""
    layout = renderer.frame
    top = round(layout.margin / 2) + layout.title_font.get_linesize() + layout.line_height
    row = frame[top:top + layout.line_height, :renderer.width // 2]
    return int((row.max(axis=2) < 140).sum())


@pytest.mark.parametrize("every", [1, 7])
def test_first_and_last_frames_carry_the_overlay(tmp_path, every):
    env = make_env("paper_6v2", render_mode="rgb_array", render_width=320)
    scenario = env.unwrapped.scenario
    renderer = Renderer(scenario.map, scenario.capture_radius, width=320)
    frames = {}
    for name, defenders in (("says", Says()), ("quiet", GreedyDefender())):
        path = tmp_path / f"{name}.gif"
        result = run_episode(env, StraightAttacker(), defenders, seed=0, video=path,
                             every=every)
        frames[name] = iio.imread(path)
        assert len(frames[name]) == result.frames
    assert result.first_lines == result.last_lines == ()
    for k in (0, len(frames["says"]) // 2, -1):
        assert overlay_line_ink(frames["says"][k], renderer) > 30
        assert overlay_line_ink(frames["quiet"][k], renderer) == 0
    # the first frame's edges are the first decision's: green between defender and quarry
    first = frames["says"][0].astype(int)
    assert np.all(np.abs(first - palette.EDGE) <= 40, axis=2).sum() > 50
    assert np.all(np.abs(frames["quiet"][0].astype(int) - palette.EDGE) <= 40, axis=2).sum() > 50


def test_result_keeps_the_first_and_last_overlay_text():
    result = run_episode(make_env(), StraightAttacker(), Says(), seed=0)
    assert result.first_lines == result.last_lines == ("greedy: chasing",)
    assert result.outcome.startswith("2 attackers: ") or result.outcome == (
        "All 2 attackers captured")


def test_video_every_nth_step_and_gif(tmp_path):
    path = tmp_path / "game.gif"
    env = make_env(render_mode="rgb_array", render_width=320)
    result = run_episode(env, StraightAttacker(), GreedyDefender(), seed=0, video=path,
                         every=10)
    assert result.frames == len(range(0, result.steps, 10)) + 1
    assert len(iio.imread(path)) == result.frames


def test_video_needs_rgb_array_and_a_good_path(tmp_path):
    with pytest.raises(ValueError, match="rgb_array"):
        run_episode(make_env(), StraightAttacker(), IdleDefender(), video=tmp_path / "a.mp4")
    with pytest.raises(ValueError, match="must end in"):
        run_episode(make_env(render_mode="rgb_array"), StraightAttacker(), IdleDefender(),
                    video=tmp_path / "a.webm")
    with pytest.raises(ValueError, match="every"):
        run_episode(make_env(), StraightAttacker(), IdleDefender(), every=0)


def test_interrupted_episode_leaves_no_video(tmp_path):
    class Interrupts(StraightAttacker):
        def act(self, state):
            if state.step == 20:
                raise KeyboardInterrupt
            return super().act(state)

    env = make_env(render_mode="rgb_array")
    with pytest.raises(KeyboardInterrupt):
        run_episode(env, Interrupts(), GreedyDefender(), seed=0, video=tmp_path / "a.mp4")
    assert list(tmp_path.iterdir()) == []

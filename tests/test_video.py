"""VideoWriter and RecordEpisode: MP4 and GIF round trips, streaming, no half-written files."""

from __future__ import annotations

import tracemalloc

import imageio.v3 as iio
import numpy as np
import pytest

import reachavoid_env
from reachavoid_env import AttackerStatus, GameState, Overlay, builtin_scenario
from reachavoid_env.render import Renderer
from reachavoid_env.video import RecordEpisode, VideoWriter, realtime_every, realtime_fps


def game_frames(count: int, width: int = 320):
    """Frames of paper_2v1 with the attackers walking right."""
    scenario = builtin_scenario("paper_2v1")
    renderer = Renderer(scenario.map, scenario.capture_radius, width=width)
    attackers = np.asarray(scenario.attackers)
    for step in range(count):
        state = GameState(time=step * 0.005, step=step,
                          attacker_positions=attackers + [0.01 * step, 0.0],
                          defender_positions=np.asarray(scenario.defenders),
                          attacker_status=(AttackerStatus.ACTIVE,) * 2, attacker_speed=1.0,
                          defender_speed=1.5, capture_radius=0.1)
        renderer.draw(state)
        yield renderer.rgb_array()


@pytest.mark.parametrize("suffix", [".mp4", ".gif"])
def test_round_trip(tmp_path, suffix):
    frames = list(game_frames(20))
    path = tmp_path / f"game{suffix}"
    with VideoWriter(path, fps=10) as writer:
        for frame in frames:
            writer.append(frame)
    assert writer.frames == 20
    back = iio.imread(path)
    assert back.shape == (20, *frames[0].shape)
    assert np.abs(back[0].astype(int) - back[-1]).mean() > 0.1
    assert np.abs(back[10].astype(int) - frames[10]).mean() < 3.0
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]


def test_interrupted_write_leaves_no_file(tmp_path):
    path = tmp_path / "game.mp4"
    with pytest.raises(KeyboardInterrupt), VideoWriter(path, fps=10) as writer:
        for k, frame in enumerate(game_frames(10)):
            writer.append(frame)
            if k == 5:
                raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_failed_write_keeps_the_previous_file(tmp_path):
    path = tmp_path / "game.gif"
    path.write_bytes(b"old")
    frames = game_frames(3)
    with pytest.raises(ValueError, match="frame 1"), VideoWriter(path) as writer:
        writer.append(next(frames))
        writer.append(np.zeros((32, 32, 3), dtype=np.uint8))
    assert path.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["game.gif"]


def test_memory_stays_flat(tmp_path):
    frame = next(game_frames(1, width=640))
    tracemalloc.start()
    try:
        with VideoWriter(tmp_path / "long.mp4", fps=30) as writer:
            for k in range(120):
                frame[0, 0] = k
                writer.append(frame.copy())  # a fresh frame each time, as env.render() gives
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 10 * frame.nbytes  # 120 frames held would be 120 x


@pytest.mark.parametrize(("path", "message"), [
    ("game.avi", "must end in one of .mp4, .gif"),
    ("game", "no suffix"),
    ("missing/game.mp4", "does not exist"),
])
def test_bad_paths(tmp_path, path, message):
    with pytest.raises(ValueError, match=message):
        VideoWriter(tmp_path / path)


def test_bad_frames_and_settings(tmp_path):
    with pytest.raises(ValueError, match="fps"):
        VideoWriter(tmp_path / "a.mp4", fps=0)
    writer = VideoWriter(tmp_path / "a.mp4")
    with pytest.raises(ValueError, match="uint8"):
        writer.append(np.zeros((32, 32, 3), dtype=np.float32))
    with pytest.raises(ValueError, match="no frames"):
        writer.close()
    assert list(tmp_path.iterdir()) == []


def test_record_episode_writes_every_step(tmp_path):
    path = tmp_path / "episode.mp4"
    env = reachavoid_env.parallel_env(scenario="paper_2v1", render_mode="rgb_array")
    with RecordEpisode(env, path, fps=20) as recorded:
        recorded.reset(seed=0)
        for _ in range(15):
            recorded.step({agent: np.zeros(2, dtype=np.float32) for agent in recorded.agents})
    back = iio.imread(path)
    assert len(back) == 16  # after reset and after each step
    assert back.shape[1:] == recorded.unwrapped.render().shape


def test_record_episode_one_file_per_episode(tmp_path):
    env = reachavoid_env.parallel_env(scenario="paper_2v1", render_mode="rgb_array")
    with RecordEpisode(env, tmp_path / "run_{episode}.gif", every=5,
                       per_episode=True) as recorded:
        for seed in (0, 1):
            recorded.reset(seed=seed)
            for _ in range(10):
                recorded.step({a: np.ones(2, dtype=np.float32) for a in recorded.agents})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run_0.gif", "run_1.gif"]
    assert len(iio.imread(tmp_path / "run_1.gif")) == 3  # reset, step 5, step 10


def test_record_episode_needs_rgb_array(tmp_path):
    env = reachavoid_env.parallel_env(scenario="paper_2v1")
    with pytest.raises(ValueError, match="rgb_array"):
        RecordEpisode(env, tmp_path / "x.mp4")


def test_record_episode_discards_video_on_error(tmp_path):
    env = reachavoid_env.parallel_env(scenario="paper_2v1", render_mode="rgb_array")
    with pytest.raises(RuntimeError), RecordEpisode(env, tmp_path / "x.mp4") as recorded:
        recorded.reset(seed=0)
        recorded.step({a: np.zeros(2, dtype=np.float32) for a in recorded.agents})
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_start_frame_carries_what_was_set_after_reset(tmp_path):
    """The start frame is drawn at the first step, so that the first decision's overlay
    (set after reset) is on it; an episode closed before any step still gets it."""
    path = tmp_path / "start.gif"
    env = reachavoid_env.parallel_env(scenario="paper_2v1", render_mode="rgb_array")
    with RecordEpisode(env, path) as recorded:
        recorded.reset(seed=0)
        plain = recorded.unwrapped.render()
        recorded.unwrapped.set_overlay(Overlay(edges=(("defender_0", "attacker_0"),)))
        with_edge = recorded.unwrapped.render()
        recorded.step({a: np.zeros(2, dtype=np.float32) for a in recorded.agents})
    first = iio.imread(path)[0].astype(int)
    assert (plain != with_edge).any()
    assert np.abs(first - with_edge).mean() < np.abs(first - plain).mean()
    assert np.abs(first - with_edge).mean() < 1.0

    unplayed = tmp_path / "unplayed.mp4"
    with RecordEpisode(env, unplayed) as recorded:
        recorded.reset(seed=0)
    assert len(iio.imread(unplayed)) == 1


def test_realtime_rate():
    assert realtime_fps(0.005) == pytest.approx(200.0)
    assert realtime_fps(0.005, every=4) == pytest.approx(50.0)
    assert realtime_every(0.005, 50.0) == 4 and realtime_every(0.005, 40.0) == 5
    assert realtime_every(0.1, 50.0) == 1


def test_per_episode_videos_are_opt_in(tmp_path):
    env = reachavoid_env.parallel_env(scenario="paper_2v1", render_mode="rgb_array")
    with pytest.raises(ValueError, match="episode"):
        RecordEpisode(env, tmp_path / "run.gif", per_episode=True)
    assert RecordEpisode(env, tmp_path / "r{episode}.gif").episode_path(3) == str(
        tmp_path / "r{episode}.gif")

"""Frames to MP4 (H.264) or GIF, streamed to ffmpeg one frame at a time.

``VideoWriter`` takes ``(height, width, 3)`` uint8 frames and pipes each one straight to an
ffmpeg process (imageio-ffmpeg), so memory stays flat however long the episode. The video
is written under a temporary name next to the destination (the target of a link; a
private temporary folder for a device or FIFO) and put in place on ``close``
(``files.install``); an exception (Ctrl-C included) inside a ``with`` block, or
``abort()``, removes it. ``RecordEpisode`` wraps a ``ParallelEnv`` whose ``render_mode``
is ``"rgb_array"`` and records ``env.render()`` at the start of each episode and after
its steps.

Playback speed: a frame every ``every`` steps of ``dt`` seconds, played at ``fps``, shows
``fps * every * dt`` seconds of game time per second of video; ``realtime_fps`` is the
``fps`` that makes that 1 (the env's default 50 fps with 5 ms steps is 4x slow motion).
"""

from __future__ import annotations

import errno
import math
import os
import secrets
import shutil
import tempfile
from collections.abc import Generator
from pathlib import Path
from types import TracebackType
from typing import Any

import imageio_ffmpeg
import numpy as np
from pettingzoo.utils.env import ParallelEnv
from pettingzoo.utils.wrappers.base_parallel import BaseParallelWrapper

from reachavoid_env import checks
from reachavoid_env.files import destination, install, is_stream

VIDEO_SUFFIXES = (".mp4", ".gif")
FPS_RANGE = (0.1, 240.0)
"""Frames per second a video may play at."""

# One palette per frame keeps GIF colours exact without a second pass over the video.
_GIF_FILTER = "split[a][b];[a]palettegen=stats_mode=single[p];[b][p]paletteuse=new=1"


def realtime_fps(dt: float, every: int = 1) -> float:
    """Frames per second at which a video with a frame every ``every`` steps of ``dt``
    seconds plays in game time (one second of video per second of game time)."""
    return 1.0 / (dt * every)


def realtime_every(dt: float, max_fps: float) -> int:
    """The smallest ``every`` whose real-time rate ``realtime_fps(dt, every)`` is at most
    ``max_fps`` frames per second."""
    return max(1, math.ceil(1.0 / (dt * max_fps) - 1e-9))


class _Discard(BaseException):
    """Thrown into the ffmpeg generator to kill the encoder instead of finishing."""


def check_video_path(path: str | os.PathLike[str]) -> Path:
    """``path`` as a ``Path`` if a video can be written there, else ``ValueError``."""
    path = Path(path)
    if path.suffix.lower() not in VIDEO_SUFFIXES:
        raise ValueError(f"video: {str(path)!r} must end in one of "
                         f"{', '.join(VIDEO_SUFFIXES)} (got {path.suffix or 'no suffix'!r})")
    if not path.parent.is_dir():
        raise ValueError(f"video: folder {str(path.parent)!r} does not exist")
    return path


def check_complete(written: Path, destination: Path) -> None:
    """Raise ``OSError`` naming ``destination`` unless ``written`` is a whole video file.

    imageio-ffmpeg does not report ffmpeg's exit status, so a failed write (a full disk)
    would otherwise pass: an MP4 must consist of whole top-level boxes, ``moov`` (the
    index ffmpeg writes last) among them; a GIF must end with its trailer byte.
    """
    size = written.stat().st_size if written.is_file() else 0
    with open(written, "rb") if size else open(os.devnull, "rb") as handle:
        if written.suffix.lower() == ".gif":
            handle.seek(max(size - 1, 0))
            complete = size > 6 and handle.read(1) == b"\x3b"
        else:
            boxes, offset = set(), 0
            while offset + 8 <= size:
                handle.seek(offset)
                header = handle.read(16)
                length, kind = int.from_bytes(header[:4], "big"), header[4:8]
                if length == 1:
                    length = int.from_bytes(header[8:16], "big")
                if length < 8:
                    break
                boxes.add(kind)
                offset += length
            complete = offset == size and {b"ftyp", b"moov", b"mdat"} <= boxes
    if not complete:
        raise OSError(errno.EIO, "ffmpeg did not finish the video (disk full or write "
                                 "error); nothing was written", str(destination))


class VideoWriter:
    """Streams frames into ``path`` (``.mp4``: H.264, yuv420p; ``.gif``: looping).

    ``fps`` is the playback rate (frames per second). ``quality`` (1-10) sets the H.264
    compression (10 is best). Frames are ``(height, width, 3)`` uint8 arrays of one size;
    sizes that are multiples of 16 are encoded as they are.
    """

    def __init__(self, path: str | os.PathLike[str], fps: float = 30.0, *,
                 quality: float = 7.0) -> None:
        self.path = check_video_path(path)
        checks.real(fps, "fps", *FPS_RANGE)
        if not 1 <= quality <= 10:
            raise ValueError(f"quality: must lie in [1, 10], got {quality}")
        self.fps = float(fps)
        self.quality = float(quality)
        self.frames = 0
        self._size: tuple[int, int] | None = None
        self._encoder: Generator[None, Any, None] | None = None
        self._tmp: Path | None = None
        self._private: Path | None = None
        self._closed = False

    def _open(self, width: int, height: int) -> None:
        suffix = self.path.suffix.lower()
        target = destination(self.path)
        if is_stream(self.path):
            self._private = Path(tempfile.mkdtemp(prefix="reachavoid-video-"))
            target = self._private / f"video{suffix}"
        tmp = target.with_name(f".{target.stem}.{os.getpid()}.{secrets.token_hex(4)}"
                               f".part{suffix}")
        self._tmp = tmp
        if suffix == ".gif":
            options = dict(codec="gif", pix_fmt_out="pal8", quality=None, macro_block_size=1,
                           output_params=["-vf", _GIF_FILTER, "-loop", "0"])
        else:
            options = dict(codec="libx264", pix_fmt_out="yuv420p", quality=self.quality,
                           macro_block_size=16, output_params=["-preset", "veryfast"])
        self._encoder = imageio_ffmpeg.write_frames(str(tmp), (width, height), fps=self.fps,
                                                    ffmpeg_log_level="error", **options)
        self._encoder.send(None)
        self._size = (height, width)

    def append(self, frame: np.ndarray) -> None:
        """Encode one ``(height, width, 3)`` uint8 frame."""
        if self._closed:
            raise ValueError(f"video {str(self.path)!r}: append after close")
        frame = np.asarray(frame)
        if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3:
            raise ValueError(f"video frame {self.frames}: expected a (height, width, 3) uint8 "
                             f"array, got {frame.dtype} {frame.shape}")
        if self._size is None:
            self._open(frame.shape[1], frame.shape[0])
        elif frame.shape[:2] != self._size:
            raise ValueError(f"video frame {self.frames}: size {frame.shape[:2]} differs from "
                             f"the first frame's {self._size}")
        try:
            self._encoder.send(np.ascontiguousarray(frame))
        except BaseException:
            self.abort()
            raise
        self.frames += 1

    def close(self) -> None:
        """Finish the video and move it to ``path`` (needs at least one frame)."""
        if self._closed:
            return
        self._closed = True
        if self._encoder is None:
            raise ValueError(f"video {str(self.path)!r}: no frames were appended")
        try:
            self._encoder.close()
            check_complete(self._tmp, self.path)
            install(self._tmp, self.path)
        finally:
            self._encoder = None
            self._remove_temporary()

    def _remove_temporary(self) -> None:
        if self._tmp is not None:
            self._tmp.unlink(missing_ok=True)
        if self._private is not None:
            shutil.rmtree(self._private, ignore_errors=True)

    def abort(self) -> None:
        """Stop the encoder and remove the partial file; ``path`` is left untouched."""
        self._closed = True
        if self._encoder is not None:
            try:
                self._encoder.throw(_Discard())
            except (_Discard, StopIteration):
                pass
            self._encoder = None
        self._remove_temporary()

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()


class RecordEpisode(BaseParallelWrapper):
    """Records ``env.render()`` at the start of every episode and after every ``every``-th
    step and the last one, to a video.

    The start frame is drawn just before the first step (or when the episode ends without
    one), not at ``reset``: what the caller sets between the two (the policies' first
    decision through ``set_overlay``) is on it, as on every later frame.
    All episodes go into the one file at ``path``, finished by ``close()``. With
    ``per_episode`` each episode gets its own file, finished when the episode ends: the
    text ``{episode}`` in ``path`` is replaced by the episode's number (from 0; e.g.
    ``"run_{episode}.mp4"``); a path is otherwise taken as it is, braces included.
    ``fps`` defaults to ``env.metadata["render_fps"]`` (``realtime_fps`` gives the one at
    which video time equals game time).
    Used as a context manager, an exception inside the block discards the unfinished
    video.
    """

    def __init__(self, env: ParallelEnv, path: str | os.PathLike[str], fps: float | None = None,
                 *, every: int = 1, per_episode: bool = False) -> None:
        super().__init__(env)
        if getattr(env, "render_mode", None) != "rgb_array":
            raise ValueError(f"RecordEpisode needs render_mode='rgb_array', got "
                             f"{getattr(env, 'render_mode', None)!r}")
        if every < 1:
            raise ValueError(f"every: must be a positive integer, got {every}")
        self.path_template = str(path)
        self.per_episode = per_episode
        if per_episode and "{episode}" not in self.path_template:
            raise ValueError(f"video: {self.path_template!r} needs '{{episode}}' with "
                             "per_episode=True")
        check_video_path(self.episode_path(0))
        self.fps = float(fps if fps is not None else env.metadata.get("render_fps", 30))
        self.every = int(every)
        self.episode = -1
        self.frames = 0
        self._steps = 0
        self._start_pending = False
        self._writer: VideoWriter | None = None

    def episode_path(self, episode: int) -> str:
        """Where episode ``episode`` (from 0) is written."""
        if not self.per_episode:
            return self.path_template
        return self.path_template.replace("{episode}", str(episode))

    def reset(self, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[dict, dict]:
        self._record_start()  # a last episode that ended before its first step
        if self.per_episode:
            self.finish()
        result = self.env.reset(seed=seed, options=options)
        self.episode += 1
        self._steps = 0
        if self._writer is None:
            self._writer = VideoWriter(self.episode_path(self.episode), self.fps)
        self._start_pending = True
        return result

    def step(self, actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        live = bool(self.env.agents)
        if live:
            self._record_start()
        result = self.env.step(actions)
        if not live:
            return result
        self._steps += 1
        ended = not self.env.agents
        if self._writer is not None and (ended or self._steps % self.every == 0):
            self._record()
        if ended and self.per_episode:
            self.finish()
        return result

    def _record_start(self) -> None:
        """The start frame of the episode, if it is still to be drawn."""
        if self._start_pending and self._writer is not None:
            self._record()
        self._start_pending = False

    def _record(self) -> None:
        frame = self.env.render()
        try:
            self._writer.append(frame)
        except BaseException:
            self.abort()
            raise
        self.frames += 1

    def finish(self) -> None:
        """Finish the video being written (the env stays open)."""
        self._record_start()
        if self._writer is not None:
            writer, self._writer = self._writer, None
            writer.close()

    def abort(self) -> None:
        """Discard the video being written; its destination is left untouched."""
        self._start_pending = False
        if self._writer is not None:
            writer, self._writer = self._writer, None
            writer.abort()

    def close(self) -> None:
        """Finish the current video, then close the env."""
        try:
            self.finish()
        finally:
            self.env.close()

    def __enter__(self) -> RecordEpisode:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        if kind is not None:
            self.abort()
        self.close()

"""Writing MP4 video in process, with the H.264 encoder PyAV ships in its wheel (no system ffmpeg).

`VideoWriter` encodes frames as they come (nothing is held but the encoded bytes and a short queue) and
`finish()` returns the file's bytes, so that the caller writes it whole with `attribot.files.write_whole`.
Frames are encoded and muxed on a thread of the writer's own: a run's deadline is enforced by a signal
that raises in the main thread (`attribot.runner.process`), and an exception raised while PyAV's muxer is
calling back into Python leaves the container broken, so that the whole saved run would be lost at
`finish()`. Signal handlers never run on another thread, and the main thread only hands frames over,
through a deque (whose append and popleft are atomic) rather than a `queue.Queue`: a signal that raised
while `Queue.put` held the queue's lock (between acquiring it and the `with` taking charge of it) left the
lock held, and the next `put` waited forever.
"""

from __future__ import annotations

import io
import threading
import time
from collections import deque
from typing import Any

import numpy as np

from attribot.errors import InputError

__all__ = ["VideoWriter"]

_QUEUED_FRAMES = 32
"""Frames waiting for the encoder at most: `add` waits beyond this, so memory stays bounded."""
_POLL_S = 0.001
"""How long the encoder waits for a frame, and `add` for room, before looking again."""


class VideoWriter:
    """H.264 MP4 of equally sized RGB uint8 frames at `fps` frames per second."""

    def __init__(self, fps: float = 4.0) -> None:
        import av

        self._buffer = io.BytesIO()
        self._container = av.open(self._buffer, mode="w", format="mp4")
        self._stream: Any = None  # av's stream, made at the first frame (its size comes from it)
        self._fps = fps
        self.frames = 0  # frame times so far (a held frame counts its repeats)
        self._held: tuple[np.ndarray, int] = (np.zeros((0, 0, 3), np.uint8), 0)
        self._size: tuple[int, int] | None = None  # width, height of every frame (even sides)
        self._queue: deque[tuple[np.ndarray, int] | None] = deque()
        self._error: BaseException | None = None
        # set when the encoder thread ends; not Thread.is_alive() or join(): a signal that raises inside
        # those (CPython 3.11's bpo-45274 handling) releases the running thread's own lock and marks it
        # stopped, and finish() then flushed the encoder while the thread still encoded (a segfault)
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._encode_queued, name="attribot-video", daemon=True)
        self._thread.start()

    def add(self, rgb: np.ndarray, repeat: int = 1) -> None:
        """Append `rgb`, shown for `repeat` frame times: a held frame is encoded once, with a longer
        duration (the file's frame times are its own; players show it for as long)."""

        if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
            raise InputError(f"a video frame must be RGB uint8 (H, W, 3), got {rgb.dtype} {rgb.shape}")
        if repeat < 1:
            raise InputError(f"a video frame is shown at least once, got repeat={repeat}")
        if self._size is None:
            h, w = rgb.shape[:2]
            self._size = (w - w % 2, h - h % 2)  # yuv420p wants even sides
        width, height = self._size
        rgb = np.ascontiguousarray(rgb[:height, :width])  # a copy the caller cannot change under us
        pts = self.frames
        self.frames += repeat
        self._held = (rgb, repeat)
        self._put((rgb, pts))

    def _put(self, item: tuple[np.ndarray, int] | None) -> None:
        """Hand an item to the encoder, waiting while `_QUEUED_FRAMES` wait already (no lock is taken: see
        the module docstring)."""
        while len(self._queue) >= _QUEUED_FRAMES and not self._done.is_set():
            time.sleep(_POLL_S)
        self._queue.append(item)

    def _encode_queued(self) -> None:
        try:
            while True:
                try:
                    item = self._queue.popleft()
                except IndexError:
                    time.sleep(_POLL_S)
                    continue
                if item is None:
                    return
                if self._error is None:
                    try:
                        self._encode(*item)
                    except BaseException as exc:  # kept for finish(): this thread has no caller to raise to
                        self._error = exc
        finally:
            self._done.set()

    def _encode(self, rgb: np.ndarray, pts: int) -> None:
        import av

        if self._stream is None:
            from fractions import Fraction

            rate = Fraction(self._fps).limit_denominator(1000)
            self._stream = self._container.add_stream("libx264", rate=rate)
            self._stream.codec_context.time_base = 1 / rate  # one tick per frame time
            self._stream.width, self._stream.height = rgb.shape[1], rgb.shape[0]
            self._stream.pix_fmt = "yuv420p"
            self._stream.options = {"crf": "28", "preset": "veryfast"}
        frame = av.VideoFrame.from_ndarray(rgb, format="rgb24")
        frame.pts = pts
        for packet in self._stream.encode(frame):
            self._container.mux(packet)

    def finish(self) -> bytes:
        """Flush the encoder and return the MP4 file's bytes (empty when no frame was added)."""
        rgb, repeat = self._held
        if repeat > 1:  # the last frame's duration is the gap to the next: one more frame ends it
            self._put((rgb, self.frames - 1))
        self._put(None)
        self._done.wait()
        if self._error is not None:
            raise self._error
        if self._stream is None:
            self._container.close()
            return b""
        for packet in self._stream.encode():
            self._container.mux(packet)
        self._container.close()
        return self._buffer.getvalue()

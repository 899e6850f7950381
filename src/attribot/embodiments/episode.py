"""Episode videos: what the robot saw and did, frame by frame in sim time, for a person to watch.

`EpisodeRecorder` hooks the simulated world's clock (`SimWorld.step_hooks`): every `period_s` of sim time
it takes the robot camera's view and the fixed third-person room camera's view, puts them side by side,
draws the box the servo controller is tracking (when it is) and writes the API call being executed
underneath, and encodes the frame at once. `finish()` gives the MP4 bytes.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import cv2
import mujoco
import numpy as np

from attribot.video import VideoWriter

__all__ = ["EpisodeRecorder"]

Box = tuple[float, float, float, float]


class EpisodeRecorder:
    """Records `world` (a `MujocoWorld`) from now on. caption(): the text for the frame (the API call);
    tracked(): the tracked box in camera pixels or None. `view` is the size of each half of the video."""

    def __init__(
        self,
        world: Any,
        caption: Callable[[], str],
        tracked: Callable[[], Box | None] = lambda: None,
        period_s: float = 0.25,
        view: tuple[int, int] = (320, 240),
    ) -> None:
        self.sim = world.sim
        self._scratch: Any = None
        self.caption = caption
        self.tracked = tracked
        self.period_s = period_s
        self.view = view
        self.writer = VideoWriter(fps=1.0 / period_s)
        self._next = float(self.sim.data.time)
        self.sim.step_hooks.append(self._on_step)
        self._grab()

    def _on_step(self, now: float) -> None:
        if now + 1e-9 >= self._next:
            self._grab()
            while self._next <= now + 1e-9:
                self._next += self.period_s

    def _grab(self) -> None:
        # filmed from a copy of the world's state: rendering runs mj_forward, which leaves solver state
        # behind, and a filmed episode must move exactly as an unfilmed one (a --save run replays bit for bit)
        live = self.sim.data
        if self._scratch is None:
            self._scratch = mujoco.MjData(self.sim.model)
        mujoco.mj_copyData(self._scratch, self.sim.model, live)
        self.sim.data = self._scratch
        try:
            self._frame()
        finally:
            self.sim.data = live

    def _frame(self) -> None:
        w, h = self.view
        camera = self.sim.observe(depth=False, segmentation=False).rgb
        sx, sy = w / camera.shape[1], h / camera.shape[0]
        left = cv2.resize(camera, (w, h), interpolation=cv2.INTER_AREA)
        box = self.tracked()
        if box is not None:
            p0 = (int(box[0] * sx), int(box[1] * sy))
            p1 = (int(box[2] * sx), int(box[3] * sy))
            cv2.rectangle(left, p0, p1, (255, 220, 0), 2)
        cv2.drawMarker(left, (w // 2, h // 2), (255, 255, 255), cv2.MARKER_CROSS, 12, 1)
        right = cv2.resize(self.sim.room_view(), (w, h), interpolation=cv2.INTER_AREA)
        bar = np.full((28, 2 * w, 3), 24, np.uint8)
        text = f"t={self.sim.data.time:5.1f}s  {self.caption()}"[:90]
        cv2.putText(bar, text, (8, 19), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (235, 235, 235), 1, cv2.LINE_AA)
        self.writer.add(np.vstack([np.hstack([left, right]), bar]))

    def finish(self) -> bytes:
        """Stop recording and return the MP4 bytes."""
        if self._on_step in self.sim.step_hooks:
            self.sim.step_hooks.remove(self._on_step)
            self._grab()  # the last moment: how the episode ended
        return self.writer.finish()

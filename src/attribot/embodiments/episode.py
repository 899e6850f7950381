"""Episode videos: what the robot saw and did, frame by frame in sim time, for a person to watch.

`EpisodeRecorder` hooks the simulated world's clock (`SimWorld.step_hooks`): every `period_s` of sim time
it takes the robot camera's view and the fixed third-person room camera's view, puts them side by side,
draws the box the servo controller is tracking (when it is), writes the action under way and the values
read so far underneath, and encodes the frame at once. The video opens with a card that shows the query
and ends with one that shows the answer, its box on the robot's image and its values; a new caption is
held for a moment so that it can be read. `finish()` gives the MP4 bytes. Played at `1 / period_s` frames
a second, the video runs at the pace of sim time.
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable, Sequence
from typing import Any

import cv2
import mujoco
import numpy as np

from attribot.draw import draw_boxes
from attribot.video import VideoWriter

__all__ = ["EpisodeRecorder"]

Box = tuple[float, float, float, float]

_BAR_H = 84  # the caption bar under the two views: the action, then the values read
_BACKGROUND = (24, 26, 30)
_TEXT = (235, 235, 235)
_DIM = (160, 166, 176)
_ACCENT = (255, 200, 40)


def _font(size: int) -> Any:
    """Pillow's own scalable font (bundled with it since 10.1): the same letters on every machine."""
    from PIL import ImageFont

    return ImageFont.load_default(size=size)


def _text(rgb: np.ndarray, lines: Sequence[tuple[str, int, tuple[int, int, int]]], x: int, y: int) -> int:
    """Write `lines` (text, size, colour) onto `rgb` in place from (x, y) down; return the y below them."""
    from PIL import Image, ImageDraw

    img = Image.fromarray(rgb)
    draw = ImageDraw.Draw(img)
    for text, size, colour in lines:
        draw.text((x, y), text, font=_font(size), fill=colour)
        y += int(size * 1.3)
    rgb[:] = np.asarray(img)
    return y


def _box_of(frame: Any, object_id: str) -> Box | None:
    """The box (pixels, xyxy) of the object `object_id` in the frame's segmentation, None when unseen."""
    keys = [k for k, truth in frame.objects.items() if truth.id == object_id]
    if not keys or frame.segmentation is None:
        return None
    ys, xs = np.nonzero(frame.segmentation == keys[0])
    if xs.size == 0:
        return None
    return float(xs.min()), float(ys.min()), float(xs.max() + 1), float(ys.max() + 1)


class EpisodeRecorder:
    """Records `world` (a `MujocoWorld`) from now on.

    caption(): the action under way (e.g. "measuring the distance to the mug 0"); readings(): the values
    read so far, one short line each; tracked(): the box the controller tracks, in camera pixels, or None;
    target(): the name and world id of the object acted on (the id None when unknown), whose box is
    drawn from the world's segmentation while nothing is tracked. `view` is the size of each half of the
    video; `title` (the query) fills the opening card; `on_frame` sees each pair of views (robot camera,
    room camera) as it is taken, before their labels are written on them."""

    def __init__(
        self,
        world: Any,
        caption: Callable[[], str],
        tracked: Callable[[], Box | None] = lambda: None,
        period_s: float = 0.1,
        view: tuple[int, int] = (640, 480),
        title: str = "",
        readings: Callable[[], Sequence[str]] = lambda: (),
        target: Callable[[], tuple[str, str | None]] = lambda: ("", None),
        on_frame: Callable[[np.ndarray, np.ndarray], None] | None = None,
        hold_s: float = 0.8,
    ) -> None:
        self.sim = world.sim
        self._scratch: Any = None
        self.caption = caption
        self.readings = readings
        self.tracked = tracked
        self.target = target
        self.on_frame = on_frame
        self.period_s = period_s
        self.view = view
        self.hold = max(1, round(hold_s / period_s))
        self.writer = VideoWriter(fps=1.0 / period_s)
        self.size = (2 * view[0], view[1] + _BAR_H)  # width, height of every frame
        self._shown = ""  # the caption of the last frame: a new one is held for `hold` frames
        if title:
            self._card(self._title_card(title), 2.5)
        self._next = float(self.sim.data.time)
        self.sim.step_hooks.append(self._on_step)
        self._grab()

    def _on_step(self, now: float) -> None:
        if now + 1e-9 >= self._next:
            self._grab()
            while self._next <= now + 1e-9:
                self._next += self.period_s

    def _card(self, rgb: np.ndarray, seconds: float) -> None:
        self.writer.add(rgb, repeat=max(1, round(seconds / self.period_s)))

    def _blank(self) -> np.ndarray:
        w, h = self.size
        return np.full((h, w, 3), _BACKGROUND, np.uint8)

    def _title_card(self, query: str) -> np.ndarray:
        card = self._blank()
        lines = [(line, 44, _TEXT) for line in textwrap.wrap(f"\u201c{query}\u201d", 46)[:5]]
        y0 = max(40, (card.shape[0] - 60 * len(lines)) // 2 - 40)
        y = _text(card, [("attribot: the query", 24, _DIM)], 80, y0)
        _text(card, lines, 80, y + 16)
        return card

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
        name, object_id = self.target()
        box = self.tracked()
        frame = self.sim.observe(depth=False, segmentation=box is None and object_id is not None)
        if box is None and object_id is not None:
            box = _box_of(frame, object_id)
        camera = frame.rgb
        sx, sy = w / camera.shape[1], h / camera.shape[0]
        left = cv2.resize(camera, (w, h), interpolation=cv2.INTER_AREA)
        if box is not None:
            scaled = (box[0] * sx, box[1] * sy, box[2] * sx, box[3] * sy)
            left = draw_boxes(left, [(scaled, name or "tracked")])
        cv2.drawMarker(left, (w // 2, h // 2), (255, 255, 255), cv2.MARKER_CROSS, 18, 1)
        right = cv2.resize(self.sim.room_view(), (w, h), interpolation=cv2.INTER_AREA)
        if self.on_frame is not None:
            self.on_frame(left, right)
        for panel, name in ((left, "robot camera"), (right, "room camera")):
            panel[:32, :150] = panel[:32, :150] // 3  # a dark patch: the label stays readable on a light wall
            _text(panel, [(name, 18, (255, 255, 255))], 10, 7)
        bar = np.full((_BAR_H, 2 * w, 3), _BACKGROUND, np.uint8)
        caption = self.caption() or "looking at the scene"
        values = "   ".join(self.readings())
        lines = [(f"t = {self.sim.data.time:5.1f} s   {caption}"[:110], 26, _TEXT)]
        lines.append(
            (f"read: {values}"[-120:] if values else "no values read yet", 22, _ACCENT if values else _DIM)
        )
        _text(bar, lines, 14, 10)
        frame = np.vstack([np.hstack([left, right]), bar])
        repeat = self.hold if caption != self._shown else 1
        self._shown = caption
        self.writer.add(frame, repeat=repeat)

    def _closing_card(self, answer: Sequence[str], still: np.ndarray | None) -> np.ndarray:
        card = self._blank()
        w, h = self.view
        x = 60
        if still is not None:  # the robot's image with the answer's box, on the left half
            fitted = cv2.resize(still, (w - 40, (w - 40) * still.shape[0] // still.shape[1]))
            fitted = fitted[: card.shape[0] - 40]
            card[20 : 20 + fitted.shape[0], 20 : 20 + fitted.shape[1]] = fitted
            x = w + 20
        wrap = 34 if still is not None else 70
        lines: list[tuple[str, int, tuple[int, int, int]]] = [("the answer", 24, _DIM)]
        lines += [(line, 34, _TEXT) for line in textwrap.wrap(answer[0], wrap)[:6]]
        if len(answer) > 1:
            lines += [("", 12, _DIM), ("the values read", 24, _DIM)]
            lines += [(line, 24, _ACCENT) for line in answer[1:9]]
        _text(card, lines, x, 60)
        return card

    def finish(self, answer: Sequence[str] = (), still: np.ndarray | None = None) -> bytes:
        """Stop recording and return the MP4 bytes; `answer` (the answer's sentence, then its values, one
        line each) and `still` (the robot's image with the answer's box drawn) make the closing card."""
        if self._on_step in self.sim.step_hooks:
            self.sim.step_hooks.remove(self._on_step)
            self._grab()  # the last moment: how the episode ended
            if answer:
                self._card(self._closing_card(answer, still), 4.0)
        return self.writer.finish()

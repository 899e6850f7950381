"""A box tracker on OpenCV's pyramidal Lucas-Kanade: detect once, then follow the box frame by frame.

As the paper's robot did (one detection on the first frame, then KLT tracking, re-seeding features inside
the box when fewer than 15 survive), with a forward-backward check that drops features whose backward
flow does not come home, and a scale estimate so that the box grows as the robot drives closer:

- features: `cv2.goodFeaturesToTrack` inside the box (optionally shrunk by a margin; by default not,
  since a small or untextured object, as simulated ones are, has its corners on its outline);
- each frame: `cv2.calcOpticalFlowPyrLK` forward and backward between the previous grey frame and this
  one (OpenCV 5's Python binding takes images, not prebuilt pyramids);
- the box scales by the median ratio of pairwise feature distances and its centre moves to the median of
  the centres the features predict, both robust to a few bad features;
- fewer than `min_features` survivors: features are re-seeded inside the new box; fewer than
  `lost_features` (too few to estimate a motion), or a box that left the image or changed scale
  implausibly in one frame: the target is lost, and the caller detects again.

Images are RGB uint8 (H, W, 3) or grey (H, W); boxes are xyxy pixels, origin top-left (the project's
convention). It knows nothing of simulators or models.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from attribot.errors import InputError

__all__ = ["BoxTracker", "TrackResult"]

Box = tuple[float, float, float, float]


@dataclass(frozen=True)
class TrackResult:
    """One frame's outcome: the box (the last good one when lost), whether it is lost, how many features
    carried it, and whether they were re-seeded this frame."""

    box: Box
    lost: bool
    features: int
    reseeded: bool = False
    reason: str = ""


class BoxTracker:
    """Follows one box through a stream of frames. `start(frame, box)`, then `update(frame)` per frame.

    max_features / min_features: features seeded / the count below which they are re-seeded (the paper's
    15); lost_features: below this the motion cannot be estimated and the target is lost; fb_max_px: the
    largest forward-backward error a feature may have; max_scale_step: the largest scale change believed
    in one frame; scale_features / scale_deadband: the scale is updated only from at least this many
    features and when it changes by more than this fraction in a frame (less is noise); margin: the
    fraction of the box's size kept off each edge when seeding; quality: the corner-quality level of
    goodFeaturesToTrack, low so that plain objects still give features.
    """

    def __init__(
        self,
        *,
        max_features: int = 60,
        min_features: int = 15,
        lost_features: int = 4,
        fb_max_px: float = 1.0,
        window: int = 15,
        levels: int = 3,
        quality: float = 0.001,
        min_distance: int = 3,
        max_scale_step: float = 0.25,
        scale_features: int = 8,
        scale_deadband: float = 0.002,
        margin: float = 0.0,
    ) -> None:
        if not 0 < lost_features <= min_features <= max_features:
            raise InputError(
                f"tracker feature counts lost={lost_features}, min={min_features}, max={max_features} are "
                "out of order",
                "give 0 < lost_features <= min_features <= max_features",
            )
        self.max_features = max_features
        self.min_features = min_features
        self.lost_features = lost_features
        self.fb_max_px = fb_max_px
        self.window = (window, window)
        self.levels = levels
        self.quality = quality
        self.min_distance = min_distance
        self.max_scale_step = max_scale_step
        self.scale_features = scale_features
        self.scale_deadband = scale_deadband
        self.margin = margin
        self.box: Box | None = None
        self._points: np.ndarray | None = None  # (N, 1, 2) float32
        self._previous: np.ndarray | None = None  # the last grey frame
        self._shape: tuple[int, int] = (0, 0)
        self._criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 20, 0.03)

    # ---- public ----------------------------------------------------------------------------------------
    def start(self, image: np.ndarray, box: Box) -> TrackResult:
        """Begin tracking `box` in `image`. A box with no trackable texture is lost at once."""
        gray = _gray(image)
        self._shape = gray.shape[:2]
        self.box = _clip(box, self._shape)
        if self.box[2] <= self.box[0] or self.box[3] <= self.box[1]:
            raise InputError(f"cannot track the box {tuple(box)}: it lies outside the image or is empty")
        if self.box[2] - self.box[0] < 2 or self.box[3] - self.box[1] < 2:
            # a sliver (a far object, a detector's jitter) is no error: there is just nothing to track in it
            self._previous, self._points = gray, None
            return TrackResult(self.box, True, 0, True, "the box is too thin to track")
        self._previous = gray
        self._points = self._seed(gray, self.box)
        n = 0 if self._points is None else len(self._points)
        if n < self.lost_features:
            return TrackResult(self.box, True, n, True, "no texture to track inside the box")
        return TrackResult(self.box, False, n, True)

    def update(self, image: np.ndarray) -> TrackResult:
        """Move the box to where its features went in `image`."""
        if self.box is None or self._previous is None:
            raise InputError("the tracker has no target", "call start(frame, box) first")
        gray = _gray(image)
        if gray.shape[:2] != self._shape:
            raise InputError(
                f"frame size changed from {self._shape[::-1]} to {gray.shape[1::-1]} while tracking",
                "track in frames of one size",
            )
        old, previous = self._points, self._previous
        self._previous = gray
        if old is None or len(old) < self.lost_features:
            return TrackResult(self.box, True, 0, False, "no features left")
        new, good = self._flow(previous, gray, old)
        n = int(good.sum())
        if n < self.lost_features:
            self._points = None
            return TrackResult(self.box, True, n, False, f"only {n} features survived")
        p0, p1 = old[good, 0], new[good, 0]
        # a scale from a few features, or one within the noise of a still box, would random-walk the box's
        # size over many frames: believe only a clear change seen by enough features
        scale = _scale(p0, p1) if n >= self.scale_features else 1.0
        scale = 1.0 if abs(scale - 1.0) < self.scale_deadband else scale
        if abs(scale - 1.0) > self.max_scale_step:
            self._points = None
            return TrackResult(
                self.box, True, n, False, f"implausible scale change x{scale:.2f} in one frame"
            )
        x0, y0, x1, y1 = self.box
        # each feature says where the centre went (its new place minus its scaled offset from the old
        # centre); the median of those, unlike the median shift, is unbiased when the features sit off-centre
        centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2], np.float32)
        cx, cy = (float(v) for v in np.median(p1 - scale * (p0 - centre), axis=0))
        hw, hh = (x1 - x0) * scale / 2, (y1 - y0) * scale / 2
        moved = (cx - hw, cy - hh, cx + hw, cy + hh)
        clipped = _clip(moved, self._shape)
        visible = _area(clipped) / max(_area(moved), 1e-9)
        if visible < 0.5:
            self._points = None
            return TrackResult(self.box, True, n, False, "the box left the image")
        self.box = moved
        inside = _inside(p1, clipped)
        self._points = p1[inside].reshape(-1, 1, 2).astype(np.float32)
        reseeded = False
        if len(self._points) < self.min_features:
            seeded = self._seed(gray, clipped)
            if seeded is not None and len(seeded) > len(self._points):
                self._points = seeded
                reseeded = True
        return TrackResult(self.box, False, len(self._points), reseeded)

    # ---- internals -------------------------------------------------------------------------------------
    def _flow(self, prev: np.ndarray, nxt: np.ndarray, p0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w, lv, cr = self.window, self.levels, self._criteria
        p1, st1, _ = cv2.calcOpticalFlowPyrLK(prev, nxt, p0, None, winSize=w, maxLevel=lv, criteria=cr)  # type: ignore[call-overload]
        back, st2, _ = cv2.calcOpticalFlowPyrLK(nxt, prev, p1, None, winSize=w, maxLevel=lv, criteria=cr)  # type: ignore[call-overload]
        fb = np.linalg.norm((p0 - back).reshape(-1, 2), axis=1)
        good = (st1.ravel() == 1) & (st2.ravel() == 1) & (fb <= self.fb_max_px)
        return p1, good

    def _seed(self, gray: np.ndarray, box: Box) -> np.ndarray | None:
        x0, y0, x1, y1 = box
        mx, my = (x1 - x0) * self.margin, (y1 - y0) * self.margin
        mask = np.zeros(gray.shape[:2], np.uint8)
        mask[int(y0 + my) : int(np.ceil(y1 - my)), int(x0 + mx) : int(np.ceil(x1 - mx))] = 255
        pts = cv2.goodFeaturesToTrack(
            gray, self.max_features, self.quality, self.min_distance, mask=mask, blockSize=3
        )
        return None if pts is None else pts.astype(np.float32)


def _gray(image: np.ndarray) -> np.ndarray:
    if image.ndim == 2:
        return image
    if image.ndim == 3 and image.shape[2] == 3:
        return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    raise InputError(f"the tracker needs an RGB (H, W, 3) or grey (H, W) image, got shape {image.shape}")


def _clip(box: Box, shape: tuple[int, int]) -> Box:
    h, w = shape
    x0, y0, x1, y1 = (float(v) for v in box)
    return (min(max(x0, 0.0), w), min(max(y0, 0.0), h), min(max(x1, 0.0), w), min(max(y1, 0.0), h))


def _area(box: Box) -> float:
    return max(box[2] - box[0], 0.0) * max(box[3] - box[1], 0.0)


def _inside(points: np.ndarray, box: Box) -> np.ndarray:
    x, y = points[:, 0], points[:, 1]
    return (x >= box[0]) & (x <= box[2]) & (y >= box[1]) & (y <= box[3])


def _scale(p0: np.ndarray, p1: np.ndarray) -> float:
    """Median ratio of pairwise distances after and before: the box's scale change."""
    if len(p0) < 2:
        return 1.0
    i, j = np.triu_indices(len(p0), k=1)
    before = np.linalg.norm(p0[i] - p0[j], axis=1)
    after = np.linalg.norm(p1[i] - p1[j], axis=1)
    keep = before > 2.0  # near pairs give noisy ratios
    if not keep.any():
        return 1.0
    return float(np.median(after[keep] / before[keep]))

"""`Sighting`: an object (or the whole image) as the robot saw it, on the host side: a box of a camera
frame, what found it there, and the host's queries on it: `find` (the detector, looking again, looking
harder, the found objects in whole-image pixels), whether two sightings show one object, its best box, and
what a controller is given to act on it. The robot session and the mechanisms act on sightings;
`attribot.api.patch.ImagePatch` is a sighting with the attributes and methods programs see.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Self, TypeVar

import numpy as np

from attribot.boxes import to_upward
from attribot.control.base import Capture, Target
from attribot.errors import BackendError
from attribot.frame import Frame, load_image
from attribot.models.base import Detection, evidence_of
from attribot.skills.checks import check_number, check_text
from attribot.skills.errors import ApiArgumentError
from attribot.skills.harder import Nearer, acting_find
from attribot.skills.looking import Survey, one_object
from attribot.skills.perception import Perception
from attribot.skills.safeguards import Safeguards

__all__ = ["Sighting", "find_in", "target_of", "EDGE_TOL"]

EDGE_TOL = 1e-6  # pixels: boxes may touch the image border, not cross it

S = TypeVar("S", bound="Sighting")


class Sighting:
    """A rectangle of a camera frame (the whole frame, or one detected object), with the host's queries."""

    def __init__(
        self,
        frame: Frame,
        perception: Perception,
        box: Sequence[float] | None = None,
        *,
        capture: Capture | None = None,
        object_id: str | None = None,
        label: str = "",
        score: float | None = None,
        by_depth: bool = False,
        evidence: str | None = None,
    ) -> None:
        """Host side: a patch of `frame` (the whole camera frame) inside the xyxy `box` (pixels of `frame`,
        y down; None for the whole frame). `capture` says when and from where the frame was taken (None for
        a still image); `object_id`, `label`, `score` come from the detection that produced the patch, and
        `by_depth` says that looking harder took it where the detector did not see its name surely, and
        `evidence` what the detection rests on (`attribot.models.base.Evidence`; None: no detection)."""
        if not isinstance(frame, Frame):
            raise TypeError(f"ImagePatch needs an attribot.frame.Frame, got {type(frame).__name__}")
        if not isinstance(perception, Perception):
            raise TypeError(f"ImagePatch needs an attribot.api.Perception, got {type(perception).__name__}")
        self.frame = frame
        self.perception = perception
        self.box = _check_box(box, frame)
        self.capture = capture
        self.object_id = object_id
        self.label = label
        self.score = score
        self.by_depth = by_depth
        self.evidence = evidence
        self.survey: Survey | None = None  # views around the first image, where the robot looked again
        self.nearer: Nearer | None = None  # where the robot can drive: looks nearer at a candidate
        # look_harder: the best box each name's find took in this image, which explains that object
        self.named: dict[str, Detection] = {}
        self.sought: frozenset[str] = frozenset()  # look_harder: the names the program looks for
        # the error-catching mechanisms its finds and questions go through (a robot's image: the session's)
        self.safeguards = Safeguards("none")
        self._pixels: Frame | None = None
        self._upward = to_upward(self.box, frame.height)

    @classmethod
    def from_image(cls, image: str | Path | np.ndarray, perception: Perception) -> Self:
        """Host side: the whole-image patch of an image file or uint8 RGB array (no camera, no robot)."""
        rgb = image if isinstance(image, np.ndarray) else load_image(image)
        return cls(Frame(rgb=rgb), perception)

    def best_box(self) -> tuple[tuple[float, float, float, float], str]:
        """Host side: the robot's best estimate of this object's box in its image when it answers, and what
        it is: with `look_again`, the detection and the image looked at again around it, averaged
        (`LookAgain.box`); else, or for a patch no detection named, the patch's own box."""
        if not self.label or self._whole():
            return self.box, "the patch's own box"
        return self.safeguards.look_again.box(
            self.perception.detector,
            self.frame,
            self.box,
            self.label,
            1.0 if self.score is None else self.score,
        )

    def summary(self) -> dict[str, Any]:
        """Host side: JSON-ready description (box in pixels, y down, as answers report boxes)."""
        return {
            "label": self.label or None,
            "object_id": self.object_id,
            "box": [round(v, 2) for v in self.box],
            "score": self.score,
            **({"evidence": self.evidence} if self.evidence else {}),
        }

    def target(self) -> Target | None:
        """Host side: what a controller needs to act on this patch; None when it has no capture."""
        return target_of(self)

    def same_object(self, other: Sighting) -> bool:
        """Host side: True when both patches show the same object: the same world id where the detector
        gives ids; else boxes of one image that are the same box, or that frame one object as depth places
        it (`one_object`: a cactus boxed whole as a cactus and its pot as a vase)."""
        if self.object_id is not None and other.object_id is not None:
            return self.object_id == other.object_id
        if self.frame is not other.frame:
            return False
        return bool(np.allclose(self.box, other.box)) or one_object(self.capture, self.box, other.box)

    def find(self, object_name: str) -> list[Self]:
        """One sighting per `object_name` found inside this one, best match first (`find_in`)."""
        return find_in(self, object_name)

    def size_at(self, distance: float) -> tuple[float, float]:
        """The (width, height) in metres of what this shows at `distance` metres from the camera."""
        d = check_number(distance, "distance", "size_at")
        camera = self.frame.camera
        if camera is None:
            raise ApiArgumentError(
                "size_at needs the camera's focal length, and this image has no camera model",
                "measure sizes on the simulator or a robot, whose camera is known",
            )
        if not d > 0:
            raise ApiArgumentError(f"size_at needs a distance above 0 metres; got {d:g}", "pass metres")
        return camera.metres_across(self.box, d)

    def _crop_frame(self) -> Frame:
        if self._pixels is None:
            self._pixels = self.frame if self._whole() else self.frame.crop(self.box)
        return self._pixels

    def _whole(self) -> bool:
        return self.box == (0.0, 0.0, float(self.frame.width), float(self.frame.height))


def find_in(patch: S, object_name: str) -> list[S]:
    """`patch.find(object_name)`: one patch per object found inside `patch`, best match first."""
    name = check_text(object_name, "object_name", "find", "detector")
    pixels = patch._crop_frame()
    detections = patch.perception.detector.detect(pixels, [name])
    if not isinstance(detections, list) or not all(isinstance(d, Detection) for d in detections):
        raise BackendError(
            f"the detector {patch.perception.detector.name!r} did not return a list of Detection",
            "fix the detector backend: detect() must return list[attribot.models.base.Detection]",
        )
    survey = patch.survey if patch._whole() else None
    detections = patch.safeguards.look_again.find(patch.perception.detector, pixels, name, detections, survey)
    detections, by_depth = patch.safeguards.look_harder.find(patch, name, pixels, detections)
    dx = pixels.origin[0] - patch.frame.origin[0]
    dy = pixels.origin[1] - patch.frame.origin[1]
    found: list[S] = []
    for det in sorted(detections, key=lambda d: -d.score):
        x0, y0, x1, y1 = det.box
        box = (
            min(max(x0 + dx, 0.0), patch.frame.width),
            min(max(y0 + dy, 0.0), patch.frame.height),
            min(max(x1 + dx, 0.0), patch.frame.width),
            min(max(y1 + dy, 0.0), patch.frame.height),
        )
        child = type(patch)(
            patch.frame,
            patch.perception,
            box,
            capture=patch.capture,
            object_id=det.object_id,
            label=det.label or name,
            score=det.score,
            by_depth=det in by_depth,
            evidence=evidence_of(det),
        )
        child.safeguards = patch.safeguards  # its own finds and questions are checked the same way
        found.append(child)
    return found


def target_of(patch: Sighting) -> Target | None:
    """What a controller needs to act on `patch`; None when it has no capture."""
    if patch.capture is None:
        return None
    find = None
    if patch.label:
        detector, label = patch.perception.detector, patch.label

        def find(frame: Frame) -> list[tuple[float, float, float, float]]:
            return [d.box for d in acting_find(detector, frame, label)]

    return Target(
        box=patch.box,
        capture=patch.capture,
        object_id=patch.object_id,
        label=patch.label,
        find=find,
        by_depth=patch.by_depth,
    )


def _check_box(box: Sequence[float] | None, frame: Frame) -> tuple[float, float, float, float]:
    w, h = frame.width, frame.height
    if box is None:
        return (0.0, 0.0, float(w), float(h))
    try:
        x0, y0, x1, y1 = (float(v) for v in box)
    except (TypeError, ValueError):
        raise ApiArgumentError(
            f"a patch box must be four numbers (x0, y0, x1, y1); got {box!r}", "pass an xyxy box in pixels"
        ) from None
    if not all(math.isfinite(v) for v in (x0, y0, x1, y1)) or x1 < x0 or y1 < y0:
        raise ApiArgumentError(
            f"a patch box must be finite with x1 >= x0 and y1 >= y0; got {box!r}",
            "pass an xyxy box in pixels",
        )
    if x0 < -EDGE_TOL or y0 < -EDGE_TOL or x1 > w + EDGE_TOL or y1 > h + EDGE_TOL:
        raise ApiArgumentError(
            f"the box {tuple(box)!r} lies outside the {w}x{h} image",
            "clip boxes to [0, width] x [0, height] (attribot.boxes.clip)",
        )
    return (max(x0, 0.0), max(y0, 0.0), min(x1, float(w)), min(y1, float(h)))

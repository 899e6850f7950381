"""`ImagePatch`: the perception half of the API that programs see (after the paper and ViperGPT).

The class docstring and the docstrings of the names in `API_ATTRIBUTES` / `API_METHODS` are written for
the LLM: `attribot.api.prompt` renders them, with the signatures, into the prompt. Everything else here
is for the host (the runner and the integrator) and never reaches a program.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from attribot.api.checks import check_facade, check_number, check_patch, check_text
from attribot.api.errors import ApiArgumentError
from attribot.api.finding import EDGE_TOL, crop_of, find_in, patch_from_program, target_of
from attribot.api.harder import Nearer
from attribot.api.looking import Survey, one_object
from attribot.api.perception import Perception
from attribot.api.safeguards import Safeguards
from attribot.boxes import to_upward
from attribot.control.base import Capture, Target
from attribot.errors import BackendError
from attribot.frame import Frame, load_image
from attribot.models.base import Detection

__all__ = ["ImagePatch"]


class ImagePatch:
    """A rectangle of the camera image (the whole image, or one detected object) that you can query.

    Coordinates are pixels of the whole image with y growing upward (`upper > lower`; a larger
    `vertical_center` is higher in the image; `left` < `right` as usual).
    """

    API_KIND: ClassVar[str] = "perception"  # what a failing call of this class counts as
    API_ATTRIBUTES: ClassVar[tuple[str, ...]] = (
        "left",
        "lower",
        "right",
        "upper",
        "width",
        "height",
        "horizontal_center",
        "vertical_center",
        "area",
    )
    API_METHODS: ClassVar[tuple[str, ...]] = (
        "find",
        "exists",
        "visual_query",
        "language_query",
        "crop",
        "overlaps",
        "distance_to",
        "size_at",
    )
    # public names for the host only (runner, integrator, Robot); programs never see them
    HOST_ATTRIBUTES: ClassVar[tuple[str, ...]] = (
        "frame",
        "perception",
        "box",
        "label",
        "score",
        "object_id",
        "capture",
        "survey",
        "nearer",
        "named",
        "sought",
        "by_depth",
        "evidence",
        "safeguards",
    )
    HOST_METHODS: ClassVar[tuple[str, ...]] = (
        "from_image",
        "summary",
        "target",
        "same_object",
        "from_program",
    )
    PROGRAM_CONSTRUCTOR: ClassVar[str] = "from_program"
    """What `ImagePatch(...)` in a program calls on the image it was given (the paper's dialect)."""

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

    # ---- host side ---------------------------------------------------------------------------------
    @classmethod
    def from_image(cls, image: str | Path | np.ndarray, perception: Perception) -> ImagePatch:
        """Host side: the whole-image patch of an image file or uint8 RGB array (no camera, no robot)."""
        rgb = image if isinstance(image, np.ndarray) else load_image(image)
        return cls(Frame(rgb=rgb), perception)

    def from_program(
        self,
        image: object = None,
        left: float | None = None,
        lower: float | None = None,
        right: float | None = None,
        upper: float | None = None,
    ) -> ImagePatch:
        """Host side: `ImagePatch(image)` written in a program, as the paper's and ViperGPT's programs do.
        The image given to execute_command is already a patch, so it is returned as it is; ViperGPT's
        `ImagePatch(image, left, lower, right, upper)` is its crop."""
        return patch_from_program(self, image, left, lower, right, upper)

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

    def same_object(self, other: ImagePatch) -> bool:
        """Host side: True when both patches show the same object: the same world id where the detector
        gives ids; else boxes of one image that are the same box, or that frame one object as depth places
        it (`one_object`: a cactus boxed whole as a cactus and its pot as a vase)."""
        if self.object_id is not None and other.object_id is not None:
            return self.object_id == other.object_id
        if self.frame is not other.frame:
            return False
        return bool(np.allclose(self.box, other.box)) or one_object(self.capture, self.box, other.box)

    def _crop_frame(self) -> Frame:
        if self._pixels is None:
            self._pixels = self.frame if self._whole() else self.frame.crop(self.box)
        return self._pixels

    def _whole(self) -> bool:
        return self.box == (0.0, 0.0, float(self.frame.width), float(self.frame.height))

    def __repr__(self) -> str:
        what = f"{self.label!r} " if self.label else ""
        return (
            f"ImagePatch({what}left={self.left:.0f}, lower={self.lower:.0f}, "
            f"right={self.right:.0f}, upper={self.upper:.0f})"
        )

    # ---- attributes (for programs) -----------------------------------------------------------------
    @property
    def left(self) -> float:
        """x of the left edge, pixels"""
        return self._upward[0]

    @property
    def lower(self) -> float:
        """y of the bottom edge, pixels (y grows upward)"""
        return self._upward[1]

    @property
    def right(self) -> float:
        """x of the right edge, pixels"""
        return self._upward[2]

    @property
    def upper(self) -> float:
        """y of the top edge, pixels (y grows upward)"""
        return self._upward[3]

    @property
    def width(self) -> float:
        """right - left, pixels"""
        return self.right - self.left

    @property
    def height(self) -> float:
        """upper - lower, pixels"""
        return self.upper - self.lower

    @property
    def horizontal_center(self) -> float:
        """(left + right) / 2, pixels"""
        return (self.left + self.right) / 2.0

    @property
    def vertical_center(self) -> float:
        """(lower + upper) / 2, pixels; larger is higher in the image"""
        return (self.lower + self.upper) / 2.0

    @property
    def area(self) -> float:
        """width * height, square pixels"""
        return self.width * self.height

    # ---- methods (for programs) --------------------------------------------------------------------
    def find(self, object_name: str) -> list[ImagePatch]:
        """Returns a list of ImagePatch objects, one per `object_name` found inside this patch, best match
        first; an empty list when there is none. Their coordinates are in the whole image.

        >>> # return the leftmost cup
        >>> def execute_command(image, robot):
        >>>     cup_patches = image.find("cup")
        >>>     cup_patches.sort(key=lambda cup: cup.horizontal_center)
        >>>     return cup_patches[0]

        >>> # return the second apple from the top
        >>> def execute_command(image, robot):
        >>>     apple_patches = image.find("apple")
        >>>     apple_patches.sort(key=lambda apple: apple.vertical_center, reverse=True)
        >>>     return apple_patches[1]

        >>> # return the tallest bottle
        >>> def execute_command(image, robot):
        >>>     bottle_patches = image.find("bottle")
        >>>     return max(bottle_patches, key=lambda bottle: bottle.height)

        >>> # return the window in the middle of the bottom row
        >>> def execute_command(image, robot):
        >>>     windows = image.find("window")
        >>>     lowest = min(w.vertical_center for w in windows)
        >>>     bottom_row = [w for w in windows if abs(w.vertical_center - lowest) < w.height / 2]
        >>>     bottom_row.sort(key=lambda w: w.horizontal_center)
        >>>     return bottom_row[len(bottom_row) // 2]
        """
        return find_in(self, object_name)

    def exists(self, object_name: str) -> bool:
        """Returns True if an object called `object_name` is found inside this patch, else False.

        >>> # are there both forks and knives on the table?
        >>> def execute_command(image, robot):
        >>>     return image.exists("fork") and image.exists("knife")
        """
        check_text(object_name, "object_name", "exists", "detector")
        return len(self.find(object_name)) > 0

    def visual_query(self, question: str = "What is this?") -> str:
        """Returns the answer of a visual question-answering model to a question about this patch's pixels
        (with no question: what is this?). Use it for what can be seen: what something is, its colour, its
        material, what is in the image.

        >>> # return the red mug
        >>> def execute_command(image, robot):
        >>>     for mug in image.find("mug"):
        >>>         if mug.visual_query("What color is this?") == "red":
        >>>             return mug
        >>>     return image

        >>> # what items are in the image?
        >>> def execute_command(image, robot):
        >>>     return image.visual_query("What are the items in this image?")
        """
        q = check_text(question, "question", "visual_query", "vqa")
        vqa = self.perception.vqa
        return self.safeguards.look_again.answer(
            lambda frame: _answer(vqa.answer(frame, q), vqa.name), self._crop_frame(), q
        )

    def language_query(self, question: str) -> str:
        """Returns a language model's answer to a text question: commonsense and factual knowledge (which
        object is usually heavier, what a thing is used for). It does not see the image: put what you
        learnt from visual_query into the question.

        >>> # return the heaviest item, judging from what the items are
        >>> def execute_command(image, robot):
        >>>     names = image.visual_query("What are the items in this image?")
        >>>     question = "Out of these items: " + names + ", which one is usually the heaviest?"
        >>>     heaviest = image.language_query(question + " Answer with its name only.")
        >>>     patches = image.find(heaviest)
        >>>     return patches[0] if patches else image
        """
        q = check_text(question, "question", "language_query", "language")
        return _answer(self.perception.language.complete(q), self.perception.language.name)

    def crop(self, left: float, lower: float, right: float, upper: float) -> ImagePatch:
        """Returns a new ImagePatch of the part of this patch inside the given box, given in whole-image
        coordinates with y growing upward like the attributes. Use it to look only at a region.

        >>> # is there a book on the top half of the shelf?
        >>> def execute_command(image, robot):
        >>>     shelf = image.find("shelf")[0]
        >>>     top_half = shelf.crop(shelf.left, shelf.vertical_center, shelf.right, shelf.upper)
        >>>     return top_half.exists("book")
        """
        return crop_of(self, left, lower, right, upper)

    def overlaps(self, other: ImagePatch) -> bool:
        """Returns True if this patch and `other` share some area (touching edges do not count).

        >>> # return the plate that has an apple on it
        >>> def execute_command(image, robot):
        >>>     apples = image.find("apple")
        >>>     for plate in image.find("plate"):
        >>>         if any(plate.overlaps(apple) for apple in apples):
        >>>             return plate
        >>>     return image
        """
        o = check_patch(other, ImagePatch, "other", "overlaps")
        return min(self.right, o.right) > max(self.left, o.left) and min(self.upper, o.upper) > max(
            self.lower, o.lower
        )

    def distance_to(self, other: ImagePatch) -> float:
        """Returns the distance in pixels between the centres of this patch and `other` (in the image, not
        in the world: use robot.measure_distance for metres).

        >>> # return the cup closest to the laptop in the image
        >>> def execute_command(image, robot):
        >>>     laptop = image.find("laptop")[0]
        >>>     return min(image.find("cup"), key=lambda cup: cup.distance_to(laptop))
        """
        o = check_patch(other, ImagePatch, "other", "distance_to")
        return math.hypot(
            self.horizontal_center - o.horizontal_center, self.vertical_center - o.vertical_center
        )

    def size_at(self, distance: float) -> tuple[float, float]:
        """Returns the (width, height) in metres of what this patch shows when it is `distance` metres from
        the camera (its pixels times the distance over the camera's focal length); a still image file has
        no camera model and raises.

        >>> # how tall is the vase, in metres
        >>> def execute_command(image, robot):
        >>>     vase = image.find("vase")[0]
        >>>     robot.focus_on_patch(vase)
        >>>     return vase.size_at(robot.measure_distance(vase))[1]
        """
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


check_facade(ImagePatch, dict(vars(ImagePatch)))  # the facade programs see, checked as it is defined


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


def _answer(value: object, backend: str) -> str:
    if not isinstance(value, str):
        raise BackendError(
            f"the backend {backend!r} answered a {type(value).__name__}, not text",
            "fix the backend: answer() and complete() must return str",
        )
    return value

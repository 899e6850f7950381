"""`ImagePatch`: the perception half of the API that programs see (after the paper and ViperGPT).

The class docstring and the docstrings of the names in `API_ATTRIBUTES` / `API_METHODS` are written for
the LLM: `attribot.api.prompt` renders them, with the signatures, into the prompt. Everything else here
is for the host (the runner and the integrator) and never reaches a program.
"""

from __future__ import annotations

import math
from typing import ClassVar

from attribot.boxes import from_upward
from attribot.errors import BackendError
from attribot.skills.checks import check_facade, check_number, check_patch, check_text
from attribot.skills.errors import ApiArgumentError
from attribot.skills.sighting import EDGE_TOL, Sighting

__all__ = ["ImagePatch"]


class ImagePatch(Sighting):
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
        "best_box",
    )
    PROGRAM_CONSTRUCTOR: ClassVar[str] = "from_program"
    """What `ImagePatch(...)` in a program calls on the image it was given (the paper's dialect)."""

    # ---- host side ---------------------------------------------------------------------------------
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
        return _from_program(self, image, left, lower, right, upper)

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
        return super().find(object_name)

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
        return _crop_of(self, left, lower, right, upper)

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
        return super().size_at(distance)


check_facade(ImagePatch, dict(vars(ImagePatch)))  # the facade programs see, checked as it is defined


def _answer(value: object, backend: str) -> str:
    if not isinstance(value, str):
        raise BackendError(
            f"the backend {backend!r} answered a {type(value).__name__}, not text",
            "fix the backend: answer() and complete() must return str",
        )
    return value


def _crop_of(patch: ImagePatch, left: float, lower: float, right: float, upper: float) -> ImagePatch:
    """`patch.crop(left, lower, right, upper)`: the part of `patch` inside the box (y growing upward)."""
    values = [
        check_number(v, n, "crop")
        for v, n in zip((left, lower, right, upper), ("left", "lower", "right", "upper"), strict=True)
    ]
    left, lower, right, upper = values
    w, h = patch.frame.width, patch.frame.height
    if right <= left or upper <= lower:
        raise ApiArgumentError(
            f"crop({left:g}, {lower:g}, {right:g}, {upper:g}) is empty: "
            "it needs right > left and upper > lower",
            "pass (left, lower, right, upper) with y growing upward, "
            "e.g. patch.crop(patch.left, patch.lower, "
            "patch.right, patch.vertical_center)",
        )
    if left < -EDGE_TOL or lower < -EDGE_TOL or right > w + EDGE_TOL or upper > h + EDGE_TOL:
        raise ApiArgumentError(
            f"crop({left:g}, {lower:g}, {right:g}, {upper:g}) reaches outside the image, which spans "
            f"left=0, lower=0, right={w}, upper={h}",
            "keep the box inside the image (use max/min with 0, image.right, image.upper)",
        )
    il, ilo = max(left, patch.left), max(lower, patch.lower)
    ir, iu = min(right, patch.right), min(upper, patch.upper)
    if ir <= il or iu <= ilo:
        raise ApiArgumentError(
            f"crop({left:g}, {lower:g}, {right:g}, {upper:g}) does not overlap this patch "
            f"({patch.left:g}, "
            f"{patch.lower:g}, {patch.right:g}, {patch.upper:g})",
            "crop a region inside the patch, or crop the whole image instead",
        )
    part = type(patch)(patch.frame, patch.perception, from_upward(il, ilo, ir, iu, h), capture=patch.capture)
    part.safeguards = patch.safeguards
    return part


def _from_program(
    patch: ImagePatch,
    image: object = None,
    left: float | None = None,
    lower: float | None = None,
    right: float | None = None,
    upper: float | None = None,
) -> ImagePatch:
    """`ImagePatch(image)` written in a program (`ImagePatch.from_program`)."""
    if not isinstance(image, type(patch)):
        raise ApiArgumentError(
            f"ImagePatch(...) takes the image given to execute_command, not {_kind_of(image)}",
            "write image_patch = ImagePatch(image), or use the image argument directly",
        )
    box = (left, lower, right, upper)
    if all(v is None for v in box):
        return image
    if any(v is None for v in box):
        raise ApiArgumentError(
            "ImagePatch(image, left, lower, right, upper) needs all four coordinates",
            "give all four (y growing upward), or call image.crop(left, lower, right, upper)",
        )
    return image.crop(left, lower, right, upper)  # type: ignore[arg-type]


def _kind_of(value: object) -> str:
    """What a wrong argument is, as an error names it."""
    return "nothing" if value is None else f"a {type(value).__name__}"

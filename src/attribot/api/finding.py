"""The host side of `ImagePatch`'s queries: what `find` does (the detector, looking again, looking harder,
the found patches in whole-image pixels), what `crop` and a program's `ImagePatch(...)` make, and what a
controller is given to act on a patch. `attribot.api.patch.ImagePatch` is the facade programs see.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from attribot.api.checks import check_number, check_text
from attribot.api.errors import ApiArgumentError
from attribot.api.harder import acting_find
from attribot.boxes import from_upward
from attribot.control.base import Target
from attribot.errors import BackendError
from attribot.frame import Frame
from attribot.models.base import Detection, evidence_of

if TYPE_CHECKING:
    from attribot.api.patch import ImagePatch

__all__ = ["find_in", "crop_of", "patch_from_program", "target_of"]

EDGE_TOL = 1e-6  # pixels: boxes may touch the image border, not cross it


def find_in(patch: ImagePatch, object_name: str) -> list[ImagePatch]:
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
    found: list[ImagePatch] = []
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


def crop_of(patch: ImagePatch, left: float, lower: float, right: float, upper: float) -> ImagePatch:
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


def patch_from_program(
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
            f"ImagePatch(...) takes the image given to execute_command, not {kind_of(image)}",
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


def target_of(patch: ImagePatch) -> Target | None:
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


def kind_of(value: object) -> str:
    """What a wrong argument is, as an error names it."""
    return "nothing" if value is None else f"a {type(value).__name__}"

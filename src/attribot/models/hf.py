"""transformers backends: OWLv2 and Grounding DINO detection, BLIP-2 visual question answering.

Spec `hf:MODEL_ID_OR_PATH` for the detector and VQA roles; the model family comes from the model's own
config (`model_type`). Processors and models are called directly, not through pipelines: the
`zero-shot-object-detection` pipeline runs one forward pass per label, and transformers v5 has no VQA
pipeline at all. Everything that imports torch or transformers happens inside functions, so importing
this module (which the backend registries do) stays cheap and works without the `models` extra.

What the raw models leave to us, and this module does:
- OWLv2 pads every image to a square (bottom and right) before resizing, so its normalised boxes are
  relative to the square side and can fall outside the image: boxes are scaled by the longer side and
  clipped to the image. Its text-query output has no non-maximum suppression: we apply it per label.
- Grounding DINO scores boxes against text *tokens*; transformers' post-processing decodes the tokens
  above a threshold into phrases, which can merge two labels ("cup bowl") or cut one. We instead map
  each token back to the candidate label whose characters it covers (tokenizer offsets) and score a box
  for a label by its best token, so every label is one of the candidates.
- Batches: many images at once, each with its own list of text queries (padded and masked).
- Size: every image is brought to the model's working size (longest side, aspect ratio kept) before any
  processor sees it, and an extremely thin one is padded (cheaply, after the shrink) to at most
  `MAX_ASPECT` to 1. OWLv2's processor pads a 1x10000 image to a 10000x10000 square and blurs it on the
  CPU (minutes, 11 GB) before shrinking it to 960: shrinking first costs milliseconds. Boxes are mapped
  back to the caller's pixels.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from attribot import boxes as boxmath
from attribot.deps import install_line, require
from attribot.errors import ConfigError, InputError
from attribot.frame import Frame
from attribot.models.base import DETECTORS, UNKNOWN, VQAS, Detection, off_own_body

if TYPE_CHECKING:
    from attribot.config import Settings

__all__ = [
    "DETECTOR_FAMILIES",
    "VQA_FAMILIES",
    "HFDetector",
    "HFVisualQA",
    "LoadedModel",
    "resolve_device",
    "resolve_dtype",
    "model_family",
    "probe_hf",
    "build_hf_detector",
    "build_hf_vqa",
    "MAX_ASPECT",
    "working_side",
    "to_working_size",
]

DETECTOR_FAMILIES = ("owlv2", "grounding-dino")
"""`model_type` values of the detectors this backend runs."""
VQA_FAMILIES = ("blip-2",)
"""`model_type` values of the VQA models this backend runs."""

MAX_ASPECT = 8
"""Longest side over shortest side of what a model is shown; thinner images are padded with grey."""

_PURPOSE = "the hf: (transformers) backends"
_EXAMPLES = {
    "detector": "hf:google/owlv2-base-patch16-ensemble or hf:IDEA-Research/grounding-dino-tiny",
    "vqa": "hf:Salesforce/blip2-opt-2.7b",
}
_DTYPES = {
    "float32": "float32",
    "fp32": "float32",
    "float16": "float16",
    "fp16": "float16",
    "half": "float16",
    "bfloat16": "bfloat16",
    "bf16": "bfloat16",
}


def _torch() -> Any:
    require("transformers", _PURPOSE)
    return require("torch", _PURPOSE)


def resolve_device(name: str) -> str:
    """`auto` -> `cuda` when torch sees a GPU, else `cpu`; `cpu`, `cuda`, `cuda:N` are checked."""
    torch = _torch()
    text = name.strip().lower()
    if text == "auto":
        return "cuda" if torch.cuda.is_available() else "cpu"
    if text == "cpu":
        return "cpu"
    if text == "cuda" or text.startswith("cuda:"):
        if not torch.cuda.is_available():
            raise ConfigError(
                f"hf_device is {name!r} but torch sees no CUDA GPU",
                "set ATTRIBOT_HF_DEVICE=auto or cpu, or install a CUDA build of torch",
            )
        return text
    raise ConfigError(f"hf_device {name!r} is not a device", "use auto, cpu, cuda or cuda:N")


def resolve_dtype(name: str, device: str) -> Any:
    """The torch dtype for `name`; `auto` is float16 on a GPU (what the speed figures use), else float32."""
    torch = _torch()
    text = name.strip().lower()
    if text == "auto":
        return torch.float16 if device.startswith("cuda") else torch.float32
    if text not in _DTYPES:
        raise ConfigError(f"hf_dtype {name!r} is not a dtype", "use auto, float32, float16 or bfloat16")
    return getattr(torch, _DTYPES[text])


def _looks_like_path(model: str) -> bool:
    return model.startswith(("/", "./", "../", "~")) or Path(model).expanduser().exists()


def model_family(model: str) -> str:
    """The `model_type` in the config of `model` (a local folder or a hub id)."""
    transformers = require("transformers", _PURPOSE)
    if _looks_like_path(model):
        folder = Path(model).expanduser()
        if not (folder / "config.json").is_file():
            raise ConfigError(
                f"model folder {str(folder)!r} does not exist or has no config.json",
                "give a folder saved with save_pretrained (model and processor), or a hub model id",
            )
        model = str(folder)
    try:
        config = transformers.AutoConfig.from_pretrained(model)
    except (OSError, ValueError) as exc:
        raise ConfigError(
            f"cannot read the model config of {model!r}: {str(exc).splitlines()[0][:200]}",
            "check the model id or path; a hub id downloads once, then loads from the cache",
        ) from exc
    return str(config.model_type)


@dataclass(frozen=True)
class LoadedModel:
    """A transformers model and its processor in memory, with where it runs and what the answers call it."""

    processor: Any
    model: Any
    device: str
    dtype: Any
    family: str  # the config's model_type
    name: str  # "hf:MODEL" as the answers name the backend

    @classmethod
    def of(cls, model: Any, processor: Any, name: str) -> LoadedModel:
        """A model already in memory, on its own device and dtype, in eval mode."""
        param = next(model.parameters())
        return cls(
            processor, model.eval(), str(param.device), param.dtype, str(model.config.model_type), name
        )


def _load(model: str, family: str, model_class: str, device: str, dtype: str) -> LoadedModel:
    """`model` (hub id or folder) with its processor, on `device` in `dtype`."""
    transformers = require("transformers", _PURPOSE)
    cls = getattr(transformers, model_class, None)
    if cls is None:
        raise ConfigError(
            f"this transformers ({transformers.__version__}) has no {model_class} for {family} models",
            "pip install -U -e '.[models]' in the attribot clone",
        )
    dev = resolve_device(device)
    dt = resolve_dtype(dtype, dev)
    path = str(Path(model).expanduser()) if _looks_like_path(model) else model
    try:
        processor = transformers.AutoProcessor.from_pretrained(path)
        net = cls.from_pretrained(path)
    except (OSError, ValueError) as exc:
        raise ConfigError(
            f"cannot load {family} model {model!r}: {str(exc).splitlines()[0][:200]}",
            "the folder needs the model and its processor (save_pretrained of both)",
        ) from exc
    net = net.to(device=dev, dtype=dt).eval()
    return LoadedModel(processor, net, dev, dt, family, f"hf:{model}")


def _load_detector(model: str, device: str, dtype: str) -> LoadedModel:
    family = model_family(model)
    _check_family(
        family,
        DETECTOR_FAMILIES,
        model,
        "a detector",
        f"an OWLv2 or Grounding DINO model, e.g. {_EXAMPLES['detector']}",
    )
    model_class = "Owlv2ForObjectDetection" if family == "owlv2" else "AutoModelForZeroShotObjectDetection"
    return _load(model, family, model_class, device, dtype)


def _check_options(threshold: float, nms_iou: float) -> None:
    if not 0.0 <= threshold <= 1.0:
        raise ConfigError(
            f"detector threshold {threshold} is outside [0, 1]", "set detector_threshold, e.g. 0.1"
        )
    if not 0.0 < nms_iou <= 1.0:
        raise ConfigError(f"NMS IoU {nms_iou} is outside (0, 1]", "use e.g. 0.5")


def _check_family(family: str, allowed: tuple[str, ...], model: str, role: str, example: str) -> None:
    if family not in allowed:
        raise ConfigError(
            f"model {model!r} is a {family!r} model, not {role} model this backend runs", f"use {example}"
        )


def _device_preprocessing(image_processor: Any, device: str) -> bool:
    """True for image processors built on torchvision (v5 `TorchvisionBackend`, v4 `*Fast`), which take
    a `device` argument; the PIL/numpy ones run on the CPU whatever we ask."""
    if not device.startswith("cuda"):
        return False
    names = {c.__name__ for c in type(image_processor).__mro__}
    return bool(names & {"TorchvisionBackend", "BaseImageProcessorFast"})


def _clean_queries(queries: Sequence[str]) -> list[str]:
    """Stripped, de-duplicated (order kept) noun phrases; an empty one is an input error."""
    if isinstance(queries, str):
        raise InputError("detector queries must be a list of strings, got one string", f"pass [{queries!r}]")
    out: list[str] = []
    for q in queries:
        if not isinstance(q, str) or not q.strip():
            raise InputError(f"detector query {q!r} is empty or not a string", "pass non-empty noun phrases")
        text = " ".join(q.split())
        if text not in out:
            out.append(text)
    return out


def working_side(image_processor: Any) -> int:
    """The longest image side `image_processor` works at: the largest number in its `size` (OWLv2
    {"height": 960, "width": 960}, Grounding DINO {"shortest_edge": 800, "longest_edge": 1333})."""
    size = getattr(image_processor, "size", None)
    # a dict in transformers 4, a `SizeDict` (unset fields None) in 5
    values = [size] if size is None or isinstance(size, int | float) else dict(size).values()
    sides = [int(v) for v in values if isinstance(v, int | float) and not isinstance(v, bool) and v > 0]
    if not sides:
        raise ConfigError(
            f"the image processor {type(image_processor).__name__} states no working size",
            "save the model with a processor whose config has a size",
        )
    return max(sides)


def to_working_size(rgb: np.ndarray, side: int) -> tuple[np.ndarray, float]:
    """`rgb` shrunk (never enlarged) so that its longest side is at most `side`, aspect ratio kept, then
    padded bottom and right with grey to at most `MAX_ASPECT` to 1; and the scale (new / old pixels).
    A box in the result's pixels divided by the scale is a box in `rgb`'s pixels."""
    import cv2

    h, w = rgb.shape[:2]
    scale = min(1.0, side / max(h, w))
    if scale < 1.0:
        size = (max(1, round(w * scale)), max(1, round(h * scale)))
        rgb = cv2.resize(rgb, size, interpolation=cv2.INTER_AREA)
    h, w = rgb.shape[:2]
    short = -(-max(h, w) // MAX_ASPECT)  # ceiling
    if min(h, w) < short:
        out = np.full((max(h, short), max(w, short), 3), 128, dtype=np.uint8)
        out[:h, :w] = rgb
        rgb = out
    return np.ascontiguousarray(rgb), scale


def _corners(cxcywh: Any) -> Any:
    cx, cy, w, h = cxcywh.unbind(-1)
    return _torch().stack([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2], dim=-1)


class HFDetector:
    """Zero-shot detection with OWLv2 or Grounding DINO through transformers.

    `detect(frame, queries)` gives the boxes of all `queries` in the frame, best score first;
    `detect_batch(frames, queries)` does many frames (each with its own queries) in batched forward
    passes of at most `max_batch` images. Boxes are xyxy pixels of the frame, clipped to it; scores
    are probabilities in [0, 1], at least `threshold`; per label, boxes overlapping a better one by more
    than `nms_iou` are dropped.
    """

    def __init__(
        self,
        model: str | LoadedModel,
        *,
        device: str = "auto",
        dtype: str = "auto",
        threshold: float = 0.1,
        nms_iou: float = 0.5,
        max_detections: int = 100,
        max_batch: int = 32,
    ) -> None:
        """`model`: a hub id or folder, loaded here on `device` in `dtype`; or a `LoadedModel` (see
        `from_loaded`), used as it is."""
        _check_options(threshold, nms_iou)
        loaded = model if isinstance(model, LoadedModel) else _load_detector(model, device, dtype)
        _check_family(
            loaded.family, DETECTOR_FAMILIES, loaded.name, "a detector", "an OWLv2 or Grounding DINO model"
        )
        self.processor, self.model = loaded.processor, loaded.model
        self.device, self.dtype = loaded.device, loaded.dtype
        self.family = loaded.family
        self.name = loaded.name
        self.pixels_only = True  # its answer is a function of the RGB pixels and the queries
        self.threshold = float(threshold)
        self.nms_iou = float(nms_iou)
        self.max_detections = int(max_detections)
        self.max_batch = max(1, int(max_batch))
        # torchvision-backed image processors can resize and normalise on the GPU
        self._image_kwargs = (
            {"device": self.device}
            if _device_preprocessing(self.processor.image_processor, self.device)
            else {}
        )

    @classmethod
    def from_loaded(
        cls,
        model: Any,
        processor: Any,
        *,
        name: str = "hf:in-memory",
        threshold: float = 0.1,
        nms_iou: float = 0.5,
        max_detections: int = 100,
        max_batch: int = 32,
    ) -> HFDetector:
        """A detector over a model and processor already in memory, on the model's device and dtype
        (benchmarks of real-size random models; a server sharing one model)."""
        return cls(
            LoadedModel.of(model, processor, name),
            threshold=threshold,
            nms_iou=nms_iou,
            max_detections=max_detections,
            max_batch=max_batch,
        )

    # ---- public -----------------------------------------------------------------------------------

    def detect(self, frame: Frame, queries: Sequence[str]) -> list[Detection]:
        """Detections of `queries` in `frame`, best first."""
        return self.detect_batch([frame], [queries])[0]

    def detect_batch(
        self, frames: Sequence[Frame], queries: Sequence[Sequence[str]]
    ) -> list[list[Detection]]:
        """One list of detections per frame; `queries[i]` are the noun phrases looked for in `frames[i]`."""
        if len(frames) != len(queries):
            raise InputError(
                f"detect_batch got {len(frames)} frames and {len(queries)} query lists",
                "pass one list per frame",
            )
        cleaned = [_clean_queries(q) for q in queries]
        results: list[list[Detection]] = [[] for _ in frames]
        todo = [i for i, q in enumerate(cleaned) if q]  # a frame with no query has no detection
        side = working_side(self.processor.image_processor)
        for chunk in self._chunks(frames, todo):
            fitted = [to_working_size(frames[i].rgb, side) for i in chunk]
            rgbs = [rgb for rgb, _ in fitted]
            labels = [cleaned[i] for i in chunk]
            raw = self._run_owl(rgbs, labels) if self.family == "owlv2" else self._run_gdino(rgbs, labels)
            for i, (_, scale), lab, (bx, sc, li) in zip(chunk, fitted, labels, raw, strict=True):
                h, w = frames[i].rgb.shape[:2]
                results[i] = off_own_body(self._finish(bx / scale, sc, li, lab, width=w, height=h), frames[i])
        return results

    def _chunks(self, frames: Sequence[Frame], todo: list[int]) -> list[list[int]]:
        """Batches of at most `max_batch` frame indices. Grounding DINO pads a batch to its largest image
        and its backbone sees the padding, so it batches only frames of one working size: then a batched
        answer equals the one-by-one answer (camera frames share a size, so real batches stay full)."""
        side = working_side(self.processor.image_processor)
        groups: dict[tuple[int, ...], list[int]] = {}
        for i in todo:
            key = _fitted_shape(frames[i].rgb.shape[:2], side) if self.family == "grounding-dino" else ()
            groups.setdefault(key, []).append(i)
        return [g[s : s + self.max_batch] for g in groups.values() for s in range(0, len(g), self.max_batch)]

    # ---- model families ---------------------------------------------------------------------------

    def _run_owl(
        self, rgbs: list[np.ndarray], labels: list[list[str]]
    ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        torch = _torch()
        # What Owlv2Processor does with nested queries, done here so that the image half can run on the
        # GPU: every image gets as many queries as the longest list, padded with " " (masked below)
        width = max(len(lab) for lab in labels)
        texts = [q for lab in labels for q in lab + [" "] * (width - len(lab))]
        enc = self.processor.tokenizer(texts, padding="max_length", truncation=True, return_tensors="pt")
        pixels = self.processor.image_processor(rgbs, return_tensors="pt", **self._image_kwargs)
        with torch.inference_mode():
            out = self.model(
                input_ids=enc["input_ids"].to(self.device),
                attention_mask=enc["attention_mask"].to(self.device),
                pixel_values=pixels["pixel_values"].to(self.device, self.dtype),
            )
            logits = out.logits.float()  # (B, boxes, max queries); short query lists are padded with " "
            n_labels = torch.tensor([len(lab) for lab in labels], device=logits.device)
            pad = torch.arange(logits.shape[-1], device=logits.device)[None, :] >= n_labels[:, None]
            logits = logits.masked_fill(pad[:, None, :], float("-inf"))
            scores, label_idx = logits.sigmoid().max(dim=-1)
            # boxes are normalised to the padded square: scale by each image's longer side
            side = torch.tensor([max(r.shape[:2]) for r in rgbs], dtype=torch.float32, device=logits.device)
            corners = _corners(out.pred_boxes.float()) * side[:, None, None]
        return self._select(corners, scores, label_idx)

    def _run_gdino(
        self, rgbs: list[np.ndarray], labels: list[list[str]]
    ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        torch = _torch()
        tokenizer = self.processor.tokenizer
        texts, spans = [], []
        for lab in labels:  # "a cat. a dog." with the character span of each label
            text, sp = "", []
            for name in lab:
                sp.append((len(text), len(text) + len(name)))
                text += name + ". "
            texts.append(text.strip())
            spans.append(sp)
        max_len = min(
            int(getattr(self.model.config, "max_text_len", 256)), int(tokenizer.model_max_length or 256)
        )
        try:
            enc = tokenizer(
                texts,
                padding="longest",
                truncation=True,
                max_length=max_len,
                return_tensors="pt",
                return_offsets_mapping=True,
            )
        except NotImplementedError as exc:  # slow tokenizers give no offsets
            raise ConfigError(
                "Grounding DINO needs a fast tokenizer (with offsets)",
                "save the model with its tokenizer.json",
            ) from exc
        offsets = enc.pop("offset_mapping").tolist()
        pixels = self.processor.image_processor(rgbs, return_tensors="pt", **self._image_kwargs)
        model_inputs = {k: v.to(self.device) for k, v in enc.items()}
        model_inputs["pixel_values"] = pixels["pixel_values"].to(self.device, self.dtype)
        if "pixel_mask" in pixels:
            model_inputs["pixel_mask"] = pixels["pixel_mask"].to(self.device)
        with torch.inference_mode():
            out = self.model(**model_inputs)
            probs = out.logits.float().sigmoid()  # (B, boxes, text positions), -inf beyond the text
            label_scores = torch.zeros(
                probs.shape[:2] + (max(len(lab) for lab in labels),), device=probs.device
            )
            for b, (sp, offs) in enumerate(zip(spans, offsets, strict=True)):
                for j, tokens in enumerate(_tokens_of_labels(sp, offs, probs.shape[-1])):
                    if tokens:  # a label cut off by truncation keeps score 0
                        label_scores[b, :, j] = probs[b][:, tokens].max(dim=-1).values
            scores, label_idx = label_scores.max(dim=-1)
            wh = torch.tensor(
                [[r.shape[1], r.shape[0]] for r in rgbs], dtype=torch.float32, device=probs.device
            )
            corners = _corners(out.pred_boxes.float()) * wh.repeat(1, 2)[:, None, :]
        return self._select(corners, scores, label_idx)

    # ---- shared post-processing -------------------------------------------------------------------

    def _select(
        self, corners: Any, scores: Any, label_idx: Any
    ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Per image: the boxes scoring at least the threshold, as numpy."""
        out = []
        for c, s, li in zip(corners, scores, label_idx, strict=True):
            keep = s >= self.threshold
            out.append((c[keep].cpu().numpy(), s[keep].cpu().numpy(), li[keep].cpu().numpy()))
        return out

    def _finish(
        self, bx: np.ndarray, sc: np.ndarray, li: np.ndarray, labels: list[str], *, width: int, height: int
    ) -> list[Detection]:
        """Clip to the image, drop boxes left under a pixel wide or high, NMS per label, best first, at
        most `max_detections`."""
        if len(bx) == 0:
            return []
        bx = boxmath.clip(bx.astype(np.float64), width, height)
        sc = np.clip(sc.astype(np.float64), 0.0, 1.0)
        # at least a pixel each way: boxes wholly (or all but a sliver) outside the image before clipping
        solid = (bx[:, 2] - bx[:, 0] >= 1.0) & (bx[:, 3] - bx[:, 1] >= 1.0)
        bx, sc, li = bx[solid], sc[solid], li[solid]
        # per-label NMS in one pass: shifting each label's boxes apart by more than the image keeps
        # labels from suppressing each other, and the pass can stop at `max_detections` (thousands of
        # boxes pass a low threshold: OWLv2 scores every patch)
        shift = (li.astype(np.float64) * (max(width, height) + 1.0))[:, None]
        kept = boxmath.nms(bx + shift, sc, self.nms_iou, max_keep=self.max_detections)
        return [
            Detection(box=tuple(float(v) for v in bx[k]), score=float(sc[k]), label=labels[int(li[k])])
            for k in kept.tolist()
        ]


def _fitted_shape(shape: tuple[int, ...], side: int) -> tuple[int, ...]:
    """The (height, width) `to_working_size` gives an image of `shape`, without touching pixels."""
    h, w = shape[:2]
    scale = min(1.0, side / max(h, w))
    if scale < 1.0:
        h, w = max(1, round(h * scale)), max(1, round(w * scale))
    short = -(-max(h, w) // MAX_ASPECT)
    return max(h, short), max(w, short)


def _tokens_of_labels(spans: list[tuple[int, int]], offsets: list[list[int]], width: int) -> list[list[int]]:
    """For each label's character span, the token positions (< width) whose characters lie inside it."""
    out: list[list[int]] = [[] for _ in spans]
    for t, (s, e) in enumerate(offsets[:width]):
        if e <= s:  # special and padding tokens
            continue
        for j, (a, b) in enumerate(spans):
            if s >= a and e <= b:
                out[j].append(t)
                break
    return out


class HFVisualQA:
    """Visual question answering with BLIP-2 through `generate` (prompt "Question: ... Answer:").

    `answer_batch` runs many (frame, question) pairs in batched `generate` calls of at most `max_batch`,
    left-padded so that every answer continues its own prompt; the prompt is cut off the output.
    """

    def __init__(
        self,
        model: str | LoadedModel,
        *,
        device: str = "auto",
        dtype: str = "auto",
        max_new_tokens: int = 10,
        max_batch: int = 32,
    ) -> None:
        """`model`: a hub id or folder, loaded here on `device` in `dtype`; or a `LoadedModel`."""
        if isinstance(model, LoadedModel):
            loaded = model
        else:
            family = model_family(model)
            _check_family(family, VQA_FAMILIES, model, "a VQA", f"a BLIP-2 model, e.g. {_EXAMPLES['vqa']}")
            loaded = _load(model, family, "Blip2ForConditionalGeneration", device, dtype)
        _check_family(loaded.family, VQA_FAMILIES, loaded.name, "a VQA", "a BLIP-2 model")
        self.processor, self.model = loaded.processor, loaded.model
        self.device, self.dtype = loaded.device, loaded.dtype
        # decoder-only language models continue the last token: pad on the left
        self.processor.tokenizer.padding_side = "left"
        self.name = loaded.name
        self.max_new_tokens = int(max_new_tokens)
        self.max_batch = max(1, int(max_batch))

    @classmethod
    def from_loaded(
        cls,
        model: Any,
        processor: Any,
        *,
        name: str = "hf:in-memory",
        max_new_tokens: int = 10,
        max_batch: int = 32,
    ) -> HFVisualQA:
        """VQA over a BLIP-2 model and processor already in memory, on the model's device and dtype."""
        return cls(LoadedModel.of(model, processor, name), max_new_tokens=max_new_tokens, max_batch=max_batch)

    def answer(self, frame: Frame, question: str) -> str:
        """A short answer to `question` about `frame`, `UNKNOWN` when the model says nothing."""
        return self.answer_batch([frame], [question])[0]

    def answer_batch(self, frames: Sequence[Frame], questions: Sequence[str]) -> list[str]:
        """One answer per (frame, question) pair."""
        if len(frames) != len(questions):
            raise InputError(
                f"answer_batch got {len(frames)} frames and {len(questions)} questions",
                "pass one question per frame",
            )
        prompts = []
        for q in questions:
            if not isinstance(q, str) or not q.strip():
                raise InputError(f"question {q!r} is empty or not a string", "ask a question in words")
            prompts.append(f"Question: {' '.join(q.split())} Answer:")
        side = working_side(self.processor.image_processor)
        answers: list[str] = []
        for start in range(0, len(prompts), self.max_batch):
            chunk = slice(start, start + self.max_batch)
            rgbs = [to_working_size(f.rgb, side)[0] for f in frames[chunk]]
            answers.extend(self._generate(rgbs, prompts[chunk]))
        return answers

    def _generate(self, rgbs: list[np.ndarray], prompts: list[str]) -> list[str]:
        torch = _torch()
        inputs = self.processor(images=rgbs, text=prompts, return_tensors="pt", padding=True)
        inputs = {
            k: (v.to(self.device, self.dtype) if k == "pixel_values" else v.to(self.device))
            for k, v in inputs.items()
        }
        with torch.inference_mode():
            out = self.model.generate(
                **inputs, max_new_tokens=self.max_new_tokens, do_sample=False, num_beams=1
            )
        new = _strip_prompt(out, inputs["input_ids"])
        texts = self.processor.batch_decode(new, skip_special_tokens=True)
        return [_clean_answer(t) for t in texts]


def _strip_prompt(out: Any, input_ids: Any) -> Any:
    """The generated tokens alone: recent transformers return prompt + answer, older ones the answer."""
    n = input_ids.shape[1]
    if out.shape[1] >= n and bool((out[:, :n] == input_ids.to(out.device)).all()):
        return out[:, n:]
    return out


def _clean_answer(text: str) -> str:
    lines = text.strip().splitlines()
    answer = lines[0].strip() if lines else ""
    return answer or UNKNOWN


# ---- registration and probing ------------------------------------------------------------------------


def probe_hf(arg: str | None, settings: Settings) -> tuple[bool | None, str]:
    """Whether an `hf:` backend can load here, without importing torch: extra installed, model present."""
    missing = [m for m in ("torch", "transformers") if importlib.util.find_spec(m) is None]
    if missing:
        return False, f"{', '.join(missing)} not installed: {install_line('models')}"
    if not arg:
        return False, "no model given: write hf:MODEL_ID_OR_PATH"
    if _looks_like_path(arg):
        folder = Path(arg).expanduser()
        if (folder / "config.json").is_file():
            return True, f"local model folder {folder}"
        return False, f"model folder {folder} does not exist or has no config.json"
    try:
        from huggingface_hub import try_to_load_from_cache

        cached = try_to_load_from_cache(arg, "config.json")
    except Exception:  # noqa: BLE001 - a malformed id or an old hub library: say we cannot tell
        cached = None
    if isinstance(cached, str):
        return True, f"hub model {arg} is in the local cache"
    return None, f"hub model {arg} is not in the local cache: downloaded on first use (needs network)"


def build_hf_detector(arg: str | None, settings: Settings) -> HFDetector:
    """`hf:MODEL` detector from the settings' device, dtype and threshold."""
    if not arg:
        raise ConfigError("the hf detector needs a model", f"write e.g. {_EXAMPLES['detector']}")
    return HFDetector(
        arg, device=settings.hf_device, dtype=settings.hf_dtype, threshold=settings.detector_threshold
    )


def build_hf_vqa(arg: str | None, settings: Settings) -> HFVisualQA:
    """`hf:MODEL` VQA (BLIP-2) from the settings' device and dtype."""
    if not arg:
        raise ConfigError("the hf VQA backend needs a model", f"write e.g. {_EXAMPLES['vqa']}")
    return HFVisualQA(arg, device=settings.hf_device, dtype=settings.hf_dtype)


build_hf_detector.probe = probe_hf  # type: ignore[attr-defined]
build_hf_vqa.probe = probe_hf  # type: ignore[attr-defined]
DETECTORS.register("hf")(build_hf_detector)
VQAS.register("hf")(build_hf_vqa)

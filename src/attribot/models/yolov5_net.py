"""YOLOv5s v6.1 in our own torch modules, read from Ultralytics' checkpoint without running its code.

The network is built here from the structure of Ultralytics' `models/yolov5s.yaml` (v6.1: depth 0.33,
width 0.50, a 6x6 stem, SPPF), written as code: `Conv` (convolution, batch norm, SiLU), `Bottleneck`, `C3`,
`SPPF`, `Concat`, `nn.Upsample` and `Detect` (one 1x1 convolution per stride, 8, 16 and 32, three anchors
each). A checkpoint is a torch pickle of Ultralytics' module objects; it is untrusted input, so
`read_checkpoint` unpickles it with `RestrictedUnpickler`, whose `find_class` answers only the globals a
YOLOv5 checkpoint names, each with an inert stand-in (a record of the pickled attributes, never the class
itself), and refuses every other global. `load_state` then takes the tensors out of the stand-ins by name
and copies them into a network built here; nothing of the checkpoint but its tensors, class names, anchors
and strides reaches our code.

`forward` returns each stride's raw output map; `attribot.models.yolov5.decode` (numpy, shared by the ONNX
and the torch paths) turns them into boxes. This module needs torch (`attribot[models]`); the detector itself
runs the exported ONNX graph with onnxruntime and imports this module only to export it, or to run it on a
CUDA device.
"""

from __future__ import annotations

import io
import pickle
import warnings
import zipfile
from collections import OrderedDict
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import torch
from torch import nn

from attribot.errors import ConfigError
from attribot.models.yolov5 import STRIDES

__all__ = [
    "ANCHORS",
    "Conv",
    "Bottleneck",
    "C3",
    "SPPF",
    "Concat",
    "Detect",
    "YoloV5",
    "RestrictedUnpickler",
    "Checkpoint",
    "read_checkpoint",
    "load_state",
    "export_onnx",
]

ANCHORS = ((10, 13, 16, 30, 33, 23), (30, 61, 62, 45, 59, 119), (116, 90, 156, 198, 373, 326))
"""v6.1's anchors in input pixels (w, h pairs), three per stride."""


class Conv(nn.Module):
    """Convolution (no bias, 'same' padding), batch norm (eps 1e-3), SiLU."""

    def __init__(self, c1: int, c2: int, k: int = 1, s: int = 1, p: int | None = None) -> None:
        super().__init__()
        self.conv = nn.Conv2d(c1, c2, k, s, k // 2 if p is None else p, bias=False)
        self.bn = nn.BatchNorm2d(c2, eps=1e-3, momentum=0.03)
        self.act = nn.SiLU()

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.act(self.bn(self.conv(x)))


class Bottleneck(nn.Module):
    """1x1 then 3x3 convolution, added to its input when `shortcut` (and the widths agree)."""

    def __init__(self, c1: int, c2: int, shortcut: bool = True) -> None:
        super().__init__()
        self.cv1 = Conv(c1, c2, 1, 1)
        self.cv2 = Conv(c2, c2, 3, 1)
        self.add = shortcut and c1 == c2

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        y = self.cv2(self.cv1(x))
        return x + y if self.add else y


class C3(nn.Module):
    """CSP block: `n` bottlenecks on half the channels, concatenated with a 1x1 branch, then a 1x1 mix."""

    def __init__(self, c1: int, c2: int, n: int = 1, shortcut: bool = True) -> None:
        super().__init__()
        c_ = c2 // 2
        self.cv1 = Conv(c1, c_, 1, 1)
        self.cv2 = Conv(c1, c_, 1, 1)
        self.cv3 = Conv(2 * c_, c2, 1)
        self.m = nn.Sequential(*(Bottleneck(c_, c_, shortcut) for _ in range(n)))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.cv3(torch.cat((self.m(self.cv1(x)), self.cv2(x)), 1))


class SPPF(nn.Module):
    """Spatial pyramid pooling, fast: three chained 5x5 max pools, concatenated with their input."""

    def __init__(self, c1: int, c2: int, k: int = 5) -> None:
        super().__init__()
        c_ = c1 // 2
        self.cv1 = Conv(c1, c_, 1, 1)
        self.cv2 = Conv(c_ * 4, c2, 1, 1)
        self.m = nn.MaxPool2d(kernel_size=k, stride=1, padding=k // 2)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = self.cv1(x)
        y1 = self.m(x)
        y2 = self.m(y1)
        return self.cv2(torch.cat((x, y1, y2, self.m(y2)), 1))


class Concat(nn.Module):
    """Concatenation of its inputs along channels."""

    def forward(self, xs: list[torch.Tensor]) -> torch.Tensor:
        return torch.cat(xs, 1)


class Detect(nn.Module):
    """One 1x1 convolution per stride to 3 anchors x (4 box + 1 objectness + classes); `anchors` (a buffer,
    in grid cells of each stride, as Ultralytics keeps it) come from the checkpoint."""

    anchors: torch.Tensor

    def __init__(self, classes: int, channels: tuple[int, ...]) -> None:
        super().__init__()
        self.no = classes + 5
        self.na = len(ANCHORS[0]) // 2
        self.m = nn.ModuleList(nn.Conv2d(c, self.no * self.na, 1) for c in channels)
        grid = torch.tensor(ANCHORS, dtype=torch.float32).view(len(STRIDES), -1, 2)
        self.register_buffer("anchors", grid / torch.tensor(STRIDES, dtype=torch.float32).view(-1, 1, 1))

    def forward(self, xs: list[torch.Tensor]) -> list[torch.Tensor]:
        return [conv(x) for conv, x in zip(self.m, xs, strict=True)]


# v6.1 yolov5s.yaml, with depth 0.33 and width 0.50 applied: (inputs, module factory) per layer
def _layers(classes: int) -> list[tuple[int | tuple[int, ...], nn.Module]]:
    up = lambda: nn.Upsample(scale_factor=2.0, mode="nearest")  # noqa: E731
    return [
        (-1, Conv(3, 32, 6, 2, 2)),  # 0 P1/2
        (-1, Conv(32, 64, 3, 2)),  # 1 P2/4
        (-1, C3(64, 64, 1)),
        (-1, Conv(64, 128, 3, 2)),  # 3 P3/8
        (-1, C3(128, 128, 2)),
        (-1, Conv(128, 256, 3, 2)),  # 5 P4/16
        (-1, C3(256, 256, 3)),
        (-1, Conv(256, 512, 3, 2)),  # 7 P5/32
        (-1, C3(512, 512, 1)),
        (-1, SPPF(512, 512, 5)),  # 9
        (-1, Conv(512, 256, 1, 1)),  # 10
        (-1, up()),
        ((-1, 6), Concat()),
        (-1, C3(512, 256, 1, False)),  # 13
        (-1, Conv(256, 128, 1, 1)),  # 14
        (-1, up()),
        ((-1, 4), Concat()),
        (-1, C3(256, 128, 1, False)),  # 17 (P3/8 out)
        (-1, Conv(128, 128, 3, 2)),
        ((-1, 14), Concat()),
        (-1, C3(256, 256, 1, False)),  # 20 (P4/16 out)
        (-1, Conv(256, 256, 3, 2)),
        ((-1, 10), Concat()),
        (-1, C3(512, 512, 1, False)),  # 23 (P5/32 out)
        ((17, 20, 23), Detect(classes, (128, 256, 512))),  # 24
    ]


class YoloV5(nn.Module):
    """YOLOv5s v6.1. `forward(images)` takes (N, 3, H, W) floats in [0, 1], RGB, H and W multiples of 32, and
    returns each stride's raw map (N, 3 * (5 + classes), H / stride, W / stride)."""

    def __init__(self, classes: int = 80) -> None:
        super().__init__()
        layers = _layers(classes)
        self.sources = [src for src, _ in layers]
        self.model = nn.Sequential(*(m for _, m in layers))
        self.saved = {i for src in self.sources if isinstance(src, tuple) for i in src if i >= 0}
        self.classes = classes

    def forward(self, x: torch.Tensor) -> list[torch.Tensor]:
        outs: dict[int, torch.Tensor] = {}
        y: Any = x
        for i, (src, module) in enumerate(zip(self.sources, self.model, strict=True)):
            if isinstance(src, tuple):
                y = module([y if j == -1 else outs[j] for j in src])
            else:
                y = module(y)
            if i in self.saved:
                outs[i] = y
        return y

    @property
    def detect(self) -> Detect:
        return self.model[-1]  # type: ignore[return-value]


# ---- the checkpoint: restricted unpickling ------------------------------------------------------------


class _StandIn:
    """What a pickled module object becomes: its class's path and its pickled attributes, nothing run."""

    source = "?"
    state: dict[str, Any] = {}  # noqa: RUF012 - read only; an object pickled with no state keeps this

    def __setstate__(self, state: Any) -> None:
        self.state = state if isinstance(state, dict) else {"_state": state}

    def __repr__(self) -> str:
        return f"<stand-in for {self.source}>"


_MODULE_CLASSES = {
    "models.yolo": ("Model", "Detect"),
    "models.common": ("Conv", "Bottleneck", "C3", "SPPF", "Concat"),
    "torch.nn.modules.conv": ("Conv2d",),
    "torch.nn.modules.batchnorm": ("BatchNorm2d",),
    "torch.nn.modules.activation": ("SiLU",),
    "torch.nn.modules.container": ("Sequential", "ModuleList"),
    "torch.nn.modules.pooling": ("MaxPool2d",),
    "torch.nn.modules.upsampling": ("Upsample",),
}
_STAND_INS: dict[tuple[str, str], type] = {
    (mod, name): type(name, (_StandIn,), {"source": f"{mod}.{name}"})
    for mod, names in _MODULE_CLASSES.items()
    for name in names
}
_DTYPES = {
    "FloatStorage": torch.float32,
    "HalfStorage": torch.float16,
    "DoubleStorage": torch.float64,
    "LongStorage": torch.int64,
    "IntStorage": torch.int32,
    "BFloat16Storage": torch.bfloat16,
}


class _Storage:
    def __init__(self, dtype: torch.dtype) -> None:
        self.dtype = dtype


def _rebuild_tensor(
    storage: torch.Tensor, offset: int, size: tuple[int, ...], stride: tuple[int, ...], *_: Any
) -> torch.Tensor:
    if not isinstance(storage, torch.Tensor):
        raise pickle.UnpicklingError("a tensor's storage is not one of the checkpoint's data files")
    return torch.as_strided(storage, tuple(size), tuple(stride), int(offset)).clone()


def _rebuild_parameter(data: torch.Tensor, *_: Any) -> torch.Tensor:
    if not isinstance(data, torch.Tensor):
        raise pickle.UnpicklingError("a parameter holds no tensor")
    return data


_PLAIN = {
    ("collections", "OrderedDict"): OrderedDict,
    ("__builtin__", "set"): set,
    ("builtins", "set"): set,
    ("torch._utils", "_rebuild_tensor_v2"): _rebuild_tensor,
    ("torch._utils", "_rebuild_parameter"): _rebuild_parameter,
}


class RestrictedUnpickler(pickle.Unpickler):
    """Unpickles a torch checkpoint of YOLOv5's modules into stand-ins: `find_class` answers the module
    classes of a YOLOv5 checkpoint with inert stand-ins, the tensor rebuilders with our own, storages with
    the data files of the archive (`data`: key -> bytes), and refuses any other global."""

    def __init__(self, file: io.BytesIO, data: dict[str, bytes]) -> None:
        super().__init__(file)
        self.data = data

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) in _STAND_INS:
            return _STAND_INS[module, name]
        if (module, name) in _PLAIN:
            return _PLAIN[module, name]
        if module == "torch" and name in _DTYPES:
            return _Storage(_DTYPES[name])
        raise pickle.UnpicklingError(
            f"the checkpoint names {module}.{name}, which no YOLOv5 checkpoint needs: it is not loaded"
        )

    def persistent_load(self, pid: Any) -> torch.Tensor:
        if not (isinstance(pid, tuple) and len(pid) == 5 and pid[0] == "storage"):
            raise pickle.UnpicklingError(f"unexpected persistent id {pid!r:.80}")
        _, kind, key, _location, numel = pid
        if not isinstance(kind, _Storage) or str(key) not in self.data:
            raise pickle.UnpicklingError(f"storage {key!r:.40} is not a data file of the checkpoint")
        raw = self.data[str(key)]
        flat = torch.frombuffer(bytearray(raw), dtype=kind.dtype) if raw else torch.empty(0, dtype=kind.dtype)
        if flat.numel() < int(numel):
            raise pickle.UnpicklingError(f"storage {key} holds fewer values than the checkpoint says")
        return flat


class Checkpoint:
    """What we take from a YOLOv5 checkpoint: its tensors by name, class names, and anchors."""

    def __init__(self, state: dict[str, torch.Tensor], names: list[str]) -> None:
        self.state = state
        self.names = names


def _modules(node: _StandIn, prefix: str = "", depth: int = 0) -> Iterator[tuple[str, torch.Tensor]]:
    """The tensors under a stand-in module, by their state-dict names (at most 8 modules deep: a YOLOv5 is 5,
    and a cycle in an untrusted pickle must not recurse for ever)."""
    if depth > 8:
        raise ConfigError("the checkpoint's modules nest deeper than a YOLOv5's", "fetch it again")
    for group in ("_parameters", "_buffers"):
        for key, value in dict(node.state.get(group) or {}).items():
            if isinstance(value, torch.Tensor):
                yield prefix + str(key), value
    for key, child in dict(node.state.get("_modules") or {}).items():
        if isinstance(child, _StandIn):
            yield from _modules(child, f"{prefix}{key}.", depth + 1)


def read_checkpoint(path: Path) -> Checkpoint:
    """The tensors and class names of a YOLOv5 checkpoint (a torch zip archive), read with
    `RestrictedUnpickler`. Raises `ConfigError` for a file that is not one."""
    try:
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
            pkl = next((n for n in names if n.endswith("/data.pkl")), None)
            if pkl is None:
                raise ConfigError(f"{path} is not a torch checkpoint (no data.pkl)", "fetch it again")
            root = pkl[: -len("data.pkl")]
            if f"{root}byteorder" in names and archive.read(f"{root}byteorder").strip() != b"little":
                raise ConfigError(f"{path} stores big-endian tensors", "fetch it again")
            data = {n[len(root) + 5 :]: archive.read(n) for n in names if n.startswith(root + "data/")}
            loaded = RestrictedUnpickler(io.BytesIO(archive.read(pkl)), data).load()
    except (zipfile.BadZipFile, pickle.UnpicklingError, EOFError, ValueError, TypeError) as exc:
        raise ConfigError(
            f"{path} is not a YOLOv5 checkpoint this loader accepts: {exc}",
            "fetch it again with `attribot fetch yolov5s` (the file is checked by its SHA-256)",
        ) from exc
    model = loaded.get("ema") or loaded.get("model") if isinstance(loaded, dict) else loaded
    if not isinstance(model, _StandIn) or model.source != "models.yolo.Model":
        raise ConfigError(f"{path} holds no YOLOv5 model", "fetch it again with `attribot fetch yolov5s`")
    classes = model.state.get("names")
    if isinstance(classes, dict):
        classes = [classes[k] for k in sorted(classes)]
    if not isinstance(classes, list) or not all(isinstance(c, str) for c in classes):
        raise ConfigError(f"{path} names no classes", "fetch it again with `attribot fetch yolov5s`")
    try:
        return Checkpoint(dict(_modules(model)), list(classes))
    except (TypeError, ValueError, AttributeError) as exc:
        raise ConfigError(
            f"{path} holds modules of an unexpected form: {exc}", "fetch it again: attribot fetch yolov5s"
        ) from exc


def load_state(checkpoint: Checkpoint) -> YoloV5:
    """Our network with the checkpoint's tensors (as float32), every one of them checked by name and
    shape; anchors included."""
    net = YoloV5(len(checkpoint.names))
    own = net.state_dict()
    state = {k: v for k, v in checkpoint.state.items() if k in own or not k.endswith("num_batches_tracked")}
    missing = sorted(set(own) - set(state) - {k for k in own if k.endswith("num_batches_tracked")})
    extra = sorted(set(state) - set(own))
    wrong = sorted(k for k in set(own) & set(state) if tuple(own[k].shape) != tuple(state[k].shape))
    if missing or extra or wrong:
        raise ConfigError(
            f"the checkpoint is not YOLOv5s v6.1: missing {missing[:3]}, unexpected {extra[:3]}, "
            f"other shapes {wrong[:3]}",
            "fetch the file attribot checks: `attribot fetch yolov5s`",
        )
    net.load_state_dict({k: v.float() for k, v in state.items()}, strict=False)
    return net.eval()


def export_onnx(net: YoloV5, path: Path, side: int = 640) -> None:
    """Write `net` as an ONNX graph with dynamic batch, height and width (input `images`, outputs `p3`,
    `p4`, `p5`: the raw maps `forward` returns)."""
    example = torch.zeros(1, 3, side, side)
    axes = {"images": {0: "batch", 2: "height", 3: "width"}}
    axes.update({n: {0: "batch", 2: f"h{n}", 3: f"w{n}"} for n in ("p3", "p4", "p5")})
    part = path.with_name(path.name + ".part")
    with torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the TorchScript exporter's deprecation notice
        torch.onnx.export(
            net.eval(),
            (example,),
            str(part),
            input_names=["images"],
            output_names=["p3", "p4", "p5"],
            dynamic_axes=axes,
            opset_version=17,
            dynamo=False,
        )
    part.replace(path)

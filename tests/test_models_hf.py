"""transformers backends (hf:) on tiny random models built from configs, saved to a folder, loaded by path.

The real loading, pre-processing, forward, post-processing and batching code runs; nothing downloads.
Some OWLv2 heads are set by hand so that the expected boxes and scores are known exactly.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from conftest import random_frame

pytest.importorskip("torch")
pytest.importorskip("transformers")

import torch  # noqa: E402

from attribot.boxes import iou_matrix  # noqa: E402
from attribot.config import Settings  # noqa: E402
from attribot.errors import ConfigError, InputError, MissingDependency  # noqa: E402
from attribot.frame import Frame  # noqa: E402
from attribot.models import hf  # noqa: E402
from attribot.models.base import UNKNOWN, VQAS, build_backend, detect_many, probe_backend  # noqa: E402
from fakes.hf_random import build_random, save_random  # noqa: E402


def _owl_grid(model) -> None:
    """Box head outputs 0: every box is OWLv2's prior for its patch (centre at the patch's lower-right
    corner, size one patch). Class logits (cos + 2) * 1: scores in sigmoid([1, 3]) = [0.73, 0.95]."""
    with torch.no_grad():
        model.box_head.dense2.weight.zero_()
        model.box_head.dense2.bias.zero_()
        model.class_head.logit_shift.weight.zero_()
        model.class_head.logit_shift.bias.fill_(2.0)
        model.class_head.logit_scale.weight.zero_()
        model.class_head.logit_scale.bias.zero_()


def _owl_wide(model) -> None:
    """As `_owl_grid`, but every box is as large as the whole padded square: heavy overlaps for NMS."""
    _owl_grid(model)
    with torch.no_grad():
        model.box_head.dense2.bias[2:] = 12.0


@pytest.fixture(scope="session")
def models(tmp_path_factory):
    root = tmp_path_factory.mktemp("hf-models")
    return {
        "owl": save_random("owlv2-tiny", root / "owl"),
        "owl_grid": save_random("owlv2-tiny", root / "owl_grid", edit=_owl_grid),
        "owl_wide": save_random("owlv2-tiny", root / "owl_wide", edit=_owl_wide),
        "gdino": save_random("grounding-dino-tiny", root / "gdino"),
        "blip2": save_random("blip2-tiny", root / "blip2"),
    }


def _key(dets):
    return [(d.label, tuple(round(v, 3) for v in d.box), round(d.score, 5)) for d in dets]


def _same(a, b) -> bool:
    """Same detections up to float noise (batched kernels sum in another order)."""
    return len(a) == len(b) and all(
        x.label == y.label and np.allclose(x.box, y.box, atol=1e-2) and abs(x.score - y.score) < 1e-4
        for x, y in zip(a, b, strict=True)
    )


def _check_detections(dets, frame: Frame, labels, threshold: float) -> None:
    assert dets, "expected some detections"
    scores = [d.score for d in dets]
    assert scores == sorted(scores, reverse=True)
    for d in dets:
        x0, y0, x1, y1 = d.box
        assert 0 <= x0 < x1 <= frame.width and 0 <= y0 < y1 <= frame.height
        assert threshold <= d.score <= 1.0
        assert d.label in labels


# ---- OWLv2 ---------------------------------------------------------------------------------------------


def test_owl_grid_boxes_are_pixels_clipped_to_the_image(models):
    """A 40x80 image is padded to an 80x80 square; the 4x4 prior boxes (20 px) of the lower half lie
    below the image and are dropped, those crossing the right or lower edge are clipped."""
    det = build_backend("detector", f"hf:{models['owl_grid']}", Settings(detector_threshold=0.0))
    assert isinstance(det, hf.HFDetector) and det.family == "owlv2" and det.name == f"hf:{models['owl_grid']}"
    frame = random_frame(40, 80, 0)
    dets = det.detect(frame, ["cat"])
    _check_detections(dets, frame, {"cat"}, 0.0)
    got = sorted(tuple(round(v, 1) for v in d.box) for d in dets)
    want = sorted(
        (max(cx - 10, 0), max(cy - 10, 0), min(cx + 10, 80), min(cy + 10, 40))
        for cx in (20, 40, 60, 80)
        for cy in (20, 40)
    )
    assert got == [tuple(float(v) for v in b) for b in want]

    # the raw model output really does reach outside the image: the clipping is ours
    inputs = det.processor(text=[["cat"]], images=[frame.rgb], return_tensors="pt")
    with torch.no_grad():
        raw = det.model(**inputs).pred_boxes[0] * 80  # cx, cy, w, h in pixels of the square
    assert (raw[:, 1] - raw[:, 3] / 2 > 40).sum() == 8  # two rows of boxes wholly below the image


def test_owl_threshold_keeps_only_scores_above(models):
    frame = random_frame(48, 48, 1)
    low = build_backend("detector", f"hf:{models['owl_grid']}", Settings(detector_threshold=0.0)).detect(
        frame, ["cup"]
    )
    cut = float(np.median([d.score for d in low]))
    assert 0.73 - 1e-3 <= min(d.score for d in low) and max(d.score for d in low) <= 0.953 + 1e-3
    high = build_backend("detector", f"hf:{models['owl_grid']}", Settings(detector_threshold=cut)).detect(
        frame, ["cup"]
    )
    assert 0 < len(high) < len(low)
    assert all(d.score >= cut for d in high)
    assert _key(high) == [k for k in _key(low) if k[2] >= round(cut, 5)]


def test_owl_nms_per_label(models):
    """Whole-square boxes centred on the patch grid overlap heavily: NMS leaves no same-label pair above
    the IoU limit, while without it (limit 1.0) many overlapping boxes come back."""
    path = str(models["owl_wide"])
    frame = random_frame(64, 64, 2)
    loose = hf.HFDetector(path, threshold=0.0, nms_iou=1.0).detect(frame, ["cat", "dog"])
    strict = hf.HFDetector(path, threshold=0.0, nms_iou=0.5).detect(frame, ["cat", "dog"])
    assert len(strict) < len(loose)
    for label in ("cat", "dog"):
        mine = np.array([d.box for d in strict if d.label == label])
        if len(mine) > 1:
            m = iou_matrix(mine, mine)
            assert (m[~np.eye(len(mine), dtype=bool)] <= 0.5).all()
        raw = np.array([d.box for d in loose if d.label == label])
        if len(raw) > 1:
            assert (iou_matrix(raw, raw)[~np.eye(len(raw), dtype=bool)] > 0.5).any()
    assert strict[0] == loose[0]  # the best box always survives


def test_owl_batch_equals_one_by_one(models):
    det = hf.HFDetector(str(models["owl"]), threshold=0.0, max_batch=2)
    frames = [
        random_frame(40, 80, 3),
        random_frame(60, 50, 4),
        random_frame(33, 33, 5),
        random_frame(20, 90, 6),
    ]
    queries = [["cat", "red cup"], ["dog"], [], ["mug", "apple", "book"]]
    batched = det.detect_batch(frames, queries)
    assert batched[2] == []
    for f, q, got in zip(frames, queries, batched, strict=True):
        assert _same(got, det.detect(f, q))
        if got:  # random weights may put every box of a flat image outside it
            _check_detections(got, f, set(q), 0.0)
    assert sum(len(b) for b in batched) > 0
    assert all(_same(x, y) for x, y in zip(detect_many(det, frames, queries), batched, strict=True))


def test_owl_duplicate_and_spaced_queries_are_merged(models):
    det = hf.HFDetector(str(models["owl_grid"]), threshold=0.0)
    frame = random_frame(32, 32, 7)
    assert _key(det.detect(frame, ["red  cup", " red cup", "red cup"])) == _key(
        det.detect(frame, ["red cup"])
    )


def test_bfloat16_dtype_is_used(models):
    det = hf.HFDetector(str(models["owl"]), dtype="bfloat16", threshold=0.0)
    assert next(det.model.parameters()).dtype == torch.bfloat16
    _check_detections(det.detect(random_frame(30, 40, 8), ["cat"]), random_frame(30, 40, 8), {"cat"}, 0.0)


# ---- Grounding DINO --------------------------------------------------------------------------------------


def test_gdino_labels_are_candidates_and_boxes_pixels(models):
    det = build_backend("detector", f"hf:{models['gdino']}", Settings(detector_threshold=0.0))
    assert det.family == "grounding-dino"
    frame = random_frame(50, 70, 9)
    labels = ["red cup", "cup", "dog"]  # shared words: decoded phrases could merge them
    dets = det.detect(frame, labels)
    _check_detections(dets, frame, set(labels), 0.0)
    assert len({d.label for d in dets}) >= 2


def test_gdino_token_to_label_mapping_uses_character_spans(models):
    det = hf.HFDetector(str(models["gdino"]), threshold=0.0)
    text = "red cup. cup. dog."
    enc = det.processor.tokenizer([text], return_offsets_mapping=True)
    ids, offsets = enc["input_ids"][0], [list(o) for o in enc["offset_mapping"][0]]
    spans = [(0, 7), (9, 12), (14, 17)]
    tokens = hf._tokens_of_labels(spans, offsets, width=len(ids))
    words = [[det.processor.tokenizer.convert_ids_to_tokens(ids[t]) for t in ts] for ts in tokens]
    assert words == [["red", "cup"], ["cup"], ["dog"]]
    assert hf._tokens_of_labels(spans, offsets, width=3) == [[1, 2], [], []]  # truncated text


def test_gdino_batch_equals_one_by_one_and_groups_sizes(models):
    det = hf.HFDetector(str(models["gdino"]), threshold=0.0)
    frames = [random_frame(40, 80, 10), random_frame(40, 80, 11), random_frame(60, 50, 12)]
    queries = [["cat", "red cup"], ["dog"], ["cup"]]
    assert [len(c) for c in det._chunks(frames, [0, 1, 2])] == [2, 1]
    batched = det.detect_batch(frames, queries)
    for f, q, got in zip(frames, queries, batched, strict=True):
        assert _same(got, det.detect(f, q))


def test_gdino_threshold_and_nms(models):
    frame = random_frame(64, 64, 13)
    dets = hf.HFDetector(str(models["gdino"]), threshold=0.0, nms_iou=0.3).detect(frame, ["cat"])
    boxes = np.array([d.box for d in dets])
    m = iou_matrix(boxes, boxes)
    assert (m[~np.eye(len(boxes), dtype=bool)] <= 0.3).all()
    cut = float(np.median([d.score for d in dets]))
    high = hf.HFDetector(str(models["gdino"]), threshold=cut, nms_iou=0.3).detect(frame, ["cat"])
    assert 0 < len(high) <= len(dets) and all(d.score >= cut for d in high)


# ---- BLIP-2 ----------------------------------------------------------------------------------------------


def test_blip2_answers_batched_like_one_by_one(models):
    vqa = build_backend("vqa", f"hf:{models['blip2']}", Settings())
    assert isinstance(vqa, hf.HFVisualQA) and vqa.processor.tokenizer.padding_side == "left"
    frames = [random_frame(40, 60, 14), random_frame(50, 30, 15), random_frame(16, 16, 16)]
    questions = ["what is it?", "what colour is the big thing on the left?", "is it heavy?"]
    vqa.max_batch = 2
    batched = vqa.answer_batch(frames, questions)
    assert batched == [vqa.answer(f, q) for f, q in zip(frames, questions, strict=True)]
    assert all(isinstance(a, str) and a for a in batched)
    assert not any("Question:" in a or "Answer:" in a for a in batched)


def test_blip2_prompt_is_cut_off_the_generated_tokens(models):
    vqa = hf.HFVisualQA(str(models["blip2"]), max_new_tokens=3)
    inputs = vqa.processor(
        images=[random_frame(20, 20, 17).rgb], text=["Question: what? Answer:"], return_tensors="pt"
    )
    with torch.no_grad():
        out = vqa.model.generate(**inputs, max_new_tokens=3, do_sample=False)
    new = hf._strip_prompt(out, inputs["input_ids"])
    assert 1 <= new.shape[1] <= 3 and out.shape[1] == inputs["input_ids"].shape[1] + new.shape[1]
    assert hf._strip_prompt(new, inputs["input_ids"]) is new  # older transformers: answer tokens only
    assert hf._clean_answer("  \n ") == UNKNOWN and hf._clean_answer(" a red cup\nmore") == "a red cup"


# ---- configuration and errors ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("role", "spec", "match"),
    [
        ("detector", "hf:/nonexistent/owl", "does not exist"),
        ("detector", "hf:BLIP2", "not a detector"),
        ("vqa", "hf:OWL", "not a VQA model"),
    ],
)
def test_bad_models_are_config_errors(models, role, spec, match):
    spec = spec.replace("BLIP2", str(models["blip2"])).replace("OWL", str(models["owl"]))
    with pytest.raises(ConfigError, match=match):
        build_backend(role, spec, Settings())


def test_hf_without_model_names_an_example():
    with pytest.raises(ConfigError, match="owlv2"):
        hf.build_hf_detector(None, Settings())
    with pytest.raises(ConfigError, match="blip2"):
        VQAS.get("hf")(None, Settings())


@pytest.mark.parametrize(
    ("device", "dtype", "match"),
    [("tpu", "auto", "not a device"), ("cpu", "int8", "not a dtype")]
    + ([] if torch.cuda.is_available() else [("cuda", "auto", "no CUDA GPU")]),
)
def test_bad_device_or_dtype(models, device, dtype, match):
    with pytest.raises(ConfigError, match=match):
        hf.HFDetector(str(models["owl"]), device=device, dtype=dtype)


def test_device_and_dtype_choice():
    assert hf.resolve_device("auto") == ("cuda" if torch.cuda.is_available() else "cpu")
    assert hf.resolve_dtype("auto", "cpu") == torch.float32
    assert hf.resolve_dtype("auto", "cuda") == torch.float16
    assert hf.resolve_dtype("bf16", "cpu") == torch.bfloat16


def test_bad_inputs_are_input_errors(models):
    det = hf.HFDetector(str(models["owl"]))
    frame = random_frame(20, 20, 18)
    with pytest.raises(InputError, match="empty"):
        det.detect(frame, ["cat", "  "])
    with pytest.raises(InputError, match="one string"):
        det.detect(frame, "cat")
    with pytest.raises(InputError, match="2 frames and 1"):
        det.detect_batch([frame, frame], [["cat"]])
    assert det.detect(frame, []) == []
    vqa = hf.HFVisualQA(str(models["blip2"]))
    with pytest.raises(InputError, match="empty"):
        vqa.answer(frame, " ")


def test_missing_extra_names_the_pip_line(models, monkeypatch):
    monkeypatch.setitem(sys.modules, "transformers", None)  # import fails as if not installed
    with pytest.raises(MissingDependency, match=r"pip install -e '\.\[models\]' in the attribot clone"):
        build_backend("detector", f"hf:{models['owl']}", Settings())


def test_probe_reports_folder_extra_and_cache(models, monkeypatch, tmp_path):
    s = Settings()
    ok = probe_backend("detector", f"hf:{models['owl']}", s)
    assert ok.registered and ok.available is True and "local model folder" in ok.detail
    missing = probe_backend("vqa", f"hf:{tmp_path / 'nope'}", s)
    assert missing.available is False and "does not exist" in missing.detail
    monkeypatch.setenv("HF_HUB_CACHE", str(tmp_path))
    hub = probe_backend("detector", "hf:someone/not-cached-model", s)
    assert hub.available is None and "not in the local cache" in hub.detail
    real_find_spec = hf.importlib.util.find_spec
    monkeypatch.setattr(hf.importlib.util, "find_spec", lambda m: None if m == "torch" else real_find_spec(m))
    gone = probe_backend("detector", f"hf:{models['owl']}", s)
    assert gone.available is False and "pip install -e '.[models]'" in gone.detail


def test_random_model_catalog_builds_real_size_configs_without_weights():
    """The real-size specs the GPU benchmark uses are valid configs (checked on the meta device)."""
    model, processor = build_random("owlv2-b16", device="meta")
    n = sum(p.numel() for p in model.parameters())
    assert 150e6 < n < 170e6  # OWLv2-B/16 has about 155 M parameters
    assert processor.image_processor.size["height"] == 960


def test_import_attribot_does_not_import_torch():
    code = (
        "import sys, attribot, attribot.models.base as b; b.DETECTORS.names(); b.VQAS.names();"
        "import attribot.models.hf, attribot.models.openai_chat;"
        "assert 'torch' not in sys.modules and 'transformers' not in sys.modules, 'torch imported'"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)


def test_from_loaded_matches_the_saved_and_loaded_model(models):
    """The in-memory path (benchmarks, servers) gives what the folder path gives: same seed, same weights."""
    frame = random_frame(40, 60, 19)
    model, processor = build_random("owlv2-tiny", seed=0)
    mem = hf.HFDetector.from_loaded(model, processor, threshold=0.0)
    disk = hf.HFDetector(str(models["owl"]), threshold=0.0)
    assert mem.family == "owlv2" and _same(mem.detect(frame, ["cat"]), disk.detect(frame, ["cat"]))
    vqa_model, vqa_processor = build_random("blip2-tiny", seed=0)
    vqa = hf.HFVisualQA.from_loaded(vqa_model, vqa_processor, max_new_tokens=4)
    assert vqa.answer(frame, "what?") == hf.HFVisualQA(str(models["blip2"]), max_new_tokens=4).answer(
        frame, "what?"
    )
    with pytest.raises(ConfigError, match="not a detector"):
        hf.HFDetector.from_loaded(vqa_model, vqa_processor)


def test_gpu_preprocessing_only_for_torchvision_processors():
    class TorchvisionBackend:  # stands for transformers' base class of that name
        pass

    class Fast(TorchvisionBackend):
        pass

    class Pil:
        pass

    assert hf._device_preprocessing(Fast(), "cuda") and hf._device_preprocessing(Fast(), "cuda:1")
    assert not hf._device_preprocessing(Fast(), "cpu") and not hf._device_preprocessing(Pil(), "cuda")


def test_gpu_benchmark_code_path_runs_with_tiny_models(capsys, tmp_path):
    """benchmarks/bench_models.py --tiny runs the --real-size code (build on a device, forward inputs of
    the processors' shapes, the backends end to end) with tiny models, so the GPU run cannot fail on
    something a CPU would catch."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_models.py"
    spec = importlib.util.spec_from_file_location("bench_models", path)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    out = tmp_path / "rows.json"
    bench.main(
        [
            "--tiny",
            "--device",
            "cpu",
            "--batches",
            "1,2",
            "--warmup",
            "0",
            "--iters",
            "1",
            "--models",
            "grounding-dino-t,blip2-opt-2.7b",
            "--json",
            str(out),
        ]
    )
    import json

    rows = json.loads(out.read_text())
    assert {(r["model"], r["part"], r["batch"]) for r in rows} == {
        (m, p, b)
        for m in ("grounding-dino-t", "blip2-opt-2.7b")
        for p in ("forward", "backend")
        for b in (1, 2)
    }
    assert all("skipped" not in r and r["ms_per_image"] > 0 for r in rows), rows
    # the backend rows say where the time went; the model ran in every call (BLIP-2: through generate)
    for r in (r for r in rows if r["part"] == "backend"):
        assert r["model_ms"] > 0 and r["before_ms"] > 0 and r["after_ms"] >= 0, r
    assert "vs own batch 1" in capsys.readouterr().out


def test_max_detections_is_the_best_prefix(models):
    # a large frame, so that the random model's tiny boxes are at least a pixel (smaller ones are dropped)
    frame = random_frame(512, 512, 20)
    every = hf.HFDetector(str(models["owl"]), threshold=0.0, max_detections=10_000).detect(
        frame, ["cat", "dog"]
    )
    few = hf.HFDetector(str(models["owl"]), threshold=0.0, max_detections=5).detect(frame, ["cat", "dog"])
    assert len(every) > 5 and _same(few, every[:5])


def test_nms_early_stop_keeps_the_same_first_boxes():
    from attribot.boxes import nms

    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 100, (200, 2))
    boxes = np.hstack([xy, xy + rng.uniform(1, 40, (200, 2))])
    scores = rng.random(200)
    full = nms(boxes, scores, 0.4)
    assert 7 < len(full) < 200
    assert nms(boxes, scores, 0.4, max_keep=7).tolist() == full[:7].tolist()
    keep_all = nms(boxes, scores, 1.0)
    assert sorted(keep_all.tolist()) == list(range(200))


def test_boxes_under_a_pixel_are_not_detections(models):
    # at 64 px the tiny random model proposes many slivers; none may come back as a detection
    dets = hf.HFDetector(str(models["owl"]), threshold=0.0, max_detections=10_000).detect(
        random_frame(64, 64, 20), ["cat", "dog"]
    )
    assert dets and all(d.box[2] - d.box[0] >= 1 and d.box[3] - d.box[1] >= 1 for d in dets)


# ---- every image is brought to the model's working size before any processor sees it -------------------


class _ShapeSpy:
    """Wraps an image processor and records the (height, width) of every image handed to it."""

    def __init__(self, inner) -> None:
        self.inner, self.shapes = inner, []

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def __call__(self, images, *args, **kwargs):
        self.shapes.extend(tuple(np.asarray(im).shape[:2]) for im in images)
        return self.inner(images, *args, **kwargs)


@pytest.mark.parametrize("name", ["owl", "gdino"])
@pytest.mark.parametrize("shape", [(1, 10000), (10000, 1), (3000, 4000), (2, 3)])
def test_detector_processors_see_images_at_working_size(models, name, shape):
    """A 1x10000 or a 4000x3000 image reached OWLv2's processor at full size (which pads it to a square
    and blurs it on the CPU: minutes and 11 GB for the real model); now at most the working side, and
    at most MAX_ASPECT to 1, with boxes inside the caller's image."""
    det = hf.HFDetector(str(models[name]), threshold=0.0)
    spy = _ShapeSpy(det.processor.image_processor)
    det.processor.image_processor = spy
    side = hf.working_side(spy.inner)
    frame = Frame(rgb=np.full(shape + (3,), 90, dtype=np.uint8))
    dets = det.detect(frame, ["cat"])
    ((h, w),) = spy.shapes
    assert max(h, w) <= max(side, max(shape)) and max(h, w) <= max(side, 8)
    assert max(h, w) <= hf.MAX_ASPECT * min(h, w)
    for d in dets:
        x0, y0, x1, y1 = d.box
        assert 0 <= x0 < x1 <= shape[1] and 0 <= y0 < y1 <= shape[0]


def test_vqa_processor_sees_images_at_working_size(models):
    vqa = hf.HFVisualQA(str(models["blip2"]), max_new_tokens=2)
    seen = []
    inner = vqa.processor

    def spying(*, images, **kwargs):
        seen.extend(np.asarray(im).shape[:2] for im in images)
        return inner(images=images, **kwargs)

    vqa.processor = type(
        "P", (), {"__call__": staticmethod(spying), "__getattr__": lambda s, n: getattr(inner, n)}
    )()
    assert isinstance(vqa.answer(Frame(rgb=np.zeros((1, 10000, 3), np.uint8)), "what?"), str)
    side = hf.working_side(inner.image_processor)
    assert seen and max(seen[0]) <= side


def test_working_size_maps_boxes_back_to_the_callers_pixels(models):
    """An image twice the size (each pixel doubled) shrinks back to the original exactly: the same
    detections, with boxes twice as large."""
    det = hf.HFDetector(str(models["owl"]), threshold=0.0)
    side = hf.working_side(det.processor.image_processor)
    small = random_frame(side, side // 2, 23)
    big = Frame(rgb=np.repeat(np.repeat(small.rgb, 2, axis=0), 2, axis=1))
    a, b = det.detect(small, ["cat", "dog"]), det.detect(big, ["cat", "dog"])
    assert a and len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert x.label == y.label and abs(x.score - y.score) < 1e-4
        assert np.allclose(np.array(x.box) * 2, y.box, atol=1e-2)


@pytest.mark.parametrize(
    ("shape", "want"),
    [((480, 640), (480, 640)), ((1, 10000), (120, 960)), ((3000, 4000), (720, 960)), ((100, 2), (100, 13))],
)
def test_to_working_size_shapes(shape, want):
    rgb = np.zeros(shape + (3,), np.uint8)
    out, scale = hf.to_working_size(rgb, 960)
    assert out.shape[:2] == want and out.flags.c_contiguous
    assert scale == min(1.0, 960 / max(shape))


# ---- the real OWLv2 size (random weights): a thin and a large photo stay cheap --------------------------


def _real_size_owl_on_awkward_images(device: str, dtype: str) -> None:
    model, processor = build_random("owlv2-b16", device=device, dtype=dtype, seed=0)
    det = hf.HFDetector.from_loaded(model, processor, threshold=0.0)
    spy = _ShapeSpy(det.processor.image_processor)
    det.processor.image_processor = spy
    assert hf.working_side(spy.inner) == 960
    for shape in [(1, 10000), (3000, 4000)]:
        frame = Frame(rgb=np.full(shape + (3,), 90, dtype=np.uint8))
        for d in det.detect(frame, ["cup"]):
            assert 0 <= d.box[0] < d.box[2] <= shape[1] and 0 <= d.box[1] < d.box[3] <= shape[0]
    assert spy.shapes == [(120, 960), (720, 960)]


@pytest.mark.slow
def test_real_size_owlv2_on_a_thin_and_a_large_image_cpu():
    """The size whose processor took minutes and 11 GB on a 1x10000 PNG (a ViT-B/16 forward on the CPU)."""
    _real_size_owl_on_awkward_images("cpu", "float32")


@pytest.mark.gpu
@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs an NVIDIA GPU")
def test_real_size_owlv2_on_a_thin_and_a_large_image_gpu():
    _real_size_owl_on_awkward_images("cuda", "float16")

"""Seeded perception noise for the oracle backends: the rates asked for, the same errors on every rerun,
independent errors across scenes, clear errors for bad options."""

from __future__ import annotations

import numpy as np
import pytest

from attribot.config import SceneConfig, Settings, load_settings
from attribot.errors import ConfigError
from attribot.eval.methods import Condition
from attribot.frame import Frame, ObjectTruth
from attribot.mechanisms import Mechanism
from attribot.models.base import Detection, build_backend, parse_spec, probe_backend
from attribot.models.noise import DetectorNoise, NoisyDetector, NoisyVQA, VQANoise
from attribot.noise import PerceptionNoise
from attribot.session import Scene, ask
from conftest import random_frame

N_OBJECTS = 5


class FiveObjects:
    """A stand-in detector that always finds the same five objects, each a different box."""

    name = "five"

    def detect(self, frame, queries):
        return [
            Detection(
                box=(10.0 * i, 5.0, 10.0 * i + 8, 20.0),
                score=0.9 - 0.1 * i,
                label="object",
                object_id=f"o{i}",
            )
            for i in range(N_OBJECTS)
        ]


class Truthful:
    name = "truthful"

    def __init__(self, reply: str) -> None:
        self.reply = reply

    def answer(self, frame, question):
        return self.reply


def _frames(n: int) -> list[Frame]:
    return [random_frame(24, 64, seed=i) for i in range(n)]


def test_specs_carry_options_to_the_oracle_builders():
    assert parse_spec("oracle?miss=0.1") == ("oracle", "?miss=0.1")
    assert parse_spec("oracle:40?miss=0.1") == ("oracle", "40?miss=0.1")
    det = build_backend("detector", "oracle?miss=0.1&jitter_px=4", Settings())
    assert isinstance(det, NoisyDetector) and det.name == "oracle?miss=0.1&jitter_px=4"
    assert det.inner.min_pixels == 30
    vqa = build_backend("vqa", "oracle:40?noise=realistic", Settings())
    assert isinstance(vqa, NoisyVQA) and vqa.noise.wrong == 0.1 and vqa.inner.min_pixels == 40
    assert build_backend("detector", "oracle?noise=clean", Settings()).name == "oracle"  # no wrapper


def test_a_condition_puts_typed_noise_on_any_oracle_spec_as_the_spec_string_would():
    condition = Condition.parse("realistic-no-remeasure")
    assert condition.without is Mechanism.REMEASURE
    settings = condition.settings_for(Settings(detector="oracle:50?miss=0.3"), seed=7)
    assert settings.perception_noise == PerceptionNoise(preset="realistic", seed=7)
    assert Mechanism.REMEASURE not in settings.mechanisms and Mechanism.LOOK_AGAIN in settings.mechanisms
    typed = build_backend("detector", settings.detector, settings)
    # the preset's noise, drawn from the item's seed, under the spec's own pixels and its own miss rate
    assert isinstance(typed, NoisyDetector) and typed.inner.min_pixels == 50
    assert (
        typed.noise == build_backend("detector", "oracle?noise=realistic&miss=0.3&seed=7", Settings()).noise
    )
    vqa = build_backend("vqa", "oracle", settings)
    assert isinstance(vqa, NoisyVQA) and vqa.noise == VQANoise(wrong=0.1, seed=7)
    # clean adds none, and a coco spec is not the oracle's: the noise reaches no other backend
    assert Condition.parse("clean").settings_for(Settings(), seed=7).perception_noise is None
    assert (
        build_backend("detector", "oracle", Condition("clean").settings_for(Settings(), 7)).name == "oracle"
    )
    with pytest.raises(ValueError, match="unknown noise preset"):
        PerceptionNoise(preset="awful")


def test_miss_rate_and_reruns_give_the_same_errors():
    noisy = NoisyDetector(FiveObjects(), DetectorNoise(miss=0.3))
    frames = _frames(400)
    kept = [len(noisy.detect(f, ["object"])) for f in frames]
    assert 1 - np.mean(kept) / N_OBJECTS == pytest.approx(0.3, abs=0.04)
    again = [len(noisy.detect(f, ["object"])) for f in frames]
    assert again == kept  # the same frame and query give the same draw
    other_seed = NoisyDetector(FiveObjects(), DetectorNoise(miss=0.3, seed=1))
    assert [len(other_seed.detect(f, ["object"])) for f in frames] != kept


def test_false_positives_jitter_and_confusions_at_their_rates():
    frames = _frames(400)
    fp = NoisyDetector(FiveObjects(), DetectorNoise(false_pos=0.2))
    spurious = [sum(d.object_id is None for d in fp.detect(f, ["cup"])) for f in frames]
    assert np.mean(spurious) == pytest.approx(0.2, abs=0.05)

    jit = NoisyDetector(FiveObjects(), DetectorNoise(jitter_px=2.0))
    shifts = [
        d.box[1] - 5.0 for f in frames for d in jit.detect(f, ["object"]) if 2.0 < d.box[1] < 22.0
    ]  # y0 away from the image's edges, where clipping would bias it
    assert np.std(shifts) == pytest.approx(2.0, rel=0.15)

    con = NoisyDetector(FiveObjects(), DetectorNoise(confuse=0.25))
    truth_boxes = {d.object_id: d.box for d in FiveObjects().detect(None, ["object"])}
    clean_ids = list(truth_boxes)
    detections = [list(enumerate(con.detect(f, ["object"]))) for f in frames]
    # a confusion hands over another object's whole box and id, never a mix of the two
    assert all(truth_boxes[d.object_id] == d.box for dets in detections for _, d in dets)
    changed = [d.object_id != clean_ids[i] for dets in detections for i, d in dets]
    assert np.mean(changed) == pytest.approx(0.25, abs=0.05)


@pytest.mark.parametrize(
    ("truth", "check"),
    [
        ("yes", lambda a: a == "no"),
        ("no", lambda a: a == "yes"),
        ("red", lambda a: a != "red" and a.isalpha()),
        ("mug", lambda a: a == "apple"),
    ],
)
def test_vqa_answers_wrong_at_its_rate_and_plausibly(truth, check):
    frames = [
        Frame(
            rgb=f.rgb,
            objects={
                1: ObjectTruth(id="mug_0", category="mug", color="red"),
                2: ObjectTruth(id="apple_1", category="apple", color="green"),
            },
        )
        for f in _frames(400)
    ]
    vqa = NoisyVQA(Truthful(truth), VQANoise(wrong=0.3))
    answers = [vqa.answer(f, "what is it?") for f in frames]
    wrong = [a for a in answers if a != truth]
    assert len(wrong) / len(answers) == pytest.approx(0.3, abs=0.05)
    assert all(check(a) for a in wrong)


@pytest.mark.parametrize(
    ("spec", "role", "words"),
    [
        ("oracle?mis=0.1", "detector", "has no option 'mis'"),
        ("oracle?miss=1.5", "detector", "out of range"),
        ("oracle?miss=abc", "detector", "not a number"),
        ("oracle?noise=awful", "detector", "unknown noise preset 'awful'"),
        ("oracle?wrong=0.1", "detector", "has no option 'wrong'"),
        ("oracle?miss=0.1", "vqa", "has no option 'miss'"),
        ("oracle?miss", "detector", "malformed"),
    ],
)
def test_bad_noise_options_are_clear_errors(spec, role, words):
    with pytest.raises(ConfigError, match=words):
        build_backend(role, spec, Settings())


def test_attribot_backends_shows_the_noise():
    status = probe_backend("detector", "oracle?noise=realistic", Settings())
    assert status.available and "seeded noise: noise=realistic" in status.detail
    assert probe_backend("detector", "oracle?mis=1", Settings()).available is False


def test_a_noisy_run_names_its_noise_and_reruns_identically():
    settings = load_settings(detector="oracle?noise=frame&seed=3", vqa="oracle?noise=frame")
    scene = Scene(SceneConfig(layout="household", seed=5), sensors=["camera", "distance"])
    first = ask("Which object is the closest to me?", scene, settings)
    second = ask("Which object is the closest to me?", scene, settings)
    assert first.backends["detector"] == "oracle?miss=0.1&false_pos=0.05&jitter_px=4&confuse=0.05&seed=3"
    assert first.model_dump(exclude={"trace"}) == second.model_dump(exclude={"trace"})


def test_a_noisy_oracle_on_a_still_image_is_refused_like_the_oracle(tmp_path):
    from PIL import Image

    photo = tmp_path / "photo.png"
    Image.fromarray(np.zeros((48, 64, 3), np.uint8)).save(photo)
    with pytest.raises(ConfigError, match="a still image needs a real detector"):
        ask("Where is the mug?", Scene(image=photo), load_settings(detector="oracle?noise=realistic"))

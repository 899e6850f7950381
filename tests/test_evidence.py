"""Answers that carry their evidence: what each found object rests on (a sure or faint box, a look from
nearer, elimination, a likeness, a measurement), inferences confirmed by acting before an answer rests on
them, and a question about an object that is not there answered "not found", never with another object.
Truth comes from the world's own state (the scene's objects and masses)."""

from __future__ import annotations

import numpy as np
import pytest

from attribot.api import Perception, Robot
from attribot.config import SceneConfig, load_settings
from attribot.control.base import build_controller
from attribot.control.candidates import Candidate
from attribot.embodiments.mujoco import MujocoWorld
from attribot.errors import InvalidSetting
from attribot.eval.datasets import Item
from attribot.eval.methods import CLEAN, _record
from attribot.frame import Frame
from attribot.models.base import Detection, evidence_of
from attribot.planning.answer import AnswerObject, _answer_object, _guessed, _last_measurement
from attribot.skills.harder import LookHarderReport, confirmed
from attribot.skills.robot_core import Measurement
from attribot.skills.safeguards import Safeguards


class SeesOnly:
    """A detector that reads pixels only (so that the robot looks harder for it) and names only the
    categories in `sees`, wherever the simulator's segmentation shows them: a closed-set detector in a room
    with other things in it."""

    name = "sees-only"
    pixels_only = True

    def __init__(self, sees: set[str]) -> None:
        self.sees = sees

    def detect(self, frame: Frame, queries):
        out = []
        for key, obj in (frame.objects or {}).items():
            if obj.category not in self.sees or not any(q in (obj.category, "object") for q in queries):
                continue
            ys, xs = np.nonzero(frame.segmentation == key)
            if len(xs) >= 20:
                box = (float(xs.min()), float(ys.min()), float(xs.max() + 1), float(ys.max() + 1))
                out.append(Detection(box=box, score=0.9, label=obj.category))
        return out


ROOM = SceneConfig(
    layout="household", seed=3, categories=("apple", "mug", "tomato", "dumbbell", "can"), objects=5
)


def _robot_image(world: MujocoWorld, detector: SeesOnly):
    base = Perception.from_settings(load_settings(detector="oracle"))
    perception = Perception(detector=detector, vqa=base.vqa, language=base.language)
    robot = Robot(
        sensors=["camera"],
        world=world,
        controller=build_controller(world),
        safeguards=Safeguards("all,-look_again"),
    )
    return robot, robot.look(perception, survey=False)


def test_evidence_of_a_detection_is_its_own_or_the_detectors_box_by_score():
    sure = Detection(box=(0, 0, 5, 5), score=0.6, label="mug")
    assert evidence_of(sure) == "sure box"
    assert evidence_of(sure.model_copy(update={"score": 0.12})) == "faint box"
    assert evidence_of(sure.model_copy(update={"evidence": "elimination"})) == "elimination"
    with pytest.raises(ValueError):
        Detection(box=(0, 0, 5, 5), score=0.6, label="mug", evidence="a hunch")


@pytest.mark.parametrize(
    ("seen", "visits", "kept", "confirmed_n", "dropped_n"),
    [
        # the detector names it from nearer: its box seen nearer, under the name looked for
        (
            [Detection(box=(10, 10, 20, 20), score=0.7, label="cup", evidence="seen nearer")],
            1,
            "seen nearer",
            1,
            0,
        ),
        ([], 1, None, 0, 1),  # looked from nearer and not named there: dropped
        ([], 0, "elimination", 0, 0),  # no way there: still the inference, which an answer calls a guess
    ],
)
def test_an_inference_is_confirmed_by_a_look_from_nearer_or_dropped(
    seen, visits, kept, confirmed_n, dropped_n
):
    place = Candidate(box=(10.0, 10.0, 20.0, 20.0), rise=0.1, pixels=40, size=0.1)
    inferred = [Detection(box=place.box, score=0.001, label="mug", evidence="elimination")]
    asked: list[tuple[str, list[Candidate]]] = []

    def nearer(name, places):
        asked.append((name, places))
        return seen, visits

    report = LookHarderReport(1, 0, 0, 0)
    out = confirmed(inferred, [place], "mug", nearer, report)
    assert asked == [("mug", [place])]  # it drove to the very place inferred
    assert [evidence_of(d) for d in out] == ([kept] if kept else [])
    assert all(d.label == "mug" for d in out)
    assert (report.confirmed, report.unconfirmed) == (confirmed_n, dropped_n)
    # a robot that cannot drive keeps the inference as it is
    assert confirmed(inferred, [place], "mug", None, LookHarderReport(1, 0, 0, 0)) == inferred
    # where everything else depth sees is named (a closed world), the one place left stands unconfirmed
    closed = LookHarderReport(1, 0, 0, 0)
    kept_closed = confirmed(inferred, [place], "mug", nearer, closed, lambda taken: True)
    assert kept_closed == (inferred if seen == [] and visits else kept_closed)
    assert closed.closed == (1 if not seen and visits else 0)


def test_a_closed_world_is_one_where_at_most_one_thing_depth_sees_is_unexplained():
    from attribot.skills.harder import closed_world

    things = [
        Candidate(box=(x, 100.0, x + 20.0, 130.0), rise=0.1, pixels=40, size=0.1)
        for x in (50.0, 150.0, 250.0)
    ]
    named = [Detection(box=(45.0, 95.0, 75.0, 135.0), score=0.8, label="cup")]
    assert not closed_world(things, named, 640, 480)  # two things no box explains: others are in the room
    named.append(Detection(box=(145.0, 95.0, 175.0, 135.0), score=0.6, label="apple"))
    assert closed_world(things, named, 640, 480)  # only the one sought is left unnamed
    # an inference that took the one unnamed thing stands on a closed world; one that took a place a sure box
    # of another name explains (a faint box of a mouse on what is boxed surely as a cup) leaves the unnamed
    # thing as likely the object sought: not closed, unless every other thing is named
    assert closed_world(things, named, 640, 480, taken=things[2].box)
    assert not closed_world(things, named, 640, 480, taken=things[0].box)
    assert closed_world(things[:2], named, 640, 480, taken=things[0].box)
    faint = [named[0], named[1].model_copy(update={"score": 0.05})]
    assert not closed_world(things, faint, 640, 480)  # a faint box explains nothing
    # a line one map pixel thick (a seam where a cabinet meets the floor, a chair's edge) is no thing...
    for seam in ((400.0, 286.0, 408.0, 288.0), (214.0, 440.0, 232.0, 442.0), (282.0, 428.0, 284.0, 458.0)):
        line = Candidate(box=seam, rise=0.01, pixels=9, size=0.06, across=0.06)
        assert closed_world([*things, line], named, 640, 480)
    # ...but a small thing, seen whole, is
    egg = Candidate(box=(298.0, 300.0, 312.0, 316.0), rise=0.042, pixels=44, size=0.043, across=0.043)
    assert not closed_world([*things, egg], named, 640, 480)
    # nor is a table's leg, seen from near and above: short in the image, tall and thin as depth measures
    leg = Candidate(
        box=(416.0, 382.0, 454.0, 468.0), rise=0.378, pixels=492, size=0.378, across=0.061, bottom=0.03
    )
    assert closed_world([*things, leg], named, 640, 480)
    # a thing as tall that is not thin across the floor (a backpack) is one more unnamed thing
    bag = Candidate(
        box=(416.0, 382.0, 454.0, 468.0), rise=0.378, pixels=492, size=0.378, across=0.25, bottom=0.03
    )
    assert not closed_world([*things, bag], named, 640, 480)

    # asked about a fork and a toaster, neither named: seeking the toaster, the one place only a fork fits is
    # the fork, not one more unnamed thing; a place a fork or a spoon might be is no more the fork than not
    from attribot.priors import priors

    fork, spoon = priors().find("fork"), priors().find("spoon")
    toaster = Candidate(box=(452.0, 100.0, 510.0, 140.0), rise=0.2, pixels=491, size=0.276, across=0.276)
    flat = Candidate(box=(342.0, 346.0, 364.0, 386.0), rise=0.0, pixels=57, size=0.162, across=0.162)
    assert not closed_world([*things[:2], toaster, flat], named, 640, 480)
    assert closed_world([*things[:2], toaster, flat], named, 640, 480, sought=[fork])
    other = Candidate(box=(100.0, 346.0, 122.0, 386.0), rise=0.0, pixels=57, size=0.17, across=0.17)
    assert not closed_world([*things[:2], toaster, flat, other], named, 640, 480, sought=[fork])
    assert not closed_world([*things[:2], toaster, flat, other], named, 640, 480, sought=[fork, spoon])


def test_pieces_of_one_thing_that_depth_parted_are_no_more_things():
    from attribot.skills.harder import closed_world

    # one thing no box explains (the one sought, say) leaves the world closed; a second opens it
    cup = Candidate(box=(50.0, 100.0, 70.0, 130.0), rise=0.1, pixels=40, size=0.1, bottom=0.45)
    # a chair the image's bottom edge cuts, and a post of it that depth parted from its seat: the post's
    # foot is within the chair's heights and half of its box on the chair's
    chair = Candidate((338.0, 432.0, 406.0, 480.0), 0.226, 234, 0.2, 0.2, 0.196)
    post = Candidate((340.0, 424.0, 346.0, 448.0), 0.218, 20, 0.22, 0.02, 0.218)
    assert closed_world([cup, chair, post], [], 640, 480)
    # a thing standing on the chair's seat stands above the chair's heights: one more thing
    on_seat = Candidate((360.0, 420.0, 380.0, 446.0), 0.08, 40, 0.08, 0.08, 0.43)
    assert not closed_world([cup, chair, on_seat], [], 640, 480)
    # a spoon lying flat, seen by depth as its bowl and its handle: taking one takes the other
    handle = Candidate((294.0, 220.0, 300.0, 238.0), 0.011, 9, 0.04, 0.04, 0.457)
    bowl = Candidate((288.0, 206.0, 298.0, 216.0), 0.013, 20, 0.04, 0.04, 0.457)
    named = [Detection(box=(40.0, 90.0, 80.0, 140.0), score=0.8, label="cup")]
    assert closed_world([cup, handle, bowl], named, 640, 480, taken=handle.box)
    # a thing that stands beside what was taken, or one lying farther off, is another thing
    mug = Candidate((300.0, 196.0, 318.0, 220.0), 0.09, 60, 0.09, 0.09, 0.457)
    assert not closed_world([cup, handle, mug], named, 640, 480, taken=handle.box)
    apart = Candidate((270.0, 200.0, 280.0, 212.0), 0.01, 20, 0.04, 0.04, 0.457)
    assert not closed_world([cup, handle, apart], named, 640, 480, taken=handle.box)


class CallsItA(SeesOnly):
    """`SeesOnly`, but it also boxes one category under another name, surely (YOLOv5s calls a potato a
    sports ball at 0.31) or at `score` (a faint box)."""

    def __init__(self, sees: set[str], thing: str, called: str, score: float | None = None) -> None:
        super().__init__(sees | {thing})
        self.thing, self.called, self.score = thing, called, score

    def detect(self, frame: Frame, queries):
        found = super().detect(frame, [self.thing if q == self.called else q for q in queries])
        named = {"label": self.called, **({} if self.score is None else {"score": self.score})}
        return [d.model_copy(update=named) if d.label == self.thing else d for d in found]


def _find_in_room(detector: SeesOnly, name: str) -> list:
    """What `find(name)` gives in `ROOM` seen with `detector` (looking again left out)."""
    with MujocoWorld(ROOM) as world:
        assert name not in {o.category for o in world.scene_info().objects}
        base = Perception.from_settings(load_settings(detector="oracle"))
        perception = Perception(detector=detector, vqa=base.vqa, language=base.language)
        robot = Robot(
            sensors=["camera"], world=world, controller=build_controller(world),
            safeguards=Safeguards("all,-look_again"),
        )  # fmt: skip
        return robot.look(perception, survey=False).find(name)


def test_an_answer_resting_on_a_faint_box_of_an_unnamed_thing_says_it_is_a_guess():
    """The detector boxes the tomato faintly as an orange (there is none): the find keeps the faint box, as
    it says, and an answer resting on it says plainly that it is a guess, never a confident answer."""
    faint = _find_in_room(CallsItA({"apple", "mug"}, "tomato", "orange", score=0.15), "orange")
    assert [p.evidence for p in faint] == ["faint box"] and faint[0].score < 0.25
    obj = AnswerObject(id=None, category="orange", box=faint[0].box, evidence=(faint[0].evidence,))
    assert obj.guess and "faintly" in _guessed(obj)


def test_a_robot_that_refuses_guesses_gives_no_answer_where_its_object_rests_on_one():
    """With guesses refused (`Settings.guesses`), the faint orange (the tomato, as it happens) is no answer:
    the refusal says why and what the guess was; the sure apple is answered all the same."""
    from attribot.planning.answer import build_answer, refusing_guess
    from attribot.runner.records import RunResult

    def answer(patch: object):
        result = RunResult(ok=True, value={"box": list(patch.box)}, value_object=patch)
        return build_answer(
            query="Which one?", planner="rules", program="...", result=result, attempts=1, backends={},
            measurements=[], world={}, frame=patch.frame,
        )  # fmt: skip

    faint = _find_in_room(CallsItA({"apple", "mug"}, "tomato", "orange", score=0.15), "orange")[0]
    said = answer(faint)
    refused = refusing_guess(said)
    assert said.object is not None and said.object.guess and said.error is None
    assert refused.object is None and refused.value is None and refused.error is not None
    assert refused.error.category == "uncertain" and "guesses are refused" in refused.error.message
    assert refused.answer.startswith("no answer:") and said.answer in refused.answer
    with MujocoWorld(ROOM) as world:
        robot, image = _robot_image(world, SeesOnly({"apple", "mug"}))
        apple = answer(image.find("apple")[0])
    assert refusing_guess(apple) == apple and apple.object is not None
    assert load_settings(guesses="refuse").guesses == "refuse"
    with pytest.raises(InvalidSetting, match="guesses"):
        load_settings(guesses="sometimes")


def test_ask_refuses_an_answer_resting_on_a_guess_only_where_the_settings_say_so(monkeypatch):
    """The session applies `guesses`: the same answer, its object made a guess (a faint box), is answered
    with its guess said by default and refused with guesses = refuse."""
    import attribot.session as session
    from attribot import Scene, ask

    def faintly(**kw):
        built = build(**kw)
        guessed = built.object.model_copy(update={"evidence": ("faint box", "measurement")})
        return built.model_copy(update={"object": guessed})

    build = session.build_answer
    monkeypatch.setattr(session, "build_answer", faintly)
    config = SceneConfig(layout="household", seed=3, categories=("apple", "mug"), objects=2)
    query = "How far away is the apple?"
    said = ask(query, Scene(config, sensors=["camera", "distance"]), load_settings())
    refused = ask(query, Scene(config, sensors=["camera", "distance"]), load_settings(guesses="refuse"))
    assert said.object is not None and said.object.guess and said.error is None
    assert refused.object is None and refused.error is not None and refused.error.category == "uncertain"


def test_an_object_not_in_the_room_is_not_found_though_one_thing_is_left_by_elimination():
    """The room holds an apple and a mug the detector names, and a tomato, a dumbbell and a can it cannot:
    asked for a microwave (there is none), elimination points at the one unexplained thing of a microwave's
    size as the perception priors know it (the dumbbell on the shelf), and the robot, driving nearer, does
    not see a microwave there: not found. Without a way to look nearer the same inference stands, marked as
    elimination, and an answer resting on it says it is a guess. (A toaster, as the priors know it, could be
    the can or the dumbbell: elimination singles out neither.)"""
    with MujocoWorld(ROOM) as world:
        truth = {o.category for o in world.scene_info().objects}
        robot, image = _robot_image(world, SeesOnly({"apple", "mug"}))
        assert "microwave" not in truth
        assert image.find("microwave") == []
        harder = [e for e in robot.safeguards.events if e.mechanism == "look_harder"]
        assert "elimination" in harder[-1].detail and "dropped" in harder[-1].detail
        image.nearer, image.named = None, {}
        guessed = image.find("microwave")
    assert [p.evidence for p in guessed] == ["elimination"]
    obj = AnswerObject(id=None, category="microwave", box=guessed[0].box, evidence=(guessed[0].evidence,))
    assert obj.guess and "a guess" in _guessed(obj) and "elimination" in _guessed(obj)
    assert not AnswerObject(id=None, category="mug", box=(0, 0, 1, 1), evidence=("sure box",)).guess


class CallsOtherwise(SeesOnly):
    """`SeesOnly` that boxes each category of `calls` surely as another name (YOLOv5s boxes the simulator's
    toasters as suitcases or books, and never as toasters)."""

    def __init__(self, sees: set[str], calls: dict[str, str]) -> None:
        super().__init__(sees)
        self.calls = calls

    def detect(self, frame: Frame, queries):
        as_called = {v: k for k, v in self.calls.items()}
        asked = [as_called.get(q, q) for q in queries if q not in self.calls]
        found = super().detect(frame, asked)
        return [d.model_copy(update={"label": self.calls.get(d.label, d.label)}) for d in found]


def _find_with(config: SceneConfig, detector: SeesOnly, name: str):
    with MujocoWorld(config) as world:
        truth = {o.category: o.box for o in world.scene_info().objects}
        robot, image = _robot_image(world, detector)
        found = image.find(name)
    harder = [e.detail for e in robot.safeguards.events if e.mechanism == "look_harder"]
    return truth, found, harder[-1]


def test_a_thing_the_detector_calls_only_by_a_name_not_asked_about_is_left_by_elimination_in_a_closed_world():
    """A toaster, apple and mug: the detector names the apple and the mug, and the toaster only (surely) as a
    suitcase, which the program does not ask about. Nothing unexplained is of a toaster's size, so the one
    thing of its size and shape that only that name explains is the toaster: everything else is named, so
    it stands unconfirmed, as an elimination (a guess). In a room with things the detector cannot name and no
    toaster (a dumbbell called a suitcase, a can and a tomato named by nothing), it is not found."""
    from attribot.boxes import iou

    calls = {"toaster": "suitcase"}
    closed = SceneConfig(layout="household", seed=1, categories=("toaster", "apple", "mug"), objects=3)
    truth, found, detail = _find_with(closed, CallsOtherwise({"apple", "mug", "toaster"}, calls), "toaster")
    assert [p.evidence for p in found] == ["elimination"]
    assert iou(found[0].box, truth["toaster"]) >= 0.7
    assert "calls only a suitcase" in detail and "everything else here is named" in detail
    truth, found, _ = _find_with(
        ROOM, CallsOtherwise({"apple", "mug", "dumbbell"}, {"dumbbell": "suitcase"}), "toaster"
    )
    assert "toaster" not in truth and found == []


class NamesClassesOtherwise(CallsOtherwise):
    """`CallsOtherwise` as a closed-set detector: each name is its own class (`class_of`), so the priors'
    kinds of a class say what shape its boxes' things have."""

    def class_of(self, name: str) -> str | None:
        return name


def test_a_sure_box_explains_a_place_for_a_closed_world_only_where_the_thing_there_has_its_class_shape():
    """No orange in the room: the tomato, which nothing names, is the one thing of an orange's size left, and
    nothing sees an orange there from nearer. A CD lying flat, boxed surely as a sports ball, is no ball (a
    ball is as tall as it is wide): it is one more thing no name explains, so the world is not closed and
    the inference is dropped (not found). A can boxed surely as a bottle has a bottle's shape: the world
    stays closed around the tomato, and the elimination stands, as a guess."""
    room = SceneConfig(layout="household", seed=2, categories=("apple", "mug", "tomato", "cd"), objects=4)
    flat = NamesClassesOtherwise({"apple", "mug", "cd"}, {"cd": "sports ball"})
    truth, found, detail = _find_with(room, flat, "orange")
    assert "orange" not in truth and found == []
    assert "elimination" in detail and "dropped" in detail
    standing = SceneConfig(
        layout="household", seed=1, categories=("apple", "mug", "tomato", "can"), objects=4
    )
    truth, found, detail = _find_with(
        standing, NamesClassesOtherwise({"apple", "mug", "can"}, {"can": "bottle"}), "orange"
    )
    assert [p.evidence for p in found] == ["elimination"] and "everything else here is named" in detail


def test_an_answer_resting_on_a_faint_box_says_it_is_a_guess_and_one_seen_nearer_does_not():
    """A box the detector scored under its sure score is as often a thing it cannot name as the object named
    (a CD boxed faintly as a bowl that is not in the room): the answer says so plainly. The same object seen
    from nearer, or boxed surely, is no guess."""
    faint = AnswerObject(id=None, category="bowl", box=(0, 0, 1, 1), evidence=("faint box", "measurement"))
    assert faint.guess and "a guess" in _guessed(faint) and "faintly" in _guessed(faint)
    for sure in ("seen nearer", "sure box"):
        obj = AnswerObject(id=None, category="bowl", box=(0, 0, 1, 1), evidence=(sure, "measurement"))
        assert not obj.guess and _guessed(obj) == ""


def test_an_answer_chosen_over_an_object_that_rests_on_a_guess_is_a_guess_too():
    """ "The mug is closer than the toaster", where what was taken for the toaster is a faint box (in a room
    with things the detector cannot name, as often one of them), is no surer than that box: the answer says
    so, naming it. Rivals measured for another quantity, rivals boxed surely and the chosen object's own
    second reading do not make it a guess."""

    class Patch:  # what the answer reads of a patch
        def __init__(self, label: str, box: tuple[float, ...], evidence: str) -> None:
            self.label, self.box, self.evidence, self.object_id = label, box, evidence, None

    def reading(patch: Patch, kind: str, value: float) -> Measurement:
        return Measurement(kind=kind, object_id=None, label=patch.label, value=value, unit="m",
                           box=patch.box, evidence=patch.evidence)  # fmt: skip

    mug = Patch("mug", (10.0, 10.0, 30.0, 30.0), "sure box")
    toaster = Patch("toaster", (50.0, 10.0, 90.0, 40.0), "faint box")
    bowl = Patch("bowl", (100.0, 10.0, 130.0, 30.0), "sure box")
    spoon = Patch("spoon", (140.0, 10.0, 150.0, 40.0), "elimination")
    frame = Frame(rgb=np.zeros((60, 160, 3), np.uint8))

    measured = [
        reading(mug, "distance", 1.2),
        reading(toaster, "distance", 1.9),
        reading(mug, "distance", 1.21),
    ]
    obj = _answer_object(mug, frame, measured)
    assert obj.evidence == ("sure box", "measurement") and obj.rivals_guessed == (
        "toaster: named only faintly by the detector",
    )
    assert (
        obj.guess
        and _guessed(obj) == " (a guess: chosen over the toaster, named only faintly by the detector)"
    )
    measured += [reading(spoon, "distance", 2.0), reading(spoon, "distance", 2.0)]
    assert "and the spoon, taken by elimination)" in _guessed(_answer_object(mug, frame, measured))

    sure = [reading(mug, "distance", 1.2), reading(bowl, "distance", 1.5), reading(toaster, "weight", 0.9)]
    obj = _answer_object(mug, frame, sure)
    assert obj.rivals_guessed == () and not obj.guess and _guessed(obj) == ""
    # a faint second box of the chosen name is another of that name, not "the" one the answer names
    faint_mug = Patch("mug", (50.0, 10.0, 90.0, 40.0), "faint box")
    obj = _answer_object(mug, frame, [reading(mug, "distance", 1.2), reading(faint_mug, "distance", 1.9)])
    assert _guessed(obj) == " (a guess: chosen over another mug, named only faintly by the detector)"
    # the guessed object chosen itself says what it rests on, not what it was chosen over
    obj = _answer_object(toaster, frame, [reading(mug, "distance", 1.2), reading(toaster, "distance", 0.8)])
    assert obj.guess and "faintly, under its sure score" in _guessed(obj)


def test_an_answer_names_what_its_object_rests_on_and_the_measurement_of_it():
    from attribot import Scene, ask

    config = SceneConfig(layout="household", seed=3, categories=("apple", "mug"), objects=2)
    with MujocoWorld(config) as world:
        heaviest = max(world.scene_info().objects, key=lambda o: o.mass_kg)
    answer = ask(
        "Out of the apple and the mug, which one is the heaviest?",
        Scene(config, sensors=["camera", "force"]),
        load_settings(),
    )
    assert answer.object is not None and answer.object.id == heaviest.id
    assert answer.object.evidence == ("sure box", "measurement") and not answer.object.guess


def test_a_measurement_without_a_world_id_is_the_chosen_objects_by_name_and_box():
    class Patch:
        object_id = None
        label = "mug"
        box = (1.0, 2.0, 3.0, 4.0)

    class Reading:
        def __init__(self, label, box):
            self.object_id, self.label, self.box = None, label, box

    mine, other = Reading("mug", (1.0, 2.0, 3.0, 4.0)), Reading("mug", (5.0, 2.0, 7.0, 4.0))
    assert _last_measurement(Patch(), [mine, other]) is mine
    assert _last_measurement(Patch(), [other]) is None


def _absent_item() -> Item:
    return Item(
        id="absent_realroom-000", task="absent_realroom", query="How far away is the toaster?",
        form="comparative", phrasing="paper", layout="household", seed=3, sensors=["camera", "distance"],
        embodied=True, true_id="", true_box=[], absent=["toaster"],
    )  # fmt: skip


def test_a_question_about_an_absent_object_is_right_only_when_no_object_is_named():
    item = _absent_item()
    refused = _record(item, "pa-api", CLEAN, error="no toaster found in the image")
    named = _record(item, "pa-api", CLEAN, box=[1.0, 2.0, 30.0, 40.0], answer="the toaster at ...")
    guessed = _record(item, "pa-api", CLEAN, box=[1.0, 2.0, 30.0, 40.0], guess=True)
    assert refused.right and refused.status == "right"
    assert not named.right and named.status == "wrong" and named.confidently_wrong
    assert guessed.status == "wrong" and not guessed.confidently_wrong


def test_the_report_keeps_confidently_wrong_answers_apart_from_refusals_and_guesses():
    from attribot.eval.report import answer_lines, summarize

    item = _absent_item()
    records = [
        _record(item, "pa-api", CLEAN, error="no toaster found in the image"),
        _record(item, "pa-api", CLEAN, box=[1.0, 2.0, 30.0, 40.0]),
        _record(item, "pa-api", CLEAN, box=[1.0, 2.0, 30.0, 40.0], guess=True),
    ]
    (row,) = summarize(records)
    assert (row["n"], row["right"], row["refused"], row["wrong_guess"], row["confidently_wrong"]) == (
        3,
        1,
        0,
        1,
        1,
    )
    # refusing guesses, the guess on the absent toaster would be no answer: right
    assert row["right_refusing_guesses"] == 2
    assert answer_lines([row]) == [
        "absent_realroom pa-api clean: 1/3 right (0.33), 0 refused, 1 wrong as a guess, 1 confidently wrong; "
        "with its 1 guess refused: 2/3 right"
    ]
    # a guess on an object that is there would be no answer too: right no longer
    present = _absent_item().model_copy(
        update={"absent": [], "true_id": "toaster_0", "true_box": [1, 2, 30, 40]}
    )
    right_guess = _record(present, "pa-api", CLEAN, box=[1.0, 2.0, 30.0, 40.0], guess=True)
    assert right_guess.right and not right_guess.right_refusing_guesses
    # a record written before `absent` was kept reads it from its truth: no true object, not there
    from attribot.eval.methods import Record

    for record, absent in ((records[2], True), (right_guess, False)):
        legacy = record.model_dump()
        del legacy["absent"]
        assert Record.model_validate(legacy).absent is absent


def test_a_sure_box_on_a_thing_of_no_size_the_name_has_is_set_aside():
    """The tomato (6-8 cm) boxed surely as a basketball (24 cm across) is not the basketball asked about: the
    room holds none, and the answer is not found."""
    with MujocoWorld(ROOM) as world:
        robot, image = _robot_image(world, SeesOnly({"apple", "mug"}))
        image.perception = Perception(
            detector=CallsItA({"apple", "mug"}, "tomato", "basketball"),
            vqa=image.perception.vqa,
            language=image.perception.language,
        )
        image.nearer = None
        assert image.perception.detector.detect(image.frame, ["basketball"])  # it does box it, surely
        assert image.find("basketball") == []
    harder = [e for e in robot.safeguards.events if e.mechanism == "look_harder"]
    assert "set aside" in harder[-1].detail

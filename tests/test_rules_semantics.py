"""What the rules planner's programs choose: each program runs in-process against small fake ImagePatch and
Robot classes with known boxes (y grows upward, as in the API), and must return the right object."""

from __future__ import annotations

import math

import pytest

from attribot.planning.rules import rules_program

GENERIC = {"item", "object", "thing", "one"}


class FakePatch:
    """An ImagePatch stand-in: a box (left, lower, right, upper; y up), a label, a colour, a mass, a range."""

    def __init__(self, label, box, color="", kg=1.0, metres=1.0, scene=None):
        self.label, self.color, self.kg, self.metres = label, color, kg, metres
        self.left, self.lower, self.right, self.upper = box
        self.width = self.right - self.left
        self.height = self.upper - self.lower
        self.horizontal_center = (self.left + self.right) / 2
        self.vertical_center = (self.lower + self.upper) / 2
        self.area = self.width * self.height
        self.scene = scene or []
        self.asked: list[str] = []

    def __repr__(self):
        return f"<{self.label} {self.left:.0f},{self.lower:.0f}>"

    def find(self, name):
        name = name.lower().strip()
        return [p for p in self.scene if name in GENERIC or name.rstrip("s") == p.label or name == p.label]

    def visual_query(self, question):
        self.asked.append(question)
        if question == "What is this?":
            return self.label
        if question == "What are the items in this image?":
            return ", ".join(p.label for p in self.scene)
        if question.startswith("What color"):
            return self.color
        return "unknown"

    def language_query(self, question):
        self.asked.append(question)
        # a knowledgeable language model: the named item with the largest (or smallest) typical mass
        named = [p for p in self.scene if p.label in question]
        if not named:
            return "unknown"
        pick = max if "heaviest" in question else min
        return "The " + pick(named, key=lambda p: p.kg).label + "."


class FakeRobot:
    """A Robot stand-in that checks the preconditions the real one enforces and records every call."""

    def __init__(self, sensors):
        self.sensors = list(sensors)
        self.held = None
        self.calls: list[tuple[str, object]] = []

    def go_to_object(self, patch):
        self.calls.append(("go_to_object", patch))

    def pick_up(self, patch):
        assert self.held is None, "picked up with the gripper full"
        self.held = patch
        self.calls.append(("pick_up", patch))

    def measure_weight(self, patch):
        assert "force" in self.sensors
        assert self.held is patch, "weighed an object that is not held"
        self.calls.append(("measure_weight", patch))
        return patch.kg

    def put_down(self):
        assert self.held is not None
        self.held = None
        self.calls.append(("put_down", None))

    def focus_on_patch(self, patch):
        self.calls.append(("focus_on_patch", patch))

    def measure_distance(self, patch):
        assert "distance" in self.sensors
        self.calls.append(("measure_distance", patch))
        return patch.metres


def scene(*patches):
    image = FakePatch("image", (0, 0, 1000, 1000), scene=list(patches))
    for p in patches:
        p.scene = image.scene
    return image


def run(query, image, sensors=("camera",), embodied=False, robot=None):
    source = rules_program(query, sensors, embodied)
    namespace = {"math": math}
    exec(compile(source, "<program>", "exec"), namespace)
    return namespace["execute_command"](image, robot or FakeRobot(sensors))


def row_of(label, n, y=400, size=60, step=100, x0=50, **kw):
    return [FakePatch(f"{label}", (x0 + i * step, y, x0 + i * step + size, y + size), **kw) for i in range(n)]


def grid(label, rows, cols, ys, jitter=0.0):
    """Patches in rows at the given vertical positions (y up), columns 100 px apart; jitter moves odd ones."""
    out = {}
    for r, y in enumerate(ys):
        for c in range(cols):
            dy = jitter if (r + c) % 2 else -jitter
            out[(r, c)] = FakePatch(label, (100 + c * 100, y + dy, 160 + c * 100, y + dy + 50))
    return out


# ---- location --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("query", "index"),
    [
        ("the second dog from the right", 3),
        ("the first dog from the left", 0),
        ("the third dog from the left", 2),
        ("leftmost dog", 0),
        ("rightmost dog", 4),
        ("2nd dog starting from the left", 1),
        ("dog in the middle", 2),
        ("the last dog", 4),
        ("the second to last dog", 3),
        ("the first dog", 0),
    ],
)
def test_ordinals_in_a_row_of_five(query, index):
    dogs = row_of("dog", 5)
    # shuffle the detection order: the program must order by position, not by score
    image = scene(*[dogs[i] for i in (3, 0, 4, 1, 2)], FakePatch("cat", (900, 900, 950, 950)))
    assert run(query, image) is dogs[index]


def test_second_umbrella_from_the_left_in_the_second_to_last_row():
    # four rows squeezed into the top half of a 1000 px image: cutting the image into equal bands would
    # put several rows in one band, clustering the centres does not
    ys = [900, 820, 740, 660]  # top row first (y up)
    cells = grid("umbrella", 4, 4, ys, jitter=8)
    image = scene(*reversed(list(cells.values())))
    assert run("the second umbrella from the left at the second to last row", image) is cells[(2, 1)]
    assert run("first umbrella from the left on the second row from the bottom", image) is cells[(2, 0)]
    assert run("second umbrella from the right in the top row", image) is cells[(0, 2)]
    assert run("top right umbrella", image) is cells[(0, 3)]
    assert run("bottom left umbrella", image) is cells[(3, 0)]


@pytest.mark.parametrize(
    ("query", "cell"),
    [
        ("the pill in the middle of the right column", (1, 2)),
        ("pill in the middle of the first column", (1, 0)),
        ("middle pill in top row", (0, 1)),
        ("middle pill at the bottom", (2, 1)),
        ("pill in the middle of the second row from the top", (1, 1)),
        ("topmost pill from the second column", (0, 1)),
        ("second pill from the right on the third line from the bottom", (0, 1)),
        ("rightmost pill in the middle row", (1, 2)),
        ("rightmost pill in the middle", (1, 2)),
        ("second pill at the bottom", (2, 1)),
        ("middle pill on the right", (1, 2)),
        ("pill in the middle", (1, 1)),
        ("right pill at the top row", (0, 2)),
        ("bottom right pill", (2, 2)),
        ("pill at the very bottom", None),  # three share the bottom row: the lowest box wins, checked below
    ],
)
def test_rows_columns_and_middles_in_a_three_by_three_grid(query, cell):
    cells = grid("pill", 3, 3, [700, 500, 300], jitter=0)
    cells[(2, 0)].lower -= 5  # make one bottom-row pill stick out lowest
    cells[(2, 0)].vertical_center -= 2.5
    image = scene(*cells.values())
    chosen = run(query, image)
    assert chosen is (cells[cell] if cell else cells[(2, 0)])


def test_rows_follow_the_objects_when_the_grid_is_slanted_and_uneven():
    # rows 60 px apart, wobbling by +-12 px: cutting the 1000 px image into 3 bands would mix them
    ys = [560, 500, 440]
    cells = grid("egg", 3, 5, ys, jitter=12)
    image = scene(*cells.values())
    assert run("second egg at the third row from the top", image) is cells[(2, 1)]
    assert run("fourth egg on the second row", image) is cells[(1, 3)]


def test_colour_words_filter_with_vqa():
    books = [
        FakePatch("book", (100, 100, 150, 200), color="black"),
        FakePatch("book", (300, 100, 350, 200), color="black"),
        FakePatch("book", (500, 100, 550, 200), color="red"),
    ]
    image = scene(*books)
    assert run("rightmost black book", image) is books[1]
    assert all(q == "What color is this object?" for b in books for q in b.asked)


def test_nothing_found_and_ordinals_beyond_the_count_are_clear_errors():
    image = scene(*row_of("dog", 3))
    with pytest.raises(ValueError, match="asked for the 5th dog from the right, but only 3 were found"):
        run("the fifth dog from the right", image)
    with pytest.raises(ValueError, match="asked for the 1000th dog"):
        run("the 1000th dog from the left", image)
    with pytest.raises(ValueError, match="no cat found"):
        run("the second cat from the left", image)
    with pytest.raises(ValueError, match="form only 1 row"):
        run("second dog in the third row", image)


# ---- size ----------------------------------------------------------------------------------------------


def test_long_and_short_follow_the_orientation_of_the_object():
    upright_a = FakePatch("pepper", (100, 100, 120, 160))  # long side 60 (vertical)
    lying = FakePatch("pepper", (300, 100, 370, 130))  # long side 70 (horizontal), lowest box
    upright_b = FakePatch("pepper", (500, 100, 520, 165))  # long side 65
    image = scene(upright_a, lying, upright_b)
    assert run("the shortest pepper", image) is upright_a  # by height it would be the lying one
    assert run("the short pepper", image) is upright_a
    assert run("the longest pepper", image) is lying
    assert run("the tallest pepper", image) is upright_b  # tall is height


@pytest.mark.parametrize(
    ("query", "index"),
    [
        ("the tallest item", 2),
        ("third tallest item", 0),
        ("the third tall item", 0),
        ("the smallest item", 3),
        ("the biggest item", 2),
        ("least wide item", 1),
        ("the widest item", 0),
        ("the thin item", 1),
    ],
)
def test_size_superlatives_absolutes_and_ranks(query, index):
    items = [
        FakePatch("box", (0, 0, 100, 50)),  # 100 x 50, area 5000
        FakePatch("bottle", (200, 0, 220, 90)),  # 20 x 90, area 1800
        FakePatch("lamp", (300, 0, 360, 120)),  # 60 x 120, area 7200
        FakePatch("cup", (400, 0, 440, 40)),  # 40 x 40, area 1600
    ]
    assert run(query, scene(*items)) is items[index]


def test_size_with_a_colour_and_a_category():
    apples = [
        FakePatch("apple", (0, 0, 50, 50), color="red"),
        FakePatch("apple", (100, 0, 130, 30), color="green"),
        FakePatch("apple", (200, 0, 240, 40), color="red"),
    ]
    image = scene(*apples, FakePatch("flamingo", (400, 0, 420, 300)))
    assert run("the smallest red apple", image) is apples[2]
    assert run("the tall flamingo", image).label == "flamingo"


# ---- weight and distance ----------------------------------------------------------------------------------


def test_weight_is_measured_with_a_force_sensor():
    items = [
        FakePatch("mug", (0, 0, 50, 50), kg=0.3),
        FakePatch("book", (100, 0, 150, 50), kg=0.9),
        FakePatch("apple", (200, 0, 250, 50), kg=0.2),
    ]
    robot = FakeRobot(["camera", "force"])
    assert run("the heaviest item", scene(*items), ("camera", "force"), True, robot) is items[1]
    names = [name for name, _ in robot.calls]
    assert names == ["go_to_object", "pick_up", "measure_weight", "put_down"] * 3
    robot = FakeRobot(["camera", "force"])
    query = "Out of the mug, the book and the apple, which one is the most lightweight?"
    assert run(query, scene(*items), ("camera", "force"), True, robot) is items[2]
    assert robot.held is None


def test_weight_without_a_force_sensor_asks_vqa_then_the_language_model():
    items = [
        FakePatch("feather", (0, 0, 50, 50), kg=0.01),
        FakePatch("car", (100, 0, 150, 50), kg=1500),
        FakePatch("dog", (200, 0, 250, 50), kg=20),
    ]
    image = scene(*items)
    assert run("the heaviest item", image) is items[1]
    assert image.asked[0] == "What are the items in this image?"
    assert "feather, car, dog" in image.asked[1] and "heaviest" in image.asked[1]
    query = "Out of the a feather, a car, and a dog, which one is the most lightweight?"
    assert run(query, scene(*items)) is items[0]


def test_a_language_model_that_cannot_tell_makes_the_program_fail_clearly():
    items = [FakePatch("gizmo", (0, 0, 50, 50)), FakePatch("widget", (100, 0, 150, 50))]
    image = scene(*items)
    image.language_query = lambda question: "unknown"  # e.g. the catalog does not know these words
    with pytest.raises(ValueError, match="could not tell which item is the heaviest"):
        run("the heaviest item", image)


def test_distance_is_measured_with_a_distance_sensor_and_estimated_without():
    laptop = FakePatch("laptop", (100, 300, 200, 360), metres=2.5)  # lower in the picture
    tv = FakePatch("tv", (400, 500, 600, 650), metres=1.2)
    robot = FakeRobot(["camera", "distance"])
    query = "Is the laptop or the tv closer to me?"
    assert run(query, scene(laptop, tv), ("camera", "distance"), True, robot) is tv
    assert [n for n, _ in robot.calls] == ["focus_on_patch", "measure_distance"] * 2
    # no sensor: the visual proxy (the lower bottom edge is closer) says laptop, and says it is a proxy
    assert run(query, scene(laptop, tv)) is laptop
    assert (
        run(
            "the farthest chair",
            scene(FakePatch("chair", (0, 10, 10, 20)), far := FakePatch("chair", (0, 50, 10, 60))),
        )
        is far
    )


def test_weight_of_coloured_items_without_a_force_sensor_names_each_then_asks():
    items = [
        FakePatch("feather", (0, 0, 50, 50), color="red", kg=0.01),
        FakePatch("car", (100, 0, 150, 50), color="blue", kg=1500),
        FakePatch("dog", (200, 0, 250, 50), color="red", kg=20),
    ]
    image = scene(*items)
    assert run("the heaviest red item", image) is items[2]  # the car is heavier, but blue
    assert "feather, dog" in image.asked[-1]


def test_several_objects_of_one_kind_without_a_force_sensor_use_a_stated_size_proxy():
    apples = [FakePatch("apple", (0, 0, 50, 50)), FakePatch("apple", (100, 0, 180, 80))]
    assert run("the heaviest apple", scene(*apples)) is apples[1]
    assert "proxy" in rules_program("the heaviest apple")


# ---- "than" comparisons and grounding ------------------------------------------------------------------


def test_than_comparisons_answer_yes_or_no_with_the_one_that_is():
    """Issue 17: "Is the apple heavier than the book?" answers no (it used to answer with the book alone),
    with the one that is heavier and both values."""
    apple = FakePatch("apple", (0, 0, 50, 50), kg=0.2)
    book = FakePatch("book", (100, 0, 150, 50), kg=0.9)
    robot = FakeRobot(["camera", "force"])
    query = "Is the apple heavier than the book?"
    said = run(query, scene(apple, book), ("camera", "force"), True, robot)
    assert said["yes"] is False and said["object"] is book and said["value"] == 0.9 and said["unit"] == "kg"
    assert "0.2 kg" in said["text"] and "0.9 kg" in said["text"] and "lighter" in said["text"]
    assert [n for n, _ in robot.calls].count("measure_weight") == 2
    said = run("Is the book heavier than the apple?", scene(apple, book))  # by reasoning
    assert said["yes"] is True and said["object"] is book
    said = run("Is the apple lighter than the book?", scene(apple, book))
    assert said["yes"] is True and said["object"] is apple
    lamp = FakePatch("lamp", (0, 0, 50, 50), metres=3.0)
    chair = FakePatch("chair", (100, 0, 150, 50), metres=1.0)
    query = "Is the lamp closer to me than the chair?"
    said = run(query, scene(lamp, chair), ("camera", "distance"), True)
    assert said["yes"] is False and said["object"] is chair and said["unit"] == "m"
    said = run(
        "Is the lamp farther from me than the chair?", scene(lamp, chair), ("camera", "distance"), True
    )
    assert said["yes"] is True and said["object"] is lamp
    said = run("Is the lamp to the left of the chair?", scene(lamp, chair))
    assert said["yes"] is True and said["object"] is lamp and said["unit"] == "px"


def test_grounding_returns_the_best_match_and_filters_by_colour():
    mugs = [FakePatch("mug", (0, 0, 50, 50), color="blue"), FakePatch("mug", (100, 0, 150, 50), color="red")]
    for query in ("Where is the mug?", "find the mug", "point at the mug", "Can you find the mug?"):
        assert run(query, scene(*mugs)) is mugs[0]  # find lists the best match first
    assert run("find the red mug", scene(*mugs)) is mugs[1]
    with pytest.raises(ValueError, match="no cup found"):
        run("Where is the cup?", scene(*mugs))


def test_measurements_measure_the_best_match_and_return_it():
    lamp = FakePatch("lamp", (0, 0, 50, 50), metres=3.0, kg=2.0)
    other = FakePatch("lamp", (100, 0, 150, 50), metres=1.0, kg=1.0)
    robot = FakeRobot(["camera", "distance"])
    assert run("How far away is the lamp?", scene(lamp, other), ("camera", "distance"), True, robot) is lamp
    assert robot.calls == [("focus_on_patch", lamp), ("measure_distance", lamp)]
    robot = FakeRobot(["camera", "force"])
    assert run("How much does the lamp weigh?", scene(lamp, other), ("camera", "force"), True, robot) is lamp
    assert [n for n, _ in robot.calls] == ["go_to_object", "pick_up", "measure_weight", "put_down"]
    assert robot.held is None


@pytest.mark.parametrize(
    ("query", "sensors", "embodied", "match"),
    [
        ("How heavy is the apple?", ("camera",), True, "no force sensor"),
        ("How far away is the apple?", ("camera", "force"), True, "no distance sensor"),
        ("How far away is the apple?", ("camera", "distance"), False, "still image has no robot"),
    ],
)
def test_a_measurement_without_its_sensor_is_refused_before_running(query, sensors, embodied, match):
    from attribot.errors import InputError

    with pytest.raises(InputError, match=match) as info:
        rules_program(query, sensors, embodied)
    assert "--sensors camera," in info.value.fix and "comparison" in info.value.fix


# ---- a side, row or column around any family ---------------------------------------------------------------


@pytest.mark.parametrize(
    ("query", "expected"),
    [
        ("the heaviest item on the left side", "left_heavy"),
        ("which thing on the right is the heaviest?", "right_heavy"),
        ("which object in the top row is the lightest?", "top_light"),
        ("the heaviest object in the bottom row", "left_heavy"),
        ("the lightest mug in the second column from the right", "top_mid"),
    ],
)
def test_a_side_row_or_column_scopes_the_choice(query, expected):
    # two rows of three (y up: the top row has the larger vertical centre); the heaviest of all is on the
    # right in the top row, so a scope that is not applied picks it instead
    patches = {
        "top_light": FakePatch("mug", (100, 600, 160, 660), kg=0.1),
        "top_mid": FakePatch("mug", (400, 600, 460, 660), kg=0.2),
        "right_heavy": FakePatch("mug", (700, 600, 760, 660), kg=9.0),
        "left_heavy": FakePatch("mug", (100, 300, 160, 360), kg=5.0),
        "mid_low": FakePatch("mug", (400, 300, 460, 360), kg=0.3),
        "right_low": FakePatch("mug", (700, 300, 760, 360), kg=0.4),
    }
    image = scene(*patches.values())
    chosen = run(query, image, sensors=("camera", "force"), embodied=True)
    assert chosen is patches[expected]


def test_a_side_of_a_named_surface_is_that_side_of_the_surface():
    # a table on the right half of the picture: "on the left side of the table" is left of its middle
    table = FakePatch("table", (500, 200, 900, 400))
    inner_left = FakePatch("cup", (560, 380, 600, 420), kg=1.0)
    inner_right = FakePatch("cup", (800, 380, 840, 420), kg=2.0)
    picture_left = FakePatch("cup", (100, 50, 140, 90), kg=3.0)  # on the floor, left of the picture
    image = scene(table, inner_left, inner_right, picture_left)
    query = "which is the heaviest cup on the left side of the table?"
    chosen = run(query, image, sensors=("camera", "force"), embodied=True)
    assert chosen is inner_left

"""The household object catalog: what the simulator can build and what is true of each kind of object.

Each `Category` gives a name, synonyms, a shape (the name of a builder in `attribot.sim.shapes` that
makes the object from primitives), a size range (the object's longest dimension, metres), colour
options, a realistic mass range (kilograms), whether the robot may pick it up, where it is placed (on
furniture or on the floor), and whether its look tells its weight.

Deceptive categories are the point of the paper: a closed cardboard box may be empty or full, a ball may
be hollow or solid, and they look the same. Their `mass_variants` list the hidden states; a scene draws
one of them, and only a measurement settles which. This module is plain data with no MuJoCo import, so
language backends can read it cheaply.

Beyond weight, objects carry states no camera sees, drawn per scene (`attribot.sim.scene`): a temperature
(`temperatures`: a kettle hot or cold, a mug of coffee hot, a can from the fridge cold; anything not listed
is at the room's temperature), a stiffness (`stiffness`, newtons per millimetre of gripper closure: a foam
ball soft, a tennis ball firm, an apple hard; `RIGID_N_PER_MM` when not listed) and, for containers, how
full they are (`fill_states`, with the empty container's mass `empty_kg`, within the category's mass range,
and the mass of the contents when full `capacity_kg`, which may take a full one past that range: a mug of
coffee is heavier than any empty mug). Categories with `drawn=False` appear only where a
scene names them (the layouts never draw them), so that adding one leaves every existing scene as it was.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cache

from attribot.errors import UnknownName
from attribot.lexicon import singular_forms
from attribot.sim.shapes import build_shape

__all__ = [
    "COLORS",
    "Category",
    "categories",
    "get_category",
    "find_category",
    "category_names",
    "RIGID_N_PER_MM",
    "ROOM_TEMPERATURE_C",
]

RIGID_N_PER_MM = 30.0
"""The stiffness of an object whose category states none: it does not give under the gripper."""
ROOM_TEMPERATURE_C = (19.0, 24.0)
"""The range a scene's room temperature is drawn from (degrees Celsius); objects with no thermal state of
their own are at it."""

Range = tuple[float, float]

# Colour names (each in attribot.lexicon.COLOR_WORDS) and their linear RGB; the colour name of an object is
# what VQA answers and detectors filter on.
COLORS: dict[str, tuple[float, float, float]] = {
    "red": (0.80, 0.10, 0.10),
    "green": (0.15, 0.60, 0.20),
    "blue": (0.15, 0.30, 0.85),
    "yellow": (0.95, 0.85, 0.15),
    "orange": (0.95, 0.50, 0.10),
    "purple": (0.50, 0.20, 0.65),
    "pink": (0.95, 0.55, 0.70),
    "brown": (0.50, 0.30, 0.15),
    "black": (0.08, 0.08, 0.08),
    "white": (0.92, 0.92, 0.90),
    "gray": (0.50, 0.50, 0.52),
    "silver": (0.75, 0.76, 0.78),
    "beige": (0.85, 0.75, 0.58),
    "teal": (0.10, 0.55, 0.55),
}


@dataclass(frozen=True)
class Category:
    """One kind of household object.

    size_range_m: (min, max) of the longest dimension in metres. mass_range_kg: (min, max) over all
    variants. mass_variants: `(state, (min, max))` pairs for objects whose look hides their weight
    (deceptive), empty otherwise. placement: "surface" (tables, counters, shelves) or "floor".
    """

    name: str
    synonyms: tuple[str, ...]
    shape: str
    size_range_m: tuple[float, float]
    colors: tuple[str, ...]
    mass_range_kg: tuple[float, float]
    pickable: bool = True
    deceptive: bool = False
    mass_variants: tuple[tuple[str, tuple[float, float]], ...] = ()
    placement: str = "surface"
    temperatures: tuple[tuple[str, Range | None], ...] = ()  # hidden thermal states (None: room temperature)
    stiffness: tuple[tuple[str, Range], ...] = ()  # hidden softness states, N/mm; () is RIGID_N_PER_MM
    empty_kg: Range | None = None  # a container's own mass, empty
    capacity_kg: float = 0.0  # the mass of its contents when full (0: not a container)
    fill_states: tuple[tuple[str, float], ...] = ()  # hidden fullness states: (name, share of capacity)
    drawn: bool = True  # layouts draw it unasked (False: only where a scene names it)

    @property
    def container(self) -> bool:
        """Whether it holds contents whose mass a weighing against `empty_kg` reveals."""
        return self.capacity_kg > 0 and self.empty_kg is not None

    @property
    def typical_mass_kg(self) -> float:
        """The geometric mean of the mass range: a fair single number for comparisons."""
        lo, hi = self.mass_range_kg
        return float((lo * hi) ** 0.5)

    @property
    def words(self) -> tuple[str, ...]:
        """The name and synonyms, lower case."""
        return (self.name, *self.synonyms)

    @property
    def height_range_m(self) -> tuple[float, float]:
        """(min, max) of its height standing as it is put (a knife lies flat: 1 to 2 cm; a toaster stands
        16 to 20 cm): its shape's height at the smallest and largest size."""
        return _heights(self.shape, self.size_range_m)

    @property
    def across_range_m(self) -> tuple[float, float]:
        """(min, max) of its longest span across what it stands on, as it is put (a knife lying flat: its
        length; a bottle standing: its girth): its shape's at the smallest and largest size."""
        return _acrosses(self.shape, self.size_range_m)


def _c(
    name: str,
    synonyms: tuple[str, ...],
    shape: str,
    size: tuple[float, float],
    colors: tuple[str, ...],
    mass: tuple[float, float],
    *,
    pickable: bool = True,
    variants: tuple[tuple[str, tuple[float, float]], ...] = (),
    placement: str = "surface",
    temperatures: tuple[tuple[str, Range | None], ...] = (),
    stiffness: tuple[tuple[str, Range], ...] = (),
    contents: tuple[Range, float] | None = None,
    fill: tuple[tuple[str, float], ...] = (("empty", 0.0), ("full", 1.0)),
    drawn: bool = True,
) -> Category:
    if variants:
        mass = (min(v[1][0] for v in variants), max(v[1][1] for v in variants))
    empty, capacity = contents if contents is not None else (None, 0.0)
    if empty is not None and not mass[0] <= empty[0] <= empty[1] <= mass[1]:
        raise ValueError(f"{name}: its empty mass {empty} lies outside its mass range {mass}")
    return Category(
        name,
        synonyms,
        shape,
        size,
        colors,
        mass,
        pickable,
        bool(variants),
        variants,
        placement,
        temperatures,
        stiffness,
        empty,
        capacity,
        fill if contents is not None else (),
        drawn,
    )


_HOT_DRINK = (("hot", (55.0, 70.0)), ("room", None))
_FROM_THE_FRIDGE = (("cold", (3.0, 7.0)), ("room", None))
_SOFT, _FIRM, _HARD = (0.15, 0.4), (2.0, 4.0), (10.0, 18.0)


_DATA: tuple[Category, ...] = (
    # kitchen
    _c(
        "apple",
        ("fruit",),
        "apple",
        (0.07, 0.09),
        ("red", "green", "yellow"),
        (0.15, 0.25),
        stiffness=(("hard", _HARD),),
    ),
    _c("tomato", (), "tomato", (0.06, 0.08), ("red",), (0.10, 0.18), stiffness=(("firm", (1.0, 2.0)),)),
    _c("potato", (), "potato", (0.08, 0.12), ("beige", "brown"), (0.15, 0.30)),
    _c("carrot", (), "carrot", (0.15, 0.20), ("orange",), (0.05, 0.10)),
    _c("egg", (), "egg", (0.05, 0.06), ("white", "beige"), (0.05, 0.065)),
    _c("banana", (), "banana", (0.17, 0.21), ("yellow",), (0.10, 0.15), stiffness=(("firm", _FIRM),)),
    _c(
        "orange", ("citrus",), "orange", (0.07, 0.09), ("orange",), (0.14, 0.22), stiffness=(("firm", _FIRM),)
    ),
    _c(
        "mug",
        ("cup", "coffee mug", "coffee cup"),
        "mug",
        (0.09, 0.11),
        ("white", "red", "blue", "yellow", "green"),
        (0.25, 0.40),
        temperatures=_HOT_DRINK,
        contents=((0.25, 0.40), 0.25),  # a mug of coffee weighs its own mass and a quarter of a kilogram more
    ),
    _c("bowl", (), "bowl", (0.14, 0.20), ("white", "blue", "red", "beige"), (0.25, 0.50)),
    _c("plate", ("dish",), "plate", (0.20, 0.27), ("white", "blue", "beige"), (0.35, 0.60)),
    _c(
        "pot",
        ("cooking pot", "saucepan", "stockpot"),
        "pot",
        (0.22, 0.30),
        ("silver", "black", "red"),
        (1.2, 2.5),
    ),
    _c("pan", ("frying pan", "skillet"), "pan", (0.38, 0.48), ("black", "silver"), (0.8, 1.6)),
    _c("knife", ("kitchen knife",), "knife", (0.20, 0.28), ("black", "brown"), (0.06, 0.15)),
    _c("fork", (), "fork", (0.17, 0.20), ("silver",), (0.03, 0.05)),
    _c("spoon", ("teaspoon", "tablespoon"), "spoon", (0.15, 0.19), ("silver",), (0.02, 0.05)),
    _c("ladle", (), "ladle", (0.28, 0.34), ("silver", "black"), (0.10, 0.20)),
    _c("toaster", (), "toaster", (0.25, 0.30), ("silver", "red", "black", "white"), (1.5, 2.5)),
    _c(
        "teapot",
        ("tea pot",),
        "teapot",
        (0.18, 0.24),
        ("white", "blue", "brown", "red"),
        (0.6, 1.1),
        temperatures=(("hot", (60.0, 85.0)), ("room", None)),
    ),
    _c(
        "kettle",
        ("electric kettle",),
        "kettle",
        (0.22, 0.26),
        ("silver", "black", "white"),
        (0.9, 1.4),
        temperatures=(("hot", (80.0, 95.0)), ("room", None)),  # just boiled, or not switched on
    ),
    _c(
        "bottle",
        ("water bottle",),
        "bottle",
        (0.20, 0.28),
        ("green", "blue", "teal", "white"),
        (0.4, 0.9),
        temperatures=_FROM_THE_FRIDGE,
        contents=((0.40, 0.45), 0.45),  # a glass bottle, and what it holds when full
    ),
    _c(
        "can",
        ("soda can", "tin", "tin can"),
        "can",
        (0.11, 0.13),
        ("red", "silver", "blue", "green"),
        (0.33, 0.40),
        temperatures=_FROM_THE_FRIDGE,
    ),
    _c(
        "jar",
        ("pot jar", "container"),
        "jar",
        (0.12, 0.16),
        ("white", "brown", "red"),
        (0.1, 1.2),
        variants=(("empty", (0.10, 0.20)), ("full", (0.8, 1.2))),
        contents=((0.10, 0.20), 0.85),  # how full it is is its mass variant (the state it was drawn in)
    ),
    _c("cutting board", ("chopping board",), "cutting_board", (0.30, 0.40), ("brown", "beige"), (0.6, 1.2)),
    # living room and office
    _c(
        "laptop",
        ("notebook computer", "computer"),
        "laptop",
        (0.32, 0.38),
        ("silver", "gray", "black"),
        (1.2, 2.2),
    ),
    _c(
        "book",
        ("novel", "textbook"),
        "book",
        (0.18, 0.26),
        ("red", "blue", "green", "yellow", "purple", "brown"),
        (0.25, 0.9),
    ),
    _c("cd", ("compact disc", "disc", "dvd"), "cd", (0.12, 0.12), ("silver",), (0.015, 0.02)),
    _c(
        "cell phone",
        ("phone", "smartphone", "mobile phone", "cellphone"),
        "phone",
        (0.14, 0.16),
        ("black", "white", "silver"),
        (0.14, 0.22),
    ),
    _c(
        "remote control",
        ("remote", "tv remote", "controller"),
        "remote",
        (0.16, 0.20),
        ("black", "gray"),
        (0.08, 0.15),
    ),
    _c("pencil", (), "pencil", (0.15, 0.19), ("yellow", "red", "blue", "green"), (0.005, 0.01)),
    _c(
        "vase", ("flower vase",), "vase", (0.20, 0.30), ("blue", "white", "teal", "red", "purple"), (0.5, 1.5)
    ),
    _c("cactus", ("potted cactus", "succulent"), "cactus", (0.18, 0.28), ("green",), (0.4, 1.0)),
    _c(
        "lamp",
        ("table lamp", "desk lamp"),
        "lamp",
        (0.35, 0.45),
        ("white", "beige", "black", "teal"),
        (1.0, 2.5),
    ),
    _c("candle", (), "candle", (0.08, 0.15), ("white", "red", "beige", "purple"), (0.08, 0.30)),
    _c("alarm clock", ("clock",), "clock", (0.10, 0.14), ("red", "black", "white", "blue"), (0.15, 0.40)),
    _c("stapler", (), "stapler", (0.13, 0.18), ("black", "red", "blue"), (0.15, 0.35)),
    _c("scissors", (), "scissors", (0.15, 0.20), ("red", "black", "blue", "orange"), (0.05, 0.10)),
    _c("computer mouse", ("mouse",), "mouse", (0.10, 0.12), ("black", "white", "gray"), (0.07, 0.12)),
    _c("keyboard", ("computer keyboard",), "keyboard", (0.40, 0.45), ("black", "white", "gray"), (0.5, 1.0)),
    _c(
        "painting",
        ("picture", "picture frame", "framed picture"),
        "painting",
        (0.25, 0.40),
        ("blue", "green", "red", "yellow"),
        (0.5, 2.0),
    ),
    _c(
        "pillow",
        ("cushion",),
        "pillow",
        (0.40, 0.50),
        ("white", "blue", "yellow", "red", "green", "beige"),
        (0.3, 0.8),
        placement="floor",
        stiffness=(("soft", (0.1, 0.3)),),
    ),
    _c("basketball", ("ball",), "basketball", (0.24, 0.24), ("orange",), (0.57, 0.65), placement="floor"),
    _c(
        "tennis racket",
        ("racket", "racquet"),
        "racket",
        (0.66, 0.70),
        ("blue", "red", "black", "white"),
        (0.28, 0.34),
        placement="floor",
    ),
    _c("broom", (), "broom", (1.1, 1.3), ("yellow", "red", "blue", "brown"), (0.5, 1.0), placement="floor"),
    _c(
        "dumbbell",
        ("hand weight", "barbell"),
        "dumbbell",
        (0.22, 0.30),
        ("black", "gray", "blue", "purple"),
        (2.0, 5.0),
    ),
    _c("hammer", (), "hammer", (0.28, 0.33), ("black", "red", "yellow"), (0.45, 0.75)),
    _c(
        "sponge",
        (),
        "sponge",
        (0.09, 0.12),
        ("yellow", "green", "blue", "pink"),
        (0.01, 0.03),
        stiffness=(("soft", (0.08, 0.2)),),
    ),
    _c("feather", (), "feather", (0.15, 0.25), ("white", "gray", "teal"), (0.001, 0.004)),
    _c(
        "tissue box",
        ("tissues", "kleenex"),
        "tissue_box",
        (0.20, 0.24),
        ("blue", "white", "pink", "green"),
        (0.15, 0.30),
    ),
    # deceptive: the look does not tell the weight
    _c(
        "box",
        ("cardboard box", "closed box", "carton", "package", "parcel"),
        "carton",
        (0.20, 0.30),
        ("brown", "beige"),
        (0.2, 6.0),
        variants=(("empty", (0.2, 0.4)), ("full", (4.0, 6.0))),
        contents=((0.2, 0.4), 4.7),  # how full it is is its mass variant
    ),
    _c(
        "ball",
        ("rubber ball", "toy ball", "sphere"),
        "ball",
        (0.09, 0.11),
        ("red", "blue", "green", "yellow"),
        (0.05, 2.5),
        variants=(("hollow", (0.05, 0.08)), ("solid", (1.8, 2.5))),
        stiffness=(("soft", _SOFT), ("firm", _FIRM), ("hard", _HARD)),  # foam, rubber or plastic: unseen
    ),
    _c(
        "toy block",
        ("block", "cube", "wooden block"),
        "block",
        (0.06, 0.08),
        ("red", "blue", "green", "yellow"),
        (0.02, 0.5),
        variants=(("foam", (0.02, 0.04)), ("metal", (0.35, 0.50))),
    ),
    _c(
        "suitcase",
        ("luggage", "travel case"),
        "suitcase",
        (0.55, 0.65),
        ("black", "blue", "red", "gray"),
        (2.5, 20.0),
        pickable=False,
        variants=(("empty", (2.5, 4.0)), ("packed", (14.0, 20.0))),
        placement="floor",
    ),
    _c(
        "backpack",
        ("bag", "rucksack", "school bag"),
        "backpack",
        (0.40, 0.48),
        ("black", "blue", "red", "green"),
        (0.5, 8.0),
        variants=(("empty", (0.5, 0.9)), ("full", (5.0, 8.0))),
        placement="floor",
        contents=((0.5, 0.9), 5.8),
    ),
    # only where a scene names them (the softness examples): drawing them unasked would change every scene
    _c(
        "foam ball",
        ("sponge ball", "stress ball"),
        "ball",
        (0.07, 0.09),
        ("yellow", "orange", "pink", "blue"),
        (0.01, 0.03),
        stiffness=(("soft", _SOFT),),
        drawn=False,
    ),
    _c(
        "tennis ball",
        (),
        "ball",
        (0.065, 0.068),
        ("yellow",),
        (0.056, 0.059),
        stiffness=(("firm", _FIRM),),
        drawn=False,
    ),
)


@cache
def _acrosses(shape: str, size_range: tuple[float, float]) -> tuple[float, float]:
    shapes = [build_shape(shape, size) for size in size_range]
    low, high = (max(s.hi[0] - s.lo[0], s.hi[1] - s.lo[1]) for s in shapes)
    return min(low, high), max(low, high)


@cache
def _heights(shape: str, size_range: tuple[float, float]) -> tuple[float, float]:
    low, high = (build_shape(shape, size).height for size in size_range)
    return min(low, high), max(low, high)


@cache
def _by_word() -> dict[str, Category]:
    table: dict[str, Category] = {}
    for cat in _DATA:
        table.setdefault(cat.name, cat)
    for cat in _DATA:  # names win over synonyms ("ball" is a category and a synonym of basketball)
        for syn in cat.synonyms:
            table.setdefault(syn, cat)
    return table


def categories() -> list[Category]:
    """Every category, in catalog order."""
    return list(_DATA)


def category_names() -> list[str]:
    """The category names, in catalog order."""
    return [c.name for c in _DATA]


def get_category(name: str) -> Category:
    """The category called `name` (a name or synonym, any case); `UnknownName` lists the names."""
    found = find_category(name)
    if found is None:
        raise UnknownName(
            f"unknown object category {name!r}", f"choose one of: {', '.join(category_names())}"
        )
    return found


def find_category(word: str) -> Category | None:
    """The category a word or phrase names (name, synonym, or a plural of either), or None.

    Matches whole phrases first ("cell phones" -> cell phone), then the longest known phrase inside the
    words ("the red coffee mug" -> mug).
    """
    text = re.sub(r"[^a-z ]+", " ", word.lower()).split()
    if not text:
        return None
    table = _by_word()
    # every contiguous run of words, longest first, so "coffee mug" beats "mug" and "tennis racket" "racket"
    for n in range(len(text), 0, -1):
        for i in range(len(text) - n + 1):
            head, last = text[i : i + n - 1], text[i + n - 1]
            for sing in singular_forms(last):
                phrase = " ".join([*head, sing])
                if phrase in table:
                    return table[phrase]
    return None

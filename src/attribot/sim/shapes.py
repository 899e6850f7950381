"""Object shapes built from MuJoCo primitives, one builder per catalog `shape`.

A builder takes the object's size (its longest dimension, metres) and returns a `Shape`: the parts in
the object's own frame (origin at the centre of its footprint on the surface, z up), each with a colour
role ("main" takes the object's colour; other roles are fixed materials). Composite shapes help both
people and detectors recognise objects: a mug has a handle, a lamp a shade, a cactus a pot.

Parts marked `hidden` are collision-only feet that keep round things (balls, eggs, pencils) from rolling
away; they are not rendered and carry almost no mass.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from attribot.registry import Registry

__all__ = ["Part", "Shape", "SHAPES", "build_shape", "MATERIALS", "quat_axis_angle", "compose_quat"]

# fixed colours of the non-"main" roles (RGB, 0..1)
MATERIALS: dict[str, tuple[float, float, float]] = {
    "metal": (0.72, 0.73, 0.75),
    "dark": (0.10, 0.10, 0.11),
    "wood": (0.55, 0.38, 0.22),
    "leaf": (0.20, 0.55, 0.15),
    "stem": (0.35, 0.25, 0.12),
    "white": (0.95, 0.95, 0.93),
    "paper": (0.96, 0.94, 0.86),
    "soil": (0.25, 0.17, 0.10),
    "terracotta": (0.78, 0.40, 0.25),
    "screen": (0.05, 0.08, 0.15),
    "tape": (0.80, 0.70, 0.50),
    "gray": (0.55, 0.55, 0.57),
    "flame": (1.0, 0.75, 0.2),
    "canvas": (0.95, 0.92, 0.80),
}


def quat_axis_angle(axis: tuple[float, float, float], angle: float) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of a rotation by `angle` radians about `axis`."""
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    s = math.sin(angle / 2)
    return (math.cos(angle / 2), float(a[0]) * s, float(a[1]) * s, float(a[2]) * s)


_ALONG_X = quat_axis_angle((0, 1, 0), math.pi / 2)  # a cylinder's axis (z) laid along x
_ALONG_Y = quat_axis_angle((1, 0, 0), math.pi / 2)
_UPRIGHT = (1.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Part:
    """One primitive: kind in box/sphere/cylinder/capsule/ellipsoid, MuJoCo half-size, pose, colour role."""

    kind: str
    size: tuple[float, ...]
    pos: tuple[float, float, float]
    quat: tuple[float, float, float, float] = _UPRIGHT
    role: str = "main"
    hidden: bool = False

    def half_extents(self) -> np.ndarray:
        """Half extents of the part's own bounding box before rotation."""
        s = self.size
        if self.kind == "sphere":
            return np.array([s[0]] * 3)
        if self.kind == "cylinder":
            return np.array([s[0], s[0], s[1]])
        if self.kind == "capsule":
            return np.array([s[0], s[0], s[1] + s[0]])
        return np.array(s[:3])

    def volume(self) -> float:
        s = self.size
        if self.kind == "sphere":
            return 4 / 3 * math.pi * s[0] ** 3
        if self.kind == "cylinder":
            return math.pi * s[0] ** 2 * 2 * s[1]
        if self.kind == "capsule":
            return math.pi * s[0] ** 2 * 2 * s[1] + 4 / 3 * math.pi * s[0] ** 3
        if self.kind == "ellipsoid":
            return 4 / 3 * math.pi * s[0] * s[1] * s[2]
        return 8 * s[0] * s[1] * s[2]


def _rotmat(q: tuple[float, float, float, float]) -> np.ndarray:
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


@dataclass(frozen=True)
class Shape:
    """The parts of one object and their bounding box in the object frame."""

    parts: tuple[Part, ...]
    lo: tuple[float, float, float] = field(init=False)
    hi: tuple[float, float, float] = field(init=False)

    def __post_init__(self) -> None:
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        for p in self.parts:
            he = p.half_extents()
            r = np.abs(_rotmat(p.quat)) @ he  # bounding box of the rotated box
            lo = np.minimum(lo, np.asarray(p.pos) - r)
            hi = np.maximum(hi, np.asarray(p.pos) + r)
        object.__setattr__(self, "lo", tuple(float(v) for v in lo))
        object.__setattr__(self, "hi", tuple(float(v) for v in hi))

    @property
    def height(self) -> float:
        return self.hi[2]

    @property
    def footprint_radius(self) -> float:
        """Radius of a circle about the origin that holds the footprint at any yaw."""
        return float(math.hypot(max(-self.lo[0], self.hi[0]), max(-self.lo[1], self.hi[1])))

    @property
    def visible_volume(self) -> float:
        return sum(p.volume() for p in self.parts if not p.hidden)


ShapeBuilder = Callable[[float], list[Part]]
SHAPES: Registry[ShapeBuilder] = Registry("shape")


def build_shape(name: str, size: float) -> Shape:
    """The shape `name` scaled so that its longest dimension is about `size` metres."""
    return Shape(tuple(SHAPES.get(name)(size)))


def _foot(r: float, h: float = 0.004) -> Part:
    """A flat hidden foot under round objects so that they rest instead of rolling."""
    return Part("cylinder", (r, h / 2), (0, 0, h / 2), role="dark", hidden=True)


def _sphere_fruit(s: float, stem: bool, leaf: bool, squash: float = 1.0) -> list[Part]:
    r = s / 2
    rz = r * squash
    parts = [Part("ellipsoid", (r, r, rz), (0, 0, rz)), _foot(r * 0.3)]
    if stem:
        parts.append(Part("cylinder", (r * 0.07, r * 0.2), (0, 0, 2 * rz + r * 0.1), role="stem"))
    if leaf:
        parts.append(
            Part("ellipsoid", (r * 0.35, r * 0.15, r * 0.04), (r * 0.25, 0, 2 * rz + r * 0.05), role="leaf")
        )
    return parts


@SHAPES.register("apple")
def _apple(s: float) -> list[Part]:
    return _sphere_fruit(s, stem=True, leaf=True, squash=0.92)


@SHAPES.register("orange")
def _orange(s: float) -> list[Part]:
    return _sphere_fruit(s, stem=True, leaf=False)


@SHAPES.register("tomato")
def _tomato(s: float) -> list[Part]:
    r = s / 2
    parts = _sphere_fruit(s, stem=False, leaf=False, squash=0.8)
    parts.append(Part("cylinder", (r * 0.35, r * 0.04), (0, 0, 1.6 * r), role="leaf"))
    parts.append(Part("cylinder", (r * 0.08, r * 0.12), (0, 0, 1.7 * r), role="leaf"))
    return parts


@SHAPES.register("potato")
def _potato(s: float) -> list[Part]:
    return [Part("ellipsoid", (s / 2, s * 0.33, s * 0.25), (0, 0, s * 0.25)), _foot(s * 0.12)]


@SHAPES.register("egg")
def _egg(s: float) -> list[Part]:
    return [Part("ellipsoid", (s / 2, s * 0.37, s * 0.37), (0, 0, s * 0.37)), _foot(s * 0.1)]


@SHAPES.register("carrot")
def _carrot(s: float) -> list[Part]:
    r = s * 0.08
    return [
        Part("cylinder", (r, s * 0.3), (-s * 0.05, 0, r), _ALONG_X),
        Part("capsule", (r * 0.6, s * 0.1), (s * 0.3, 0, r), _ALONG_X),
        Part("ellipsoid", (s * 0.12, r * 1.2, r * 0.5), (-s * 0.42, 0, r), role="leaf"),
        Part("box", (s * 0.25, r * 0.6, 0.002), (0, 0, 0.002), role="dark", hidden=True),
    ]


@SHAPES.register("banana")
def _banana(s: float) -> list[Part]:
    r = s * 0.09
    seg = s * 0.17
    parts = []
    for i, ang in enumerate((-0.45, 0.0, 0.45)):
        x = (i - 1) * seg * 1.7
        y = 0.15 * s * abs(i - 1)
        parts.append(
            Part(
                "capsule",
                (r, seg),
                (x, -y + 0.05 * s, r),
                compose_quat(quat_axis_angle((0, 0, 1), ang), _ALONG_X),
            )
        )
    parts.append(Part("box", (s * 0.35, r * 0.5, 0.002), (0, 0, 0.002), role="dark", hidden=True))
    parts.append(
        Part("cylinder", (r * 0.4, r * 0.4), (seg * 1.7 + seg * 0.9, -0.1 * s, r), _ALONG_X, role="stem")
    )
    return parts


def compose_quat(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, float, float, float]:
    """Quaternion product a*b (apply b, then a)."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return (
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    )


def _vessel(r: float, h: float, inner: str = "dark") -> list[Part]:
    """An open cylinder: the body and a dark disc on top that reads as its inside."""
    return [
        Part("cylinder", (r, h / 2), (0, 0, h / 2)),
        Part("cylinder", (r * 0.86, 0.0008), (0, 0, h + 0.0008), role=inner),
    ]


@SHAPES.register("mug")
def _mug(s: float) -> list[Part]:
    r, h = s * 0.4, s
    hr = s * 0.06
    return [
        *_vessel(r, h),
        Part("capsule", (hr, h * 0.22), (0, r + s * 0.2, h * 0.5)),
        Part("capsule", (hr, s * 0.1), (0, r + s * 0.1, h * 0.78), _ALONG_Y),
        Part("capsule", (hr, s * 0.1), (0, r + s * 0.1, h * 0.22), _ALONG_Y),
    ]


@SHAPES.register("bowl")
def _bowl(s: float) -> list[Part]:
    r = s / 2
    return [
        Part("cylinder", (r * 0.55, s * 0.03), (0, 0, s * 0.03)),
        Part("ellipsoid", (r, r, s * 0.22), (0, 0, s * 0.22)),
        Part("cylinder", (r * 0.85, 0.001), (0, 0, s * 0.36), role="white"),
        Part("cylinder", (r * 0.5, 0.001), (0, 0, s * 0.362), role="main"),
    ]


@SHAPES.register("plate")
def _plate(s: float) -> list[Part]:
    r = s / 2
    return [
        Part("cylinder", (r, 0.008), (0, 0, 0.008)),
        Part("cylinder", (r * 0.7, 0.0008), (0, 0, 0.0168), role="white"),
    ]


@SHAPES.register("pot")
def _pot(s: float) -> list[Part]:
    r, h = s * 0.36, s * 0.55
    return [
        *_vessel(r, h),
        Part("box", (s * 0.05, s * 0.07, s * 0.015), (0, r + s * 0.04, h * 0.85), role="dark"),
        Part("box", (s * 0.05, s * 0.07, s * 0.015), (0, -r - s * 0.04, h * 0.85), role="dark"),
    ]


@SHAPES.register("pan")
def _pan(s: float) -> list[Part]:
    r = s * 0.3
    return [
        *_vessel(r, s * 0.1),
        Part("box", (s * 0.2, s * 0.025, s * 0.012), (r + s * 0.2, 0, s * 0.08), role="dark"),
    ]


@SHAPES.register("knife")
def _knife(s: float) -> list[Part]:
    return [
        Part("box", (s * 0.3, s * 0.06, 0.002), (s * 0.2, 0, 0.003), role="metal"),
        Part("box", (s * 0.2, s * 0.045, s * 0.03), (-s * 0.3, 0, s * 0.03)),
    ]


@SHAPES.register("fork")
def _fork(s: float) -> list[Part]:
    parts = [
        Part("box", (s * 0.3, s * 0.035, 0.003), (-s * 0.2, 0, 0.003)),
        Part("box", (s * 0.06, s * 0.07, 0.002), (s * 0.13, 0, 0.003)),
    ]
    for k in (-1.5, -0.5, 0.5, 1.5):
        parts.append(Part("box", (s * 0.12, s * 0.01, 0.002), (s * 0.31, k * s * 0.04, 0.003)))
    return parts


@SHAPES.register("spoon")
def _spoon(s: float) -> list[Part]:
    return [
        Part("box", (s * 0.3, s * 0.03, 0.003), (-s * 0.2, 0, 0.003)),
        Part("ellipsoid", (s * 0.16, s * 0.1, s * 0.03), (s * 0.32, 0, s * 0.03)),
        _foot(s * 0.04),
    ]


@SHAPES.register("ladle")
def _ladle(s: float) -> list[Part]:
    return [
        Part("box", (s * 0.33, s * 0.025, 0.004), (-s * 0.17, 0, s * 0.06)),
        Part("ellipsoid", (s * 0.16, s * 0.16, s * 0.07), (s * 0.32, 0, s * 0.07)),
        Part("box", (s * 0.03, s * 0.02, s * 0.03), (-s * 0.45, 0, s * 0.03), role="dark"),
        _foot(s * 0.06),
    ]


@SHAPES.register("toaster")
def _toaster(s: float) -> list[Part]:
    d, w, h = s * 0.55, s, s * 0.65
    return [
        Part("box", (d / 2, w / 2, h / 2), (0, 0, h / 2)),
        Part("box", (d * 0.12, w * 0.38, 0.002), (-d * 0.18, 0, h + 0.001), role="dark"),
        Part("box", (d * 0.12, w * 0.38, 0.002), (d * 0.18, 0, h + 0.001), role="dark"),
        Part("box", (s * 0.02, s * 0.04, s * 0.06), (0, w / 2 + s * 0.02, h * 0.7), role="dark"),
    ]


@SHAPES.register("teapot")
def _teapot(s: float) -> list[Part]:
    r = s * 0.3
    return [
        Part("ellipsoid", (r, r, r * 0.85), (0, 0, r * 0.85)),
        _foot(r * 0.5),
        Part("cylinder", (r * 0.45, s * 0.02), (0, 0, r * 1.7)),
        Part("sphere", (s * 0.035,), (0, 0, r * 1.7 + s * 0.05)),
        Part("capsule", (s * 0.03, s * 0.1), (0, -r - s * 0.06, r * 1.0), quat_axis_angle((1, 0, 0), -0.8)),
        Part("capsule", (s * 0.025, s * 0.09), (0, r + s * 0.05, r * 0.9)),
    ]


@SHAPES.register("kettle")
def _kettle(s: float) -> list[Part]:
    r, h = s * 0.3, s * 0.75
    return [
        Part("cylinder", (r, h / 2), (0, 0, h / 2)),
        Part("cylinder", (r * 0.55, s * 0.02), (0, 0, h + s * 0.02), role="dark"),
        Part("box", (s * 0.03, s * 0.2, s * 0.025), (0, 0, h + s * 0.17), role="dark"),
        Part("box", (s * 0.025, s * 0.025, s * 0.08), (0, s * 0.18, h + s * 0.09), role="dark"),
        Part("box", (s * 0.025, s * 0.025, s * 0.08), (0, -s * 0.18, h + s * 0.09), role="dark"),
        Part("capsule", (s * 0.035, s * 0.08), (0, -r - s * 0.04, h * 0.8), quat_axis_angle((1, 0, 0), -0.7)),
    ]


@SHAPES.register("bottle")
def _bottle(s: float) -> list[Part]:
    r = s * 0.17
    return [
        Part("cylinder", (r, s * 0.3), (0, 0, s * 0.3)),
        Part("ellipsoid", (r, r, s * 0.12), (0, 0, s * 0.6)),
        Part("cylinder", (r * 0.4, s * 0.12), (0, 0, s * 0.8)),
        Part("cylinder", (r * 0.45, s * 0.04), (0, 0, s * 0.96), role="white"),
        Part("cylinder", (r * 1.01, s * 0.08), (0, 0, s * 0.3), role="paper"),
    ]


@SHAPES.register("can")
def _can(s: float) -> list[Part]:
    r = s * 0.27
    return [
        Part("cylinder", (r, s * 0.47), (0, 0, s * 0.48)),
        Part("cylinder", (r * 0.9, s * 0.02), (0, 0, s * 0.97), role="metal"),
        Part("cylinder", (r * 0.9, s * 0.01), (0, 0, s * 0.01), role="metal"),
    ]


@SHAPES.register("jar")
def _jar(s: float) -> list[Part]:
    r = s * 0.33
    return [
        Part("cylinder", (r, s * 0.4), (0, 0, s * 0.4)),
        Part("cylinder", (r * 1.03, s * 0.1), (0, 0, s * 0.9), role="metal"),
        Part("cylinder", (r * 1.01, s * 0.15), (0, 0, s * 0.4), role="paper"),
    ]


@SHAPES.register("cutting_board")
def _cutting_board(s: float) -> list[Part]:
    return [
        Part("box", (s / 2, s * 0.32, 0.01), (0, 0, 0.01)),
        Part("box", (s * 0.04, s * 0.06, 0.0005), (s * 0.4, 0, 0.0205), role="dark"),
    ]


@SHAPES.register("laptop")
def _laptop(s: float) -> list[Part]:
    d, w, t = s * 0.68, s, 0.012
    ang = 0.35  # the screen leans back by 20 degrees, its face towards -x (the viewer)
    tilt = quat_axis_angle((0, 1, 0), ang)
    cx, cz = d / 2 + math.sin(ang) * d / 2, 2 * t + math.cos(ang) * d / 2
    off = t * 0.6 + 0.001
    return [
        Part("box", (d / 2, w / 2, t), (0, 0, t)),
        Part("box", (d * 0.3, w * 0.42, 0.0008), (-d * 0.1, 0, 2 * t + 0.0008), role="dark"),
        Part("box", (t * 0.6, w / 2, d / 2), (cx, 0, cz), tilt),
        Part(
            "box",
            (0.001, w * 0.44, d * 0.42),
            (cx - off * math.cos(ang), 0, cz + off * math.sin(ang)),
            tilt,
            role="screen",
        ),
    ]


@SHAPES.register("book")
def _book(s: float) -> list[Part]:
    d, w, t = s * 0.72, s, s * 0.14
    return [
        Part("box", (d / 2, w / 2, t * 0.12), (0, 0, t * 0.12)),
        Part("box", (d / 2 * 0.97, w / 2 * 0.97, t * 0.38), (0.004, 0, t * 0.5), role="paper"),
        Part("box", (d / 2, w / 2, t * 0.12), (0, 0, t * 0.88)),
        Part("box", (0.004, w / 2, t / 2), (-d / 2, 0, t / 2)),
    ]


@SHAPES.register("cd")
def _cd(s: float) -> list[Part]:
    return [
        Part("cylinder", (s / 2, 0.0008), (0, 0, 0.0008)),
        Part("cylinder", (s * 0.15, 0.0002), (0, 0, 0.0018), role="white"),
        Part("cylinder", (s * 0.06, 0.0003), (0, 0, 0.0019), role="dark"),
    ]


@SHAPES.register("phone")
def _phone(s: float) -> list[Part]:
    return [
        Part("box", (s / 2, s * 0.24, s * 0.03), (0, 0, s * 0.03)),
        Part("box", (s * 0.45, s * 0.21, 0.0005), (0, 0, s * 0.06 + 0.0005), role="screen"),
    ]


@SHAPES.register("remote")
def _remote(s: float) -> list[Part]:
    parts = [Part("box", (s / 2, s * 0.12, s * 0.06), (0, 0, s * 0.06))]
    parts.append(Part("cylinder", (s * 0.035, 0.002), (s * 0.35, 0, s * 0.12), role="flame"))
    for i in range(3):
        for j in (-1, 1):
            parts.append(
                Part(
                    "box",
                    (s * 0.02, s * 0.025, 0.002),
                    (s * (0.15 - 0.12 * i), j * s * 0.05, s * 0.12),
                    role="gray",
                )
            )
    return parts


@SHAPES.register("pencil")
def _pencil(s: float) -> list[Part]:
    r = max(s * 0.025, 0.0035)
    return [
        Part("cylinder", (r, s * 0.42), (-s * 0.05, 0, r), _ALONG_X),
        Part("capsule", (r * 0.5, s * 0.04), (s * 0.4, 0, r), _ALONG_X, role="paper"),
        Part("cylinder", (r, s * 0.04), (-s * 0.5, 0, r), _ALONG_X, role="terracotta"),
        Part("box", (s * 0.3, r, 0.0015), (0, 0, 0.0015), role="dark", hidden=True),
    ]


@SHAPES.register("vase")
def _vase(s: float) -> list[Part]:
    r = s * 0.28
    return [
        Part("cylinder", (r * 0.6, s * 0.03), (0, 0, s * 0.03)),
        Part("ellipsoid", (r, r, s * 0.33), (0, 0, s * 0.36)),
        Part("cylinder", (r * 0.45, s * 0.14), (0, 0, s * 0.78)),
        Part("cylinder", (r * 0.6, s * 0.03), (0, 0, s * 0.93)),
        Part("cylinder", (r * 0.4, 0.001), (0, 0, s * 0.96 + 0.001), role="dark"),
    ]


@SHAPES.register("cactus")
def _cactus(s: float) -> list[Part]:
    pr, ph = s * 0.22, s * 0.32
    trunk = s * 0.1
    return [
        Part("cylinder", (pr, ph / 2), (0, 0, ph / 2), role="terracotta"),
        Part("cylinder", (pr * 0.9, 0.002), (0, 0, ph + 0.002), role="soil"),
        Part("capsule", (trunk, s * 0.22), (0, 0, ph + s * 0.28), role="main"),
        Part("capsule", (trunk * 0.6, s * 0.06), (0, trunk + s * 0.07, ph + s * 0.38), role="main"),
        Part("capsule", (trunk * 0.6, s * 0.05), (0, -trunk - s * 0.07, ph + s * 0.3), role="main"),
        Part(
            "capsule", (trunk * 0.55, s * 0.045), (0, trunk + s * 0.02, ph + s * 0.32), _ALONG_Y, role="main"
        ),
        Part(
            "capsule", (trunk * 0.55, s * 0.04), (0, -trunk - s * 0.02, ph + s * 0.24), _ALONG_Y, role="main"
        ),
    ]


@SHAPES.register("lamp")
def _lamp(s: float) -> list[Part]:
    return [
        Part("cylinder", (s * 0.2, s * 0.025), (0, 0, s * 0.025), role="dark"),
        Part("cylinder", (s * 0.02, s * 0.3), (0, 0, s * 0.35), role="metal"),
        Part("cylinder", (s * 0.3, s * 0.16), (0, 0, s * 0.8)),
        Part("cylinder", (s * 0.22, s * 0.1), (0, 0, s * 0.74), role="flame"),
    ]


@SHAPES.register("candle")
def _candle(s: float) -> list[Part]:
    r = s * 0.22
    return [
        Part("cylinder", (r, s * 0.45), (0, 0, s * 0.45)),
        Part("cylinder", (r * 0.08, s * 0.03), (0, 0, s * 0.93), role="dark"),
        Part("ellipsoid", (r * 0.15, r * 0.15, s * 0.05), (0, 0, s * 1.0), role="flame"),
    ]


@SHAPES.register("clock")
def _clock(s: float) -> list[Part]:
    r = s * 0.38
    return [
        Part("cylinder", (r, s * 0.12), (0, 0, r + s * 0.06), _ALONG_X),
        Part("cylinder", (r * 0.82, 0.001), (-s * 0.121, 0, r + s * 0.06), _ALONG_X, role="white"),
        Part("box", (0.001, s * 0.012, r * 0.55), (-s * 0.123, 0, r + s * 0.06 + r * 0.27), role="dark"),
        Part("box", (0.001, r * 0.4, s * 0.012), (-s * 0.123, r * 0.2, r + s * 0.06), role="dark"),
        Part("sphere", (s * 0.1,), (0, r * 0.55, 2 * r + s * 0.06), role="metal"),
        Part("sphere", (s * 0.1,), (0, -r * 0.55, 2 * r + s * 0.06), role="metal"),
        Part("box", (s * 0.08, s * 0.03, s * 0.03), (0, r * 0.6, s * 0.03), role="dark"),
        Part("box", (s * 0.08, s * 0.03, s * 0.03), (0, -r * 0.6, s * 0.03), role="dark"),
    ]


@SHAPES.register("stapler")
def _stapler(s: float) -> list[Part]:
    return [
        Part("box", (s / 2, s * 0.12, s * 0.04), (0, 0, s * 0.04), role="dark"),
        Part("box", (s * 0.46, s * 0.11, s * 0.06), (s * 0.02, 0, s * 0.14)),
    ]


@SHAPES.register("scissors")
def _scissors(s: float) -> list[Part]:
    return [
        Part(
            "box",
            (s * 0.28, s * 0.03, 0.002),
            (s * 0.22, s * 0.015, 0.004),
            quat_axis_angle((0, 0, 1), 0.08),
            role="metal",
        ),
        Part(
            "box",
            (s * 0.28, s * 0.03, 0.002),
            (s * 0.22, -s * 0.015, 0.004),
            quat_axis_angle((0, 0, 1), -0.08),
            role="metal",
        ),
        Part("ellipsoid", (s * 0.12, s * 0.09, s * 0.02), (-s * 0.2, s * 0.1, s * 0.02)),
        Part("ellipsoid", (s * 0.12, s * 0.09, s * 0.02), (-s * 0.2, -s * 0.1, s * 0.02)),
    ]


@SHAPES.register("mouse")
def _mouse(s: float) -> list[Part]:
    return [
        Part("ellipsoid", (s / 2, s * 0.3, s * 0.18), (0, 0, s * 0.18)),
        Part("box", (s * 0.12, 0.001, s * 0.01), (-s * 0.3, 0, s * 0.31), role="dark"),
        _foot(s * 0.15),
    ]


@SHAPES.register("keyboard")
def _keyboard(s: float) -> list[Part]:
    d = s * 0.35
    parts = [Part("box", (d / 2, s / 2, 0.012), (0, 0, 0.012))]
    for i in range(4):
        parts.append(Part("box", (d * 0.09, s * 0.45, 0.003), (d * (0.33 - 0.22 * i), 0, 0.026), role="gray"))
    return parts


@SHAPES.register("painting")
def _painting(s: float) -> list[Part]:
    w, h, t = s, s * 0.75, 0.012
    return [
        Part("box", (t, w / 2, h / 2), (0, 0, h / 2), role="wood"),
        Part("box", (0.001, w * 0.42, h * 0.38), (-t - 0.001, 0, h / 2)),
        Part("box", (0.001, w * 0.18, h * 0.14), (-t - 0.002, w * 0.1, h * 0.6), role="flame"),
        Part("box", (0.001, w * 0.3, h * 0.06), (-t - 0.002, -w * 0.05, h * 0.28), role="dark"),
        Part("box", (h * 0.18, 0.01, h * 0.25), (t + h * 0.18, 0, h * 0.25), role="wood"),
        Part("box", (h * 0.2, w / 2 * 0.9, 0.003), (h * 0.15, 0, 0.003), role="dark", hidden=True),
    ]


@SHAPES.register("pillow")
def _pillow(s: float) -> list[Part]:
    return [
        Part("ellipsoid", (s * 0.36, s / 2, s * 0.09), (0, 0, s * 0.09)),
        Part("box", (s * 0.25, s * 0.35, 0.003), (0, 0, 0.003), role="dark", hidden=True),
    ]


@SHAPES.register("basketball")
def _basketball(s: float) -> list[Part]:
    r = s / 2
    return [
        Part("sphere", (r,), (0, 0, r)),
        Part("cylinder", (r * 1.003, 0.0025), (0, 0, r), role="dark"),
        Part("cylinder", (r * 1.003, 0.0025), (0, 0, r), _ALONG_X, role="dark"),
        Part("cylinder", (r * 1.003, 0.0025), (0, 0, r), _ALONG_Y, role="dark"),
        _foot(r * 0.3),
    ]


@SHAPES.register("ball")
def _ball(s: float) -> list[Part]:
    r = s / 2
    return [
        Part("sphere", (r,), (0, 0, r)),
        Part("cylinder", (r * 1.005, r * 0.12), (0, 0, r), _ALONG_X, role="white"),
        _foot(r * 0.3),
    ]


@SHAPES.register("racket")
def _racket(s: float) -> list[Part]:
    hl = s * 0.4
    return [
        Part("ellipsoid", (s * 0.18, s * 0.14, 0.012), (s * 0.3, 0, 0.012)),
        Part("ellipsoid", (s * 0.16, s * 0.12, 0.0125), (s * 0.3, 0, 0.0125), role="white"),
        Part("box", (hl / 2, 0.014, 0.012), (-s * 0.12, 0, 0.012)),
        Part("box", (s * 0.09, 0.017, 0.016), (-s * 0.4, 0, 0.016), role="dark"),
    ]


@SHAPES.register("broom")
def _broom(s: float) -> list[Part]:
    return [
        Part("cylinder", (0.012, s * 0.38), (-s * 0.1, 0, 0.04), _ALONG_X, role="wood"),
        Part("box", (s * 0.08, s * 0.12, 0.035), (s * 0.38, 0, 0.035)),
        Part("box", (s * 0.02, s * 0.1, 0.02), (s * 0.28, 0, 0.04), role="dark"),
        Part("box", (s * 0.3, 0.02, 0.004), (-s * 0.1, 0, 0.004), role="dark", hidden=True),
    ]


@SHAPES.register("dumbbell")
def _dumbbell(s: float) -> list[Part]:
    r = s * 0.22
    return [
        Part("cylinder", (s * 0.07, s * 0.3), (0, 0, r), _ALONG_Y, role="metal"),
        Part("cylinder", (r, s * 0.08), (0, s * 0.35, r), _ALONG_Y),
        Part("cylinder", (r, s * 0.08), (0, -s * 0.35, r), _ALONG_Y),
        Part("box", (r * 0.3, s * 0.45, 0.002), (0, 0, 0.002), role="dark", hidden=True),
    ]


@SHAPES.register("hammer")
def _hammer(s: float) -> list[Part]:
    return [
        Part("box", (s * 0.42, s * 0.04, s * 0.025), (-s * 0.08, 0, s * 0.045), role="wood"),
        Part("box", (s * 0.07, s * 0.16, s * 0.045), (s * 0.38, 0, s * 0.045), role="dark"),
        Part("box", (s * 0.15, s * 0.05, s * 0.03), (-s * 0.35, 0, s * 0.045)),
    ]


@SHAPES.register("sponge")
def _sponge(s: float) -> list[Part]:
    return [
        Part("box", (s / 2, s * 0.32, s * 0.14), (0, 0, s * 0.14)),
        Part("box", (s / 2, s * 0.32, s * 0.05), (0, 0, s * 0.33), role="leaf"),
    ]


@SHAPES.register("feather")
def _feather(s: float) -> list[Part]:
    return [
        Part("ellipsoid", (s * 0.4, s * 0.08, 0.003), (s * 0.05, 0, 0.004)),
        Part("capsule", (0.0015, s * 0.48), (0, 0, 0.004), _ALONG_X, role="paper"),
    ]


@SHAPES.register("tissue_box")
def _tissue_box(s: float) -> list[Part]:
    return [
        Part("box", (s * 0.25, s / 2, s * 0.22), (0, 0, s * 0.22)),
        Part("ellipsoid", (s * 0.08, s * 0.12, s * 0.07), (0, 0, s * 0.44), role="white"),
    ]


@SHAPES.register("carton")
def _carton(s: float) -> list[Part]:
    d, w, h = s * 0.75, s, s * 0.65
    return [
        Part("box", (d / 2, w / 2, h / 2), (0, 0, h / 2)),
        Part("box", (d / 2 * 1.005, w * 0.08, 0.001), (0, 0, h + 0.001), role="tape"),
        Part("box", (0.001, w * 0.08, h * 0.2), (-d / 2 - 0.001, 0, h * 0.8), role="tape"),
    ]


@SHAPES.register("block")
def _block(s: float) -> list[Part]:
    a = s / 2
    return [Part("box", (a, a, a), (0, 0, a))]


@SHAPES.register("suitcase")
def _suitcase(s: float) -> list[Part]:
    d, w, h = s * 0.35, s * 0.7, s * 0.9
    return [
        Part("box", (d / 2, w / 2, h / 2), (0, 0, h / 2 + 0.03)),
        Part("box", (0.012, 0.012, s * 0.05), (0, w * 0.25, h + 0.03 + s * 0.05), role="dark"),
        Part("box", (0.012, 0.012, s * 0.05), (0, -w * 0.25, h + 0.03 + s * 0.05), role="dark"),
        Part("box", (0.012, w * 0.26, 0.012), (0, 0, h + 0.03 + s * 0.1), role="dark"),
        Part("cylinder", (0.03, 0.012), (d * 0.3, w * 0.4, 0.03), _ALONG_Y, role="dark"),
        Part("cylinder", (0.03, 0.012), (d * 0.3, -w * 0.4, 0.03), _ALONG_Y, role="dark"),
        Part("box", (0.015, 0.015, 0.015), (-d * 0.3, w * 0.4, 0.015), role="dark"),
        Part("box", (0.015, 0.015, 0.015), (-d * 0.3, -w * 0.4, 0.015), role="dark"),
    ]


@SHAPES.register("backpack")
def _backpack(s: float) -> list[Part]:
    d, w, h = s * 0.4, s * 0.7, s * 0.85
    return [
        Part("box", (d / 2, w / 2, h / 2), (0, 0, h / 2)),
        Part("ellipsoid", (d / 2, w / 2, s * 0.1), (0, 0, h)),
        Part("box", (d * 0.2, w * 0.38, h * 0.22), (-d / 2 - d * 0.15, 0, h * 0.3)),
        Part("box", (0.01, 0.015, s * 0.05), (0, 0, h + s * 0.12), role="dark"),
    ]

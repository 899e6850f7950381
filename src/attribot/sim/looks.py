"""How objects look: visual models that a detector trained on photographs recognises, over unchanged physics.

An object's `Shape` (`attribot.sim.shapes`) is its body: primitives that carry its mass, that the
rangefinder, the view checks and the truth's bounds read, inside one collision box. Its look is drawn over
that body: meshes generated in code (`meshes.py`: surfaces of revolution, tubes swept along curves) and
primitives with procedural materials (`textures.py`: wood grain, fabric, brushed metal, printed labels,
screens, keys, pages), with the parts that define the category: a mug's hollow and handle, a kettle's
spout, lid and arched handle, a banana's curve, a laptop's lit screen and keyboard, a backpack's zips,
straps and pocket, a book's pages between its boards and its printed cover, a suitcase's shell and wheels,
the open loops of scissors. A look reaches at most a tenth of the object's size beyond its body (a test
holds every look to it), carries no mass and never collides, so physics, sensing and the seeds' scenes are
the same with either look; only pixels change. Within a category, looks vary with the object (`variant`,
drawn from its id, never from the scene's generator).

`LOOKS` maps a shape name to its look builder; a shape without one is drawn with its body's primitives
(with the materials of their roles). `SceneConfig.looks = "primitive"` draws every object as its body, the
look of earlier releases, to compare with.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from attribot.config import OBJECT_LOOKS
from attribot.registry import Registry
from attribot.sim.catalog import COLORS
from attribot.sim.meshes import Mesh, arc, ellipse, extrude, lathe, moved, rounded, rounded_rect, tube
from attribot.sim.shapes import MATERIALS, Shape, compose_quat, quat_axis_angle

__all__ = [
    "Look",
    "LOOKS",
    "LOOK_STYLES",
    "look_of",
    "variant_of",
    "BODY_GROUP",
    "LOOK_GROUP",
]

LOOK_STYLES = OBJECT_LOOKS
"""`detailed`: the looks of this module; `primitive`: objects drawn as their bodies."""
LOOK_GROUP = 2
"""Geom group of the looks: drawn, never cast against (rays read bodies)."""
BODY_GROUP = 4
"""Geom group of an object's body parts when a look is drawn over them: not drawn, still cast against."""

Quat = tuple[float, float, float, float]
_UP: Quat = (1.0, 0.0, 0.0, 0.0)
_ALONG_X = quat_axis_angle((0, 1, 0), math.pi / 2)
_ALONG_Y = quat_axis_angle((1, 0, 0), math.pi / 2)


@dataclass(frozen=True)
class Look:
    """One visual part: a primitive (MuJoCo half-sizes) or a mesh, its pose, colour and material.

    `color` is "main" (the object's colour), a name of `shapes.MATERIALS`, or an RGB triple; `material`
    is one of `textures.TEXTURES` (or "" for a plain shaded surface) and modulates the colour."""

    kind: str
    size: tuple[float, ...] = (0.0,)
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat: Quat = _UP
    color: str | tuple[float, float, float] = "main"
    material: str = ""
    mesh: Mesh | None = None


def variant_of(object_id: str, n: int) -> int:
    """Which of `n` variants of its category an object wears: from its id, so that the scene's random
    draws (and so every seed's scene) stay as they were."""
    return int(hashlib.sha1(object_id.encode()).hexdigest()[:8], 16) % n


# ---- the looks ------------------------------------------------------------------------------------------

LookBuilder = Callable[[float, int], list[Look]]
LOOKS: Registry[LookBuilder] = Registry("look")


def look_of(shape_name: str, shape: Shape, size: float, variant: int) -> list[Look]:
    """The visual parts of an object: its category's look, or its body's primitives with role materials."""
    if shape_name in LOOKS:
        return LOOKS.get(shape_name)(size, variant)
    role_material = {"metal": "brushed", "wood": "wood", "screen": "screen"}
    return [
        Look(p.kind, p.size, p.pos, p.quat, p.role, role_material.get(p.role, "plastic"))
        for p in shape.parts
        if not p.hidden
    ]


def _mesh(m: Mesh, color: str | tuple[float, float, float] = "main", material: str = "glossy") -> Look:
    return Look("mesh", color=color, material=material, mesh=m)


@LOOKS.register("mug")
def _mug(s: float, v: int) -> list[Look]:
    r = s * 0.4
    flare = (1.0, 1.06, 0.94)[v]  # straight, flared or tapered
    rim = r * flare
    profile = [(0.0, 0.0), (r * 0.9, 0.0), (r, s * 0.04), (rim, s * 0.97), (rim * 0.99, s), (rim * 0.9, s),
               (rim * 0.9 - (rim - r) * 0.5, s * 0.12), (0.0, s * 0.1)]  # fmt: skip
    handle = arc((0.0, r * 0.92, s * 0.5), (s * 0.2, s * 0.27), -math.pi / 2, math.pi / 2, "yz")
    return [_mesh(lathe(profile, 28)), _mesh(tube(handle, s * 0.045, 10))]


@LOOKS.register("bowl")
def _bowl(s: float, v: int) -> list[Look]:
    r, h = s / 2, s * 0.36 + 0.002
    t = np.linspace(0, math.pi / 2, 9)
    outer = [(r * 0.5, 0.0)] + [(r * 0.55 + r * 0.45 * math.sin(a), h * (1 - math.cos(a))) for a in t[1:]]
    inner = [(r * 0.93 * math.sin(a), h * 0.12 + (h * 0.86) * (1 - math.cos(a))) for a in t[::-1]]
    return [_mesh(lathe([(0.0, 0.0), *outer, *inner], 28))]


@LOOKS.register("bottle")
def _bottle(s: float, v: int) -> list[Look]:
    r = s * 0.17
    neck = r * (0.38, 0.45, 0.34)[v]
    profile = [(0.0, 0.0), (r * 0.95, 0.0), (r, s * 0.02), (r, s * 0.52), (r * 0.85, s * 0.64),
               (neck * 1.1, s * 0.76), (neck, s * 0.8), (neck, s * 0.9)]  # fmt: skip
    label = [(r * 1.012, s * 0.18), (r * 1.012, s * 0.46)]
    cap = [(neck * 1.15, s * 0.88), (neck * 1.15, s), (0.0, s)]
    return [
        _mesh(lathe(profile, 24), material="glossy"),
        _mesh(lathe(label, 24), color=(1.0, 1.0, 1.0), material="label"),
        _mesh(lathe([(0.0, s * 0.88), *cap], 16), color=("white", "dark", "white")[v], material="plastic"),
    ]


@LOOKS.register("vase")
def _vase(s: float, v: int) -> list[Look]:
    r = s * 0.28
    belly = (1.0, 0.85, 0.95)[v]
    profile = [(0.0, 0.0), (r * 0.6, 0.0), (r * 0.62, s * 0.05), (r * belly, s * 0.32), (r * 0.9, s * 0.55),
               (r * 0.45, s * 0.75), (r * 0.42, s * 0.88), (r * 0.6, s * 0.99), (r * 0.5, s * 0.99),
               (r * 0.35, s * 0.8), (0.0, s * 0.78)]  # fmt: skip
    return [_mesh(lathe(profile, 28), material="glossy")]


def _round_fruit(s: float, squash: float, dimple: float) -> Mesh:
    r = s / 2
    t = np.linspace(0, math.pi, 15)
    prof = [(r * math.sin(a), r * squash * (1 - math.cos(a))) for a in t]
    prof[-1] = (0.0, 2 * r * squash - dimple)
    prof[0] = (0.0, dimple * 0.5)
    return lathe(prof, 24)


@LOOKS.register("apple")
def _apple(s: float, v: int) -> list[Look]:
    r = s / 2
    top = s * 0.92 - s * 0.06
    return [
        _mesh(_round_fruit(s, 0.92, s * 0.06), material="glossy"),
        _mesh(
            tube(np.array([[0, 0, top], [0.002, 0, top + r * 0.3], [0.006, 0, top + r * 0.45]]), r * 0.06, 6),
            color="stem",
            material="matte",
        ),  # fmt: skip
        Look(
            "ellipsoid",
            (r * 0.32, r * 0.13, r * 0.03),
            (r * 0.25, 0, top + r * 0.3),
            color="leaf",
            material="matte",
            quat=quat_axis_angle((0, 1, 0), -0.5),
        ),  # fmt: skip
    ]


@LOOKS.register("orange")
def _orange(s: float, v: int) -> list[Look]:
    r = s / 2
    return [
        Look("ellipsoid", (r, r, r * 0.97), (0, 0, r * 0.97), material="peel"),
        Look("cylinder", (r * 0.08, r * 0.04), (0, 0, r * 1.95), color="leaf", material="matte"),
    ]


@LOOKS.register("banana")
def _banana(s: float, v: int) -> list[Look]:
    t = np.linspace(-1.0, 1.0, 17)
    bend = (0.16, 0.2, 0.12)[v]
    r = s * 0.1
    path = np.stack([0.45 * s * t, -bend * s * (1 - t**2), r + 0.25 * r * t**2], 1)
    path[:, 1] -= path[:, 1].mean()  # the curve centred on the body
    radii = r * np.clip(1.0 - 0.6 * np.abs(t) ** 3, 0.35, 1.0)
    tip = np.stack([path[-1], path[-1] + (path[-1] - path[-2]) * 1.2])
    stem = np.stack([path[0], path[0] + (path[0] - path[1]) * 2.0])
    return [
        _mesh(tube(path, radii, 7), material="glossy"),
        _mesh(tube(tip, r * 0.2, 6), color="stem", material="matte"),
        _mesh(tube(stem, r * 0.22, 6), color=(0.45, 0.5, 0.2), material="matte"),
    ]


@LOOKS.register("laptop")
def _laptop(s: float, v: int) -> list[Look]:
    d, w, t = s * 0.68, s, 0.012
    ang = 0.35  # the screen leans back by 20 degrees, its face towards -x (the viewer)
    tilt = quat_axis_angle((0, 1, 0), ang)
    cx, cz = d / 2 + math.sin(ang) * d / 2, 2 * t + math.cos(ang) * d / 2

    def on_lid(off: float) -> tuple[float, float, float]:
        return (cx - off * math.cos(ang), 0.0, cz + off * math.sin(ang))

    return [
        Look("box", (d / 2, w / 2, t), (0, 0, t), material="brushed"),
        Look(
            "box",
            (d * 0.24, w * 0.44, 0.0008),
            (d * 0.14, 0, 2 * t + 0.0008),
            color=(1, 1, 1),
            material="keys",
        ),  # fmt: skip
        Look(
            "box", (d * 0.1, w * 0.14, 0.0006), (-d * 0.3, 0, 2 * t + 0.0006), color="gray", material="matte"
        ),
        Look("box", (t * 0.6, w / 2, d / 2), (cx, 0, cz), tilt, material="brushed"),
        Look(
            "box", (0.001, w * 0.48, d * 0.47), on_lid(t * 0.6 + 0.001), tilt, color="dark", material="glossy"
        ),
        Look(
            "box",
            (0.001, w * 0.44, d * 0.41),
            on_lid(t * 0.6 + 0.002),
            tilt,
            color=(1, 1, 1),
            material="screen",
        ),  # fmt: skip
    ]


@LOOKS.register("book")
def _book(s: float, v: int) -> list[Look]:
    """A hardcover lying flat: two boards in its colour over a cream block of pages that shows on three
    sides (its fore-edge towards the viewer, the spine at the back), and a printed cover: a title panel
    and, on two variants of three, a picture."""
    d, w, t = s * 0.72, s, s * 0.14
    board = max(t * 0.1, 0.0015)
    inset = 0.004  # the boards overhang the pages by this much
    top = t - board / 2
    looks = [
        Look("box", (d / 2, w / 2, board / 2), (0, 0, board / 2), material="plastic"),
        Look("box", (d / 2, w / 2, board / 2), (0, 0, top), material="plastic"),
        Look(
            "box",
            (d / 2 - inset, w / 2 - inset, t / 2 - board),
            (inset, 0, t / 2),
            color="paper",
            material="pages",
        ),
        Look("box", (board / 2, w / 2, t / 2), (d / 2 - board / 2, 0, t / 2), material="plastic"),
        Look(
            "box",
            (d * 0.36, w * 0.16, 0.0004),
            (-d * 0.04, w * 0.26, t + 0.0004),
            color=(1, 1, 1),
            material="title",
        ),
    ]
    if v != 2:  # a picture under the title
        looks.append(Look("box", (d * 0.32, w * 0.2, 0.0004), (-d * 0.04, -w * 0.12, t + 0.0004),
                          color=(1, 1, 1), material="art"))  # fmt: skip
    if v != 0:  # a band of gilt lettering on the spine's side of the cover
        looks.append(Look("box", (d * 0.04, w * 0.4, 0.0004), (d * 0.36, 0, t + 0.0004),
                          color=(0.85, 0.7, 0.3), material="glossy"))  # fmt: skip
    return looks


@LOOKS.register("phone")
def _phone(s: float, v: int) -> list[Look]:
    return [
        Look("box", (s / 2, s * 0.24, s * 0.03), (0, 0, s * 0.03), material="glossy"),
        Look(
            "box",
            (s * 0.22, s * 0.46, 0.0006),  # turned a quarter about z: along the body, the icons upright
            (0, 0, s * 0.06 + 0.0006),
            color=(1, 1, 1),
            material="phone",
            quat=quat_axis_angle((0, 0, 1), math.pi / 2),
        ),  # fmt: skip
    ]


@LOOKS.register("keyboard")
def _keyboard(s: float, v: int) -> list[Look]:
    d = s * 0.35
    return [
        Look("box", (d / 2, s / 2, 0.012), (0, 0, 0.012), material="plastic"),
        Look("box", (d * 0.45, s * 0.48, 0.002), (0, 0, 0.026), color=(1, 1, 1), material="keys"),
    ]


@LOOKS.register("cactus")
def _cactus(s: float, v: int) -> list[Look]:
    """A columnar cactus with arms, or (variants 1 and 2) a leafy succulent: both in a terracotta pot."""
    pr, ph = s * 0.22, s * 0.32
    trunk = s * 0.1
    pot = [(0.0, 0.0), (pr * 0.75, 0.0), (pr * 0.95, ph * 0.85), (pr, ph * 0.85), (pr, ph), (pr * 0.9, ph),
           (0.0, ph * 0.96)]  # fmt: skip
    looks = [
        _mesh(lathe(pot, 20), color="terracotta", material="matte"),
        Look("cylinder", (pr * 0.9, 0.002), (0, 0, ph * 0.96), color="soil", material="matte"),
    ]
    if v == 0:
        heights = (0.22, 0.24, 0.32, 0.44)
        reach = (trunk * 0.8, trunk + s * 0.08, trunk + s * 0.1, trunk + s * 0.1)
        arm_l = np.array([[0.0, y, ph + s * z] for y, z in zip(reach, heights, strict=True)])
        arm_r = arm_l * np.array([1, -1, 1]) - np.array([0, 0, s * 0.06])
        return [
            *looks,
            Look("capsule", (trunk, s * 0.22), (0, 0, ph + s * 0.28), material="ribs"),
            _mesh(tube(arm_l, trunk * 0.6, 8), material="ribs"),
            _mesh(tube(arm_r, trunk * 0.6, 8), material="ribs"),
        ]
    leaf = s * (0.2 if v == 1 else 0.16)
    for ring, (count, tilt, lift) in enumerate(((9, 0.95, 0.02), (7, 0.55, 0.06), (5, 0.2, 0.1))):
        for k in range(count):
            yaw = 2 * math.pi * (k + 0.5 * ring) / count
            q = compose_quat(quat_axis_angle((0, 0, 1), yaw), quat_axis_angle((0, 1, 0), -math.pi / 2 + tilt))
            out = leaf * math.sin(tilt) * 0.9
            pos = (out * math.cos(yaw), out * math.sin(yaw), ph + s * lift + leaf * math.cos(tilt) * 0.9)
            shade = (0.2 + 0.05 * ring, 0.5 + 0.08 * ring, 0.18)
            looks.append(Look("ellipsoid", (leaf, leaf * 0.32, leaf * 0.08), pos, q, shade, "matte"))
    return looks


@LOOKS.register("toaster")
def _toaster(s: float, v: int) -> list[Look]:
    """A rounded body with two slots, toast in them, a lever at one end and a dial at the front."""
    d, w, h = s * 0.55, s, s * 0.65
    body = extrude(rounded_rect(d / 2, h, d * (0.3, 0.45, 0.2)[v]), w)
    toast = (0.8, 0.56, 0.28)
    return [
        _mesh(body, material="brushed"),
        Look(
            "box", (d / 2 * 1.01, w / 2 * 1.005, h * 0.05), (0, 0, h * 0.05), color="dark", material="plastic"
        ),
        *(
            Look("box", (d * 0.09, w * 0.36, 0.002), (x, 0, h + 0.0005), color="dark")
            for x in (-d * 0.18, d * 0.18)
        ),
        *(
            Look("box", (d * 0.07, w * 0.3, h * 0.1), (x, 0, h + h * 0.02), color=toast, material="matte")
            for x in (-d * 0.18, d * 0.18)
        ),  # fmt: skip
        Look(
            "box",
            (s * 0.03, s * 0.02, s * 0.03),
            (0, w / 2 + s * 0.02, h * 0.72),
            color="dark",
            material="plastic",
        ),
        Look("box", (s * 0.006, s * 0.012, h * 0.3), (0, w / 2 + 0.003, h * 0.55), color="dark"),
        Look(
            "cylinder",
            (s * 0.035, s * 0.008),
            (-d / 2 - s * 0.006, w * 0.32, h * 0.3),
            _ALONG_X,
            color="dark",
            material="plastic",
        ),  # fmt: skip
    ]


@LOOKS.register("kettle")
def _kettle(s: float, v: int) -> list[Look]:
    r, h = s * 0.3, s * 0.75
    body = [(0.0, 0.0), (r * 0.95, 0.0), (r, s * 0.03), (r * (0.98, 0.9, 1.0)[v], h * 0.7), (r * 0.7, h),
            (0.0, h)]  # fmt: skip
    lid = [(r * 0.55, h), (r * 0.5, h + s * 0.03), (r * 0.12, h + s * 0.04), (0.0, h + s * 0.04)]
    spout = np.array([[0, -r * 0.8, h * 0.35], [0, -r * 1.1, h * 0.6], [0, -r * 1.3, h * 0.9]])
    handle = arc((0.0, 0.0, h), (s * 0.2, s * 0.17), 0.0, math.pi, "yz")
    return [
        _mesh(lathe(body, 28), material="brushed" if v != 1 else "glossy"),
        _mesh(lathe(lid, 20), color="dark", material="plastic"),
        Look("sphere", (s * 0.03,), (0, 0, h + s * 0.05), color="dark", material="plastic"),
        _mesh(tube(spout, np.array([s * 0.05, s * 0.035, s * 0.025]), 10), material="brushed"),
        _mesh(tube(handle, s * 0.025, 8), color="dark", material="plastic"),
    ]


@LOOKS.register("backpack")
def _backpack(s: float, v: int) -> list[Look]:
    """A soft pack with a rounded top: a zip running round its front, a front pocket with its own zip,
    mesh pockets on the sides, a grab loop on top and padded straps on its back."""
    d, w, h = s * 0.4, s * 0.7, s * 0.85
    crown = h + s * 0.08
    body = rounded(w / 2, 0.0, crown, w * 0.42, 0.04)
    pocket = rounded(w * 0.36, h * 0.06, h * 0.5, w * (0.12, 0.3, 0.2)[v], 0.03)
    front = -d / 2 - d * 0.13
    zips = [
        arc((-d / 2 - 0.003, 0.0, crown - w * 0.42), (w * 0.38, w * 0.38), 0.15, math.pi - 0.15, "yz"),
        np.array([(front - d * 0.15 - 0.003, y, z) for y, z in pocket if z > h * 0.3]),
    ]
    looks = [
        _mesh(moved(extrude(body, d), "z"), material="fabric"),
        _mesh(moved(extrude(pocket, d * 0.3), "z", (front, 0.0, 0.0)), material="fabric"),
        *(_mesh(tube(z, s * 0.008, 6), color="dark", material="plastic") for z in zips),
    ]
    for side in (-1, 1):
        path = arc((d / 2, side * w * 0.25, h * 0.55), (d * 0.18, h * 0.42), -math.pi / 2, math.pi / 2, "xz")
        looks.append(_mesh(tube(path, s * 0.025, 6), color="dark", material="fabric"))
        looks.append(Look("box", (d * 0.3, 0.012, h * 0.17), (0.0, side * (w / 2 + 0.01), h * 0.2),
                          color=(0.15, 0.15, 0.16), material="strings"))  # fmt: skip
    loop = arc((0.0, 0.0, crown), (s * 0.06, s * 0.05), 0.0, math.pi, "yz", n=8)
    looks.append(_mesh(tube(loop, s * 0.012, 6), color="dark", material="fabric"))
    return looks


@LOOKS.register("suitcase")
def _suitcase(s: float, v: int) -> list[Look]:
    """A hard-shell case on four spinner wheels: a rounded shell in its colour, split by a dark seam, with
    ridges down its front, a carry handle on top and the telescopic handle's bar above."""
    d, w, h, lift = s * 0.35, s * 0.7, s * 0.9, 0.03
    shell = rounded(w / 2, lift, lift + h, 0.05, 0.04)
    seam = rounded(w / 2 + 0.003, lift - 0.003, lift + h + 0.003, 0.053, 0.043)
    looks = [
        _mesh(moved(extrude(shell, d), "z"), material="plastic"),
        _mesh(moved(extrude(seam, 0.012), "z"), color="dark", material="plastic"),
    ]
    for y in (-0.3, -0.1, 0.1, 0.3):  # ridges down the front shell
        looks.append(Look("box", (0.003, w * 0.02, h * 0.38), (-d / 2 - 0.002, y * w, lift + h / 2),
                          material="plastic"))  # fmt: skip
    carry = arc((0.0, 0.0, lift + h), (w * 0.13, s * 0.045), 0.0, math.pi, "yz", n=10)
    looks.append(_mesh(tube(carry, 0.01, 8), color="dark", material="plastic"))
    top = lift + h + s * 0.1
    for y in (-w * 0.25, w * 0.25):  # the telescopic handle, its rods and its bar
        looks.append(Look("box", (0.01, 0.01, s * 0.05), (d * 0.3, y, top - s * 0.05), color="gray",
                          material="brushed"))  # fmt: skip
    looks.append(Look("box", (0.014, w * 0.27, 0.014), (d * 0.3, 0, top), color="dark", material="plastic"))
    for x in (-d * 0.32, d * 0.32):
        for y in (-w * 0.4, w * 0.4):
            looks.append(Look("cylinder", (lift * 0.5, 0.01), (x, y, lift * 0.5), _ALONG_Y, color="dark",
                              material="plastic"))  # fmt: skip
    return looks


@LOOKS.register("scissors")
def _scissors(s: float, v: int) -> list[Look]:
    """Two steel blades crossed at a screw, and two loop handles in its colour."""
    outline = [(-0.04 * s, -0.028 * s), (0.5 * s, -0.004 * s), (0.5 * s, 0.002 * s), (-0.04 * s, 0.03 * s)]
    blade = extrude(outline, 0.002)
    open_ = (0.06, 0.12, 0.03)[v]
    looks = []
    for side, z in ((1, 0.004), (-1, 0.006)):
        turned = moved(moved(blade, "x"), by=(0.0, 0.0, z))
        c, sn = math.cos(side * open_), math.sin(side * open_)
        x, y, zz = turned.vertices.T
        turned = Mesh(np.stack([c * x - sn * y, sn * x + c * y, zz], 1), turned.faces, turned.texcoords)
        looks.append(_mesh(turned, color="metal", material="brushed"))
        ring = ellipse((-0.2 * s, side * 0.1 * s, 0.01), (0.09 * s, 0.065 * s))
        looks.append(_mesh(tube(ring, 0.02 * s, 8, caps=False), material="plastic"))
        shank = np.array([[-0.11 * s, side * 0.07 * s, 0.01], [-0.02 * s, side * 0.012 * s, 0.007]])
        looks.append(_mesh(tube(shank, 0.018 * s, 8), material="plastic"))
    looks.append(Look("cylinder", (0.012 * s, 0.002), (0.0, 0.0, 0.008), color="dark", material="brushed"))
    return looks


@LOOKS.register("carrot")
def _carrot(s: float, v: int) -> list[Look]:
    """A tapering root lying down, ringed faintly, with a tuft of leaves at its crown."""
    r = s * 0.08
    root = [(0.0, 0.0), (r * 0.8, 0.0), (r, s * 0.04), (r * 0.92, s * 0.25), (r * 0.7, s * 0.5),
            (r * 0.35, s * 0.72), (r * 0.1, s * 0.8), (0.0, s * 0.81)]  # fmt: skip
    looks = [_mesh(moved(lathe(root, 16), "y", (-0.35 * s, 0.0, r)), material="rings")]
    for k, ang in enumerate((-0.35, 0.0, 0.35, -0.15, 0.2)):
        q = quat_axis_angle((0, 0, 1), ang)
        length = s * (0.14 if k < 3 else 0.1)
        pos = (
            -0.35 * s - length * math.cos(ang) * 0.9,
            -length * math.sin(ang) * 0.9,
            r * (1.2 if k < 3 else 1.5),
        )
        looks.append(Look("ellipsoid", (length, r * 0.3, r * 0.12), pos, q, color="leaf", material="matte"))
    return looks


@LOOKS.register("mouse")
def _mouse(s: float, v: int) -> list[Look]:
    """A computer mouse: a smooth shell, the seam between its two buttons and a scroll wheel."""
    return [
        Look("ellipsoid", (s / 2, s * 0.3, s * 0.18), (0, 0, s * 0.18), material="plastic"),
        Look("box", (s * 0.17, 0.0008, s * 0.02), (-s * 0.3, 0, s * 0.3), color="dark"),
        Look(
            "cylinder",
            (s * 0.045, s * 0.018),
            (-s * 0.27, 0, s * 0.315),
            _ALONG_Y,
            color="dark",
            material="plastic",
        ),
    ]


@LOOKS.register("knife")
def _knife(s: float, v: int) -> list[Look]:
    """A kitchen knife: a steel blade curving to its point, a bolster, and a handle with three rivets."""
    edge = [(0.0, -0.06 * s), (0.3 * s, -0.055 * s), (0.44 * s, -0.03 * s), (0.5 * s, 0.0),
            (0.0, 0.035 * s)]  # fmt: skip
    blade = moved(moved(extrude(edge, 0.002), "x"), by=(0.0, 0.0, 0.003))
    looks = [
        _mesh(blade, color="metal", material="brushed"),
        Look(
            "box",
            (0.012 * s, 0.05 * s, 0.028 * s),
            (-0.005 * s, 0, 0.028 * s),
            color="metal",
            material="brushed",
        ),
        Look("box", (0.2 * s, 0.042 * s, 0.026 * s), (-0.3 * s, 0, 0.028 * s), material="plastic"),
    ]
    for x in (-0.42, -0.3, -0.18):
        looks.append(Look("cylinder", (0.012 * s, 0.0008), (x * s, 0, 0.054 * s + 0.0008), color="metal",
                          material="brushed"))  # fmt: skip
    return looks


@LOOKS.register("spoon")
def _spoon(s: float, v: int) -> list[Look]:
    """A steel spoon: a shallow oval bowl, hollow side up, and a handle that widens towards its end."""
    t = np.linspace(0.0, math.pi / 2, 7)
    dish = [(math.sin(a), 1 - math.cos(a)) for a in t] + [(math.sin(a) * 0.9, 0.12 + 0.88 * (1 - math.cos(a)))
                                                         for a in t[::-1]]  # fmt: skip
    bowl = lathe([(0.0, 0.0), *dish[1:]], 20)
    scale = np.array([0.16 * s, 0.1 * s, 0.055 * s])
    bowl = Mesh(bowl.vertices * scale + np.array([0.32 * s, 0.0, 0.004]), bowl.faces, bowl.texcoords)
    handle = np.array([[-0.5 * s, 0.0, 0.006], [-0.2 * s, 0.0, 0.006], [0.05 * s, 0.0, 0.008],
                       [0.18 * s, 0.0, 0.01]])  # fmt: skip
    return [
        _mesh(bowl, material="brushed"),
        _mesh(tube(handle, np.array([0.035, 0.028, 0.018, 0.016]) * s, 8), material="brushed"),
    ]


@LOOKS.register("basketball")
def _basketball(s: float, v: int) -> list[Look]:
    r = s / 2
    return [
        Look("sphere", (r,), (0, 0, r), material="leather"),
        Look("cylinder", (r * 1.004, 0.002), (0, 0, r), color="dark"),
        Look("cylinder", (r * 1.004, 0.002), (0, 0, r), _ALONG_X, color="dark"),
        Look("cylinder", (r * 1.004, 0.002), (0, 0, r), _ALONG_Y, color="dark"),
    ]


@LOOKS.register("racket")
def _racket(s: float, v: int) -> list[Look]:
    t = np.linspace(0.0, 2 * math.pi, 29)
    frame = np.stack([s * 0.3 + s * 0.17 * np.cos(t), s * 0.13 * np.sin(t), np.full(t.shape, 0.014)], 1)
    return [
        _mesh(tube(frame, 0.009, 8, caps=False), material="glossy"),
        Look(
            "ellipsoid", (s * 0.17, s * 0.13, 0.002), (s * 0.3, 0, 0.014), color=(1, 1, 1), material="strings"
        ),  # fmt: skip
        Look("box", (s * 0.07, 0.01, 0.01), (-s * 0.17, 0, 0.014), material="glossy"),
        *(  # the open throat: two arms from the shaft to the head
            _mesh(tube(np.array([[-s * 0.1, 0.0, 0.014], [s * 0.171, side * s * 0.085, 0.014]]), 0.008, 8))
            for side in (-1, 1)
        ),
        Look("capsule", (0.016, s * 0.11), (-s * 0.35, 0, 0.016), _ALONG_X, color="dark", material="fabric"),
    ]


# ---- into the model --------------------------------------------------------------------------------------

_TYPES = {
    "box": mujoco.mjtGeom.mjGEOM_BOX,
    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
    "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
    "ellipsoid": mujoco.mjtGeom.mjGEOM_ELLIPSOID,
}


def color_rgb(color: str | tuple[float, float, float], main: tuple[float, float, float]) -> list[float]:
    if isinstance(color, tuple):
        return list(color)
    if color == "main":
        return list(main)
    if color in MATERIALS:
        return list(MATERIALS[color])
    return list(COLORS[color])


def add_looks(spec: mujoco.MjSpec, body: mujoco.MjsBody, looks: list[Look], main: tuple[float, float, float],
              meshes: set[str]) -> None:  # fmt: skip
    """Add `looks` to `body` as massless, non-colliding geoms of `LOOK_GROUP`; `meshes` holds the names of
    the meshes `spec` has already (identical meshes are shared)."""
    for look in looks:
        rgba = [*color_rgb(look.color, main), 1.0]
        if look.kind == "mesh":
            assert look.mesh is not None
            name = f"look_mesh_{look.mesh.key()}"
            if name not in meshes:
                mesh = spec.add_mesh(name=name)
                mesh.uservert = look.mesh.vertices.astype(np.float32).ravel().tolist()
                mesh.userface = look.mesh.faces.ravel().tolist()
                mesh.usertexcoord = look.mesh.texcoords.astype(np.float32).ravel().tolist()
                mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
                meshes.add(name)
            g = body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name, rgba=rgba)
        else:
            size = list(look.size) + [0.0] * (3 - len(look.size))
            g = body.add_geom(type=_TYPES[look.kind], size=size, pos=list(look.pos), quat=list(look.quat),
                              rgba=rgba)  # fmt: skip
        if look.material:
            g.material = f"look_{look.material}"
        g.group = LOOK_GROUP
        g.contype = g.conaffinity = 0
        g.density = 0.0
        g.mass = 0.0

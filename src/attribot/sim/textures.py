"""The procedural materials of the objects' looks: images drawn in code (wood grain, fabric, brushed metal,
printed labels, screens, keys, pages, ...) that modulate a look's colour, and plain glossy, matte and
plastic materials. `add_materials` adds them all to a model once.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache

import mujoco
import numpy as np

__all__ = ["TEXTURES", "add_materials"]


def _wood(rng: np.random.Generator, n: int = 256) -> np.ndarray:
    y, x = np.mgrid[0:n, 0:n] / n
    warp = (
        0.05 * np.sin(2 * math.pi * (3 * y + rng.uniform()))
        + 0.02 * rng.standard_normal((n, n)).cumsum(0) / 8
    )
    rings = 0.5 + 0.5 * np.sin(2 * math.pi * 18 * (x + warp))
    grain = 0.78 + 0.14 * rings + 0.05 * rng.standard_normal((n, n))
    return np.clip(grain, 0, 1)[..., None] * np.array([1.0, 0.93, 0.85])


def _fabric(rng: np.random.Generator, n: int = 128) -> np.ndarray:
    y, x = np.mgrid[0:n, 0:n]
    weave = 0.85 + 0.1 * ((x // 2 + y // 2) % 2) + 0.05 * rng.standard_normal((n, n))
    return np.clip(weave, 0, 1)[..., None] * np.ones(3)


def _brushed(rng: np.random.Generator, n: int = 128) -> np.ndarray:
    streaks = rng.standard_normal((1, n)).repeat(n, 0) * 0.04 + rng.standard_normal((n, n)) * 0.015
    return np.clip(0.9 + streaks, 0, 1)[..., None] * np.ones(3)


def _label(rng: np.random.Generator, n: int = 128) -> np.ndarray:
    img = np.ones((n, n, 3)) * np.array([0.95, 0.93, 0.85])
    img[n // 3 : n // 3 + 10] = (0.85, 0.15, 0.12)
    for k in range(5):  # lines of print
        row = n // 2 + 8 * k
        img[row : row + 3, 20 : n - 20 - 9 * k] = 0.15
    return img


def _screen(rng: np.random.Generator, n: int = 128) -> np.ndarray:
    y, x = np.mgrid[0:n, 0:n] / n
    img = np.stack([0.15 + 0.35 * y, 0.35 + 0.35 * y, 0.75 + 0.2 * x], axis=-1)  # a desktop's sky
    img[int(0.15 * n) : int(0.6 * n), int(0.1 * n) : int(0.6 * n)] = 0.95  # a window
    img[int(0.15 * n) : int(0.22 * n), int(0.1 * n) : int(0.6 * n)] = (0.3, 0.3, 0.35)
    img[int(0.9 * n) :, :] = (0.12, 0.12, 0.14)  # the task bar
    for k in range(4):
        img[int(0.9 * n) + 3 : n - 3, 10 + 14 * k : 20 + 14 * k] = (0.8, 0.6, 0.2)
    return img


def _phone_screen(rng: np.random.Generator, n: int = 128) -> np.ndarray:
    img = np.ones((n, n, 3)) * np.array([0.2, 0.35, 0.6])
    palette = [(0.9, 0.3, 0.3), (0.3, 0.8, 0.4), (0.95, 0.75, 0.2), (0.9, 0.9, 0.9), (0.4, 0.6, 0.95)]
    for i in range(5):
        for j in range(4):
            x0, y0 = 12 + 28 * j, 10 + 22 * i
            img[x0 : x0 + 16, y0 : y0 + 14] = palette[(i + j) % len(palette)]
    return img


def _keys(rng: np.random.Generator, n: int = 256) -> np.ndarray:
    img = np.ones((n, n, 3)) * 0.22
    rows, cols = 5, 14
    for i in range(rows):
        for j in range(cols):
            y0, x0 = 6 + i * (n - 12) // rows, 4 + j * (n - 8) // cols
            img[y0 + 3 : y0 + (n - 12) // rows - 3, x0 + 2 : x0 + (n - 8) // cols - 2] = 0.85
    return img.transpose(1, 0, 2)  # rows of keys across a box's x (depth), keys along its y (width)


def _pages(rng: np.random.Generator, n: int = 64) -> np.ndarray:
    y = np.arange(n)
    lines = 0.92 - 0.12 * (y % 4 == 0)
    return np.repeat(lines[:, None], n, 1)[..., None] * np.array([1.0, 0.97, 0.88])


def _title(rng: np.random.Generator, n: int = 128) -> np.ndarray:
    """A printed title: two lines of bold letters and a line of small print on paper."""
    img = np.ones((n, n, 3)) * np.array([0.96, 0.94, 0.88])
    for top, height, size, count in ((14, 26, 13, 6), (50, 26, 13, 5), (96, 10, 7, 8)):
        x = 12
        for _ in range(count):
            width = int(size * rng.uniform(0.6, 1.0))
            if x + width > n - 10:
                break
            img[top : top + height, x : x + width] = 0.12
            img[top + height // 3 : top + 2 * height // 3, x + width // 3 : x + 2 * width // 3] = 0.96
            x += width + 4
    return img.transpose(1, 0, 2)  # lines across a box's x (a cover's width), as `_keys`


def _art(rng: np.random.Generator, n: int = 128) -> np.ndarray:
    """A cover's picture: a sky, a sun and hills."""
    y, x = np.mgrid[0:n, 0:n] / n
    img = np.stack([0.55 + 0.3 * y, 0.7 + 0.2 * y, 0.95 - 0.1 * y], axis=-1)
    img[(x - 0.7) ** 2 + (y - 0.3) ** 2 < 0.02] = (0.98, 0.8, 0.2)
    img[y > 0.62 + 0.12 * np.sin(2 * math.pi * x * 1.3)] = (0.2, 0.5, 0.25)
    img[y > 0.8 + 0.06 * np.sin(2 * math.pi * (x * 2 + 0.3))] = (0.12, 0.35, 0.18)
    return img


def _peel(rng: np.random.Generator, n: int = 128) -> np.ndarray:
    bumps = 0.9 + 0.1 * rng.random((n // 4, n // 4)).repeat(4, 0).repeat(4, 1)
    return bumps[..., None] * np.ones(3)


def _leather(rng: np.random.Generator, n: int = 128) -> np.ndarray:
    dots = 0.85 + 0.15 * (rng.random((n, n)) > 0.5)
    return dots[..., None] * np.ones(3)


def _ribs(rng: np.random.Generator, n: int = 64) -> np.ndarray:
    x = np.arange(n)
    ribs = 0.75 + 0.25 * np.abs(np.sin(math.pi * 8 * x / n))
    return np.repeat(ribs[None, :], n, 0)[..., None] * np.ones(3)


def _rings(rng: np.random.Generator, n: int = 64) -> np.ndarray:
    """Faint rings round a root, unevenly spaced."""
    v = np.cumsum(rng.uniform(0.5, 1.5, n))
    rings = 0.88 + 0.12 * np.abs(np.sin(math.pi * 5 * v / v[-1] * 3))
    return np.repeat(rings[:, None], n, 1)[..., None] * np.ones(3)


def _strings(rng: np.random.Generator, n: int = 64) -> np.ndarray:
    y, x = np.mgrid[0:n, 0:n]
    grid = ((x % 6) < 1) | ((y % 6) < 1)
    return np.where(grid, 0.95, 0.5)[..., None] * np.ones(3)  # a string bed, the floor showing through


TEXTURES: dict[str, tuple[Callable[[np.random.Generator], np.ndarray], float, float, int]] = {
    # name: (image maker, specular, shininess, texture repeat)
    "wood": (_wood, 0.15, 0.3, 1),
    "fabric": (_fabric, 0.02, 0.05, 4),
    "brushed": (_brushed, 0.6, 0.7, 1),
    "label": (_label, 0.1, 0.2, 1),
    "screen": (_screen, 0.3, 0.8, 1),
    "phone": (_phone_screen, 0.3, 0.8, 1),
    "keys": (_keys, 0.1, 0.3, 1),
    "pages": (_pages, 0.0, 0.1, 1),
    "peel": (_peel, 0.25, 0.4, 3),
    "leather": (_leather, 0.1, 0.2, 6),
    "ribs": (_ribs, 0.1, 0.2, 1),
    "strings": (_strings, 0.0, 0.1, 1),
    "rings": (_rings, 0.05, 0.1, 1),
    "title": (_title, 0.05, 0.1, 1),
    "art": (_art, 0.2, 0.3, 1),
}
"""Procedural textures (grey or coloured images that modulate a look's colour), with their shading."""
_GLOSS = {"glossy": (0.5, 0.6), "matte": (0.05, 0.1), "plastic": (0.3, 0.4)}
"""Plain materials without an image: (specular, shininess)."""


@cache
def _texture_images() -> tuple[tuple[str, int, int, bytes], ...]:
    """Every texture's (name, width, height, RGB bytes): drawn once per process (drawing them took longer
    than compiling a scene), the same for every model."""
    rng = np.random.default_rng(20250)
    images = []
    for name, (make, _, _, _) in TEXTURES.items():
        img = np.clip(make(rng) * 255, 0, 255).astype(np.uint8)
        images.append((name, img.shape[1], img.shape[0], img.tobytes()))
    return tuple(images)


def add_materials(spec: mujoco.MjSpec) -> None:
    """Add every texture and material a look can name to `spec` (once per model; a few hundred KB)."""
    for name, w, h, data in _texture_images():
        _, specular, shininess, repeat = TEXTURES[name]
        tex = spec.add_texture(name=f"look_{name}", type=mujoco.mjtTexture.mjTEXTURE_2D, width=w, height=h)
        tex.nchannel = 3
        tex.data = data
        mat = spec.add_material(name=f"look_{name}", specular=specular, shininess=shininess)
        mat.texrepeat = [repeat, repeat]
        mat.textures[int(mujoco.mjtTextureRole.mjTEXROLE_RGB)] = f"look_{name}"
    for name, (specular, shininess) in _GLOSS.items():
        spec.add_material(name=f"look_{name}", specular=specular, shininess=shininess)

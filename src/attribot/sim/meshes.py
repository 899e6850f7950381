"""Meshes generated in code for the objects' looks (`looks.py`): surfaces of revolution (`lathe`), tubes swept
along curves (`tube`), prisms (`extrude`), and the outlines and curves they are made from.

Every mesh lies in the object frame, in metres, with texture coordinates for the procedural materials of
`textures.py`.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Mesh", "arc", "ellipse", "extrude", "lathe", "moved", "rounded", "rounded_rect", "tube"]


@dataclass(frozen=True)
class Mesh:
    """A triangle mesh in the object frame: vertices (N, 3), faces (M, 3), texture coordinates (N, 2)."""

    vertices: np.ndarray
    faces: np.ndarray
    texcoords: np.ndarray

    def key(self) -> str:
        digest = hashlib.sha1(np.round(self.vertices, 5).tobytes() + self.faces.tobytes())
        return digest.hexdigest()[:16]


def lathe(profile: list[tuple[float, float]], segments: int = 24) -> Mesh:
    """The surface swept by the (radius, height) polyline `profile` turning about z (a point at radius 0
    closes the surface there). Texture u goes round, v along the profile."""
    prof = np.asarray(profile, float)
    n = len(prof)
    ang = np.linspace(0.0, 2 * math.pi, segments + 1)[:-1]
    c, s = np.cos(ang), np.sin(ang)
    verts = np.stack(
        [np.outer(prof[:, 0], c).ravel(), np.outer(prof[:, 0], s).ravel(), np.repeat(prof[:, 1], segments)],
        axis=1,
    )
    seg_len = np.r_[0.0, np.cumsum(np.hypot(*np.diff(prof, axis=0).T))]
    v = seg_len / max(seg_len[-1], 1e-9)
    tex = np.stack([np.tile(ang / (2 * math.pi), n), np.repeat(v, segments)], axis=1)
    faces = []
    for i in range(n - 1):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            cc, d = a + segments, b + segments
            faces += [(a, b, d), (a, d, cc)]
    return Mesh(verts, np.asarray(faces, np.int32), tex)


def tube(path: np.ndarray, radii: np.ndarray | float, segments: int = 10, caps: bool = True) -> Mesh:
    """A tube of circular cross-section swept along the polyline `path` (N, 3) with radius per point."""
    p = np.asarray(path, float)
    n = len(p)
    r = np.broadcast_to(np.asarray(radii, float), (n,))
    tangents = np.gradient(p, axis=0)
    tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
    ref = np.array([0.0, 0.0, 1.0]) if abs(tangents[0, 2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    ang = np.linspace(0.0, 2 * math.pi, segments + 1)[:-1]
    verts, tex = [], []
    normal = np.cross(tangents[0], ref)
    for i in range(n):
        normal = normal - tangents[i] * (normal @ tangents[i])  # parallel transport: no twist
        normal /= np.linalg.norm(normal)
        binormal = np.cross(tangents[i], normal)
        for k, a in enumerate(ang):
            verts.append(p[i] + r[i] * (math.cos(a) * normal + math.sin(a) * binormal))
            tex.append((k / segments, i / max(n - 1, 1)))
    faces = []
    for i in range(n - 1):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            faces += [(a, b, b + segments), (a, b + segments, a + segments)]  # outward, as in `lathe`
    if caps:
        for end, flip in ((0, True), (n - 1, False)):
            centre = len(verts)
            verts.append(p[end])
            tex.append((0.5, float(end > 0)))
            base = end * segments
            for j in range(segments):
                a, b = base + j, base + (j + 1) % segments
                faces.append((centre, b, a) if flip else (centre, a, b))
    return Mesh(np.asarray(verts), np.asarray(faces, np.int32), np.asarray(tex))


def extrude(profile: list[tuple[float, float]], length: float) -> Mesh:
    """A prism: the convex (x, z) polygon `profile` (counter-clockwise seen from -y) extruded along y over
    `length`, centred on y = 0, with both ends closed."""
    prof = np.asarray(profile, float)
    n = len(prof)
    ys = (-length / 2, length / 2)
    verts = [(x, y, z) for y in ys for x, z in prof]
    per = np.r_[0.0, np.cumsum(np.hypot(*np.diff(np.vstack([prof, prof[:1]]), axis=0).T))]
    tex = [(per[i] / per[-1], float(k)) for k in (0, 1) for i in range(n)]
    faces = []
    for i in range(n):
        a, b = i, (i + 1) % n
        faces += [(a, a + n, b + n), (a, b + n, b)]
    for k, flip in ((0, False), (1, True)):
        # each end has vertices of its own, so that it shades flat, not blended with the sides
        ring = len(verts)
        verts += [(x, ys[k], z) for x, z in prof]
        tex += [(0.5, 0.5)] * n
        centre = len(verts)
        cx, cz = prof.mean(axis=0)
        verts.append((cx, ys[k], cz))
        tex.append((0.5, 0.5))
        for i in range(n):
            a, b = ring + i, ring + (i + 1) % n
            faces.append((centre, b, a) if flip else (centre, a, b))
    return Mesh(np.asarray(verts), np.asarray(faces, np.int32), np.asarray(tex))


def rounded_rect(half_x: float, height: float, radius: float, n: int = 5) -> list[tuple[float, float]]:
    """A rectangle of width 2 `half_x` from z = 0 to `height` with its top corners rounded, as (x, z)."""
    pts = [(-half_x, 0.0), (half_x, 0.0)]
    for cx, a0 in ((half_x - radius, 0.0), (-half_x + radius, math.pi / 2)):
        for t in np.linspace(a0, a0 + math.pi / 2, n):
            pts.append((cx + radius * math.cos(t), height - radius + radius * math.sin(t)))
    return pts


def rounded(
    half_x: float, z0: float, z1: float, top: float, bottom: float, n: int = 5
) -> list[tuple[float, float]]:
    """A rectangle from x = -half_x to half_x and z = z0 to z1 with its top corners rounded by `top` and its
    bottom ones by `bottom`, as (x, z), counter-clockwise seen from -y (convex, for `extrude`)."""
    pts: list[tuple[float, float]] = []
    for cx, cz, r, a0 in (
        (-half_x + bottom, z0 + bottom, bottom, math.pi),
        (half_x - bottom, z0 + bottom, bottom, 1.5 * math.pi),
        (half_x - top, z1 - top, top, 0.0),
        (-half_x + top, z1 - top, top, 0.5 * math.pi),
    ):
        pts += [(cx + r * math.cos(t), cz + r * math.sin(t)) for t in np.linspace(a0, a0 + math.pi / 2, n)]
    return pts


def moved(m: Mesh, turn: str = "", by: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Mesh:
    """`m` turned a quarter turn, then moved `by`. `turn` "z": about z, its x axis to y and y to -x (an
    extrusion along y then runs along x); "y": about y, its z axis to x (a lathe's axis lies along x); "x":
    about x, its z axis to y and y to -z (an extruded (x, z) outline then lies flat)."""
    x, y, z = m.vertices.T
    v = {
        "": (x, y, z),
        "z": (-y, x, z),
        "y": (z, y, -x),
        "x": (x, z, -y),
    }[turn]
    return Mesh(np.stack(v, axis=1) + np.asarray(by), m.faces, m.texcoords)


def ellipse(centre: tuple[float, float, float], radii: tuple[float, float], n: int = 20) -> np.ndarray:
    """A closed ellipse in the horizontal plane about `centre` (its first point repeated at the end)."""
    t = np.linspace(0.0, 2 * math.pi, n + 1)
    return np.stack([centre[0] + radii[0] * np.cos(t), centre[1] + radii[1] * np.sin(t),
                     np.full(t.shape, centre[2])], axis=1)  # fmt: skip


def arc(centre: tuple[float, float, float], radii: tuple[float, float], t0: float, t1: float, plane: str,
         n: int = 14) -> np.ndarray:  # fmt: skip
    """Points of an elliptical arc about `centre` in the plane "yz" or "xz" (angles in radians)."""
    t = np.linspace(t0, t1, n)
    a, b = radii[0] * np.cos(t), radii[1] * np.sin(t)
    cx, cy, cz = centre
    if plane == "yz":
        return np.stack([np.full(n, cx), cy + a, cz + b], axis=1)
    return np.stack([cx + a, np.full(n, cy), cz + b], axis=1)

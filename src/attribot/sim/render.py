"""Headless rendering: the one place that chooses the OpenGL backend and turns MuJoCo scenes into arrays.

The backend is chosen at the first render, never at import: `MUJOCO_GL` when it is set (egl or osmesa),
otherwise EGL when a probe can open an EGL context (Mesa's llvmpipe works without a GPU), otherwise
OSMesa. The probe runs in a short child process because PyOpenGL fixes its platform on first import and
cannot switch in the same process after a failed attempt; a command line that knows it will render starts
it early (`prefetch_gl_backend`). When neither works the error names the Debian packages that provide them.

`SceneRenderer` owns one GL context and one MuJoCo render context; close it (or use it as a context
manager) to free them.
"""

from __future__ import annotations

import atexit
import os
import subprocess
import sys
import threading
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from attribot.errors import ConfigError

__all__ = ["RenderProfile", "PROFILES", "gl_backend", "prefetch_gl_backend", "SceneRenderer", "RenderOutput"]

_EGL_PACKAGES = "libegl1 libegl-mesa0 libgl1-mesa-dri"
_OSMESA_PACKAGES = "libosmesa6"
_FIX = (
    f"install the system packages for headless OpenGL: `sudo apt-get install {_EGL_PACKAGES}` (EGL) "
    f"or `sudo apt-get install {_OSMESA_PACKAGES}` (OSMesa); scripts/install.sh does this when run as root"
)

_lock = threading.Lock()
_chosen: str | None = None

_PROBE = """
import os, sys
os.environ['MUJOCO_GL'] = sys.argv[1]
os.environ['PYOPENGL_PLATFORM'] = sys.argv[1]
import mujoco
if sys.argv[1] == 'egl':
    from mujoco.egl import GLContext
else:
    from mujoco.osmesa import GLContext
ctx = GLContext(16, 16)
ctx.make_current()
m = mujoco.MjModel.from_xml_string('<mujoco><worldbody><geom size=".1"/></worldbody></mujoco>')
c = mujoco.MjrContext(m, 50)
c.free()
ctx.free()
"""


def _start_probe(backend: str) -> subprocess.Popen[str]:
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    return subprocess.Popen(
        [sys.executable, "-c", _PROBE, backend],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )


def _probe(backend: str, started: subprocess.Popen[str] | None = None) -> str | None:
    """None when `backend` can render in a fresh process, else the last line of its error. `started`: that
    probe, already running (see `prefetch_gl_backend`)."""
    try:
        proc = started or _start_probe(backend)
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired as exc:
        proc.kill()
        proc.communicate()
        return str(exc)
    except OSError as exc:
        return str(exc)
    if proc.returncode == 0:
        return None
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    return lines[-1] if lines else f"exit code {proc.returncode}"


_prefetched: dict[str, subprocess.Popen[str]] = {}


def prefetch_gl_backend() -> None:
    """Start choosing the OpenGL backend now, in the background: the probe is a child process (~0.25 s),
    which then overlaps the caller's own start-up (imports, settings) instead of following it.
    `gl_backend()` collects its answer. Nothing to do when MUJOCO_GL is set or the choice is made."""
    with _lock:
        if _chosen is not None or os.environ.get("MUJOCO_GL", "").strip() or _prefetched:
            return
        try:
            _prefetched["egl"] = _start_probe("egl")
        except OSError:
            return  # gl_backend() probes again and reports the error


@atexit.register
def _end_prefetched_probes() -> None:
    for proc in _prefetched.values():
        proc.kill()
        proc.communicate()


def gl_backend() -> str:
    """The OpenGL backend for offscreen rendering ("egl" or "osmesa"), chosen once per process."""
    global _chosen
    with _lock:
        if _chosen is not None:
            return _chosen
        wanted = os.environ.get("MUJOCO_GL", "").strip().lower()
        if wanted:
            if wanted not in ("egl", "osmesa"):
                raise ConfigError(
                    f"MUJOCO_GL={wanted!r} cannot render headless",
                    "set MUJOCO_GL=egl or MUJOCO_GL=osmesa, or unset it to choose automatically",
                )
            _chosen = wanted
            return wanted
        errors = {}
        for backend in ("egl", "osmesa"):
            err = _probe(backend, _prefetched.pop(backend, None))
            if err is None:
                _chosen = backend
                # keep child processes and PyOpenGL on the same choice
                os.environ.setdefault("PYOPENGL_PLATFORM", backend)
                return backend
            errors[backend] = err
        detail = "; ".join(f"{k}: {v}" for k, v in errors.items())
        raise ConfigError(f"no headless OpenGL backend works on this machine ({detail})", _FIX)


_LLVM_LIBRARIES = (("triton", ("_C", "libtriton.so")),)
"""Python packages whose native library carries its own LLVM: (package, path of the library inside it)."""
_llvm_loaded = False


def _load_llvm_libraries_first() -> None:
    """Load the native libraries that carry their own LLVM before the first GL context loads Mesa's.

    Mesa's llvmpipe (EGL and OSMesa without a GPU) loads libLLVM; loading triton's libtriton.so (which
    CUDA builds of torch import) after it crashes the process in LLVM's static initialisers (segfault on
    `import triton` after any render), while the other order works. Loading the library file now (about
    30 ms, without importing the Python package) makes rendering and a later `import torch`/`triton` safe
    in either order; the later import finds the library already loaded."""
    global _llvm_loaded
    if _llvm_loaded:
        return
    _llvm_loaded = True
    import ctypes
    import importlib.util

    for package, parts in _LLVM_LIBRARIES:
        if package in sys.modules:
            continue  # already imported, so already loaded first
        try:
            spec = importlib.util.find_spec(package)
        except (ImportError, ValueError):
            continue
        for folder in (spec.submodule_search_locations or []) if spec is not None else []:
            path = os.path.join(folder, *parts)
            if os.path.isfile(path):
                try:
                    ctypes.CDLL(path)
                except OSError:  # a broken install fails at its own import, with its own message
                    pass
                break


def _gl_context(width: int, height: int) -> Any:
    backend = gl_backend()
    _load_llvm_libraries_first()
    try:
        if backend == "egl":
            from mujoco.egl import GLContext
        else:
            from mujoco.osmesa import GLContext
        ctx = GLContext(width, height)
        ctx.make_current()
    except Exception as exc:  # ImportError, OSError, PyOpenGL errors: all mean "this backend does not work"
        pkgs = _EGL_PACKAGES if backend == "egl" else _OSMESA_PACKAGES
        raise ConfigError(
            f"cannot open an OpenGL context with MUJOCO_GL={backend} ({exc.__class__.__name__}: {exc})",
            f"install `{pkgs}` (sudo apt-get install {pkgs}), or set MUJOCO_GL to the other backend",
        ) from exc
    return ctx


@dataclass(frozen=True)
class RenderProfile:
    """How a frame is drawn. `fast`: no shadows, reflections or skybox. `pretty`: all on, for figures."""

    name: str
    shadows: bool
    reflections: bool
    skybox: bool
    samples: int


PROFILES: dict[str, RenderProfile] = {
    "fast": RenderProfile("fast", shadows=False, reflections=False, skybox=False, samples=0),
    "pretty": RenderProfile("pretty", shadows=True, reflections=True, skybox=True, samples=4),
}


@dataclass
class RenderOutput:
    """rgb uint8 (H, W, 3); depth float32 (H, W) metres along the optical axis; geom_ids int32 (H, W),
    the model geom id seen at each pixel or -1."""

    rgb: np.ndarray | None = None
    depth: np.ndarray | None = None
    geom_ids: np.ndarray | None = None


class SceneRenderer:
    """Offscreen renderer of one model at a fixed size. Not thread-safe; close it when done."""

    def __init__(self, model: mujoco.MjModel, width: int, height: int, profile: str = "fast") -> None:
        if profile not in PROFILES:
            raise ConfigError(f"unknown render profile {profile!r}", f"choose one of: {', '.join(PROFILES)}")
        if width > model.vis.global_.offwidth or height > model.vis.global_.offheight:
            raise ConfigError(
                f"image size {width}x{height} exceeds the model's offscreen buffer "
                f"{model.vis.global_.offwidth}x{model.vis.global_.offheight}",
                "build the scene with this width and height",
            )
        self.model = model
        self.width, self.height = int(width), int(height)
        self.profile = PROFILES[profile]
        self._ctx = _gl_context(self.width, self.height)
        model.vis.quality.offsamples = self.profile.samples  # read when the render context is made
        self._mjr = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._mjr)
        self._mjr.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR  # the mapping _metric_depth undoes
        self._scene = mujoco.MjvScene(model, maxgeom=10000)
        self._option = mujoco.MjvOption()
        self._camera = mujoco.MjvCamera()
        self._rect = mujoco.MjrRect(0, 0, self.width, self.height)
        flags = self._scene.flags
        flags[mujoco.mjtRndFlag.mjRND_SHADOW] = self.profile.shadows
        flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = self.profile.reflections
        flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = self.profile.skybox
        self._rgb = np.empty((self.height, self.width, 3), np.uint8)
        self._ids = np.empty((self.height, self.width, 3), np.uint8)
        self._zbuf = np.empty((self.height, self.width), np.float32)

    def _update(self, data: mujoco.MjData, camera: int, rays: bool) -> None:
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self._camera.fixedcamid = camera
        self._option.flags[mujoco.mjtVisFlag.mjVIS_RANGEFINDER] = rays
        mujoco.mjv_updateScene(
            self.model, data, self._option, None, self._camera, mujoco.mjtCatBit.mjCAT_ALL, self._scene
        )

    def render(
        self,
        data: mujoco.MjData,
        camera: int,
        *,
        rgb: bool = True,
        depth: bool = False,
        segmentation: bool = False,
        rays: bool = True,
    ) -> RenderOutput:
        """Render camera `camera` (model camera id) of `data`: the layers asked for, in two passes at most.
        `rays`: draw the rangefinders' beams (a camera that is not the beam's own must not see them)."""
        if self._mjr is None:
            raise RuntimeError("render called after close")
        self._ctx.make_current()
        self._update(data, camera, rays)
        out = RenderOutput()
        if rgb:
            mujoco.mjr_render(self._rect, self._scene, self._mjr)
            mujoco.mjr_readPixels(self._rgb, None, self._rect, self._mjr)
            out.rgb = np.flipud(self._rgb).copy()
        if depth or segmentation:
            # the id-colour pass is flat-shaded with no blending: exact ids, and depth without
            # the far-range precision loss of the lit pass
            flags = self._scene.flags
            saved = flags.copy()
            flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = True
            flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = True
            flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
            flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
            flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = False
            try:
                mujoco.mjr_render(self._rect, self._scene, self._mjr)
                mujoco.mjr_readPixels(
                    self._ids if segmentation else None, self._zbuf if depth else None, self._rect, self._mjr
                )
            finally:
                flags[:] = saved
            if depth:
                out.depth = np.flipud(self._metric_depth(self._zbuf)).copy()
            if segmentation:
                out.geom_ids = np.flipud(self._geom_ids(self._ids)).copy()
        return out

    def _metric_depth(self, zbuf: np.ndarray) -> np.ndarray:
        # MuJoCo renders with reversed Z; undo the projection as mujoco.Renderer does
        extent = self.model.stat.extent
        znear = np.float32(self.model.vis.map.znear * extent)
        zfar = np.float32(self.model.vis.map.zfar * extent)
        c = -(zfar + znear) / (zfar - znear)
        d = -(np.float32(2) * zfar * znear) / (zfar - znear)
        c = np.float32(-0.5) * c - np.float32(0.5)
        d = np.float32(-0.5) * d
        return (d / (zbuf.astype(np.float64) + c)).astype(np.float32)

    def _geom_ids(self, ids: np.ndarray) -> np.ndarray:
        seg = (
            ids[..., 0].astype(np.int64)
            + (ids[..., 1].astype(np.int64) << 8)
            + (ids[..., 2].astype(np.int64) << 16)
        )
        n = self._scene.ngeom
        table = np.full(n + 1, -1, np.int32)
        for i in range(n):
            g = self._scene.geoms[i]
            if g.objtype == mujoco.mjtObj.mjOBJ_GEOM:
                table[i + 1] = g.objid
        seg[(seg < 0) | (seg > n)] = 0
        return table[seg]

    def close(self) -> None:
        """Free the MuJoCo and GL contexts; safe to call twice."""
        if self._mjr is not None:
            self._ctx.make_current()
            self._mjr.free()
            self._mjr = None
        if self._ctx is not None:
            self._ctx.free()
            self._ctx = None

    def __enter__(self) -> SceneRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # interpreter shutdown: the GL library may already be gone
            pass

"""Rendering (Mesa's LLVM) and then importing triton (CUDA torch) crashed the process; the renderer loads
such libraries first, so that either order is safe."""

from __future__ import annotations

import importlib.util
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest


def _python(code: str, **env: str) -> subprocess.CompletedProcess[str]:
    import os

    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=180,
        env={**os.environ, **env},
    )


@pytest.mark.skipif(importlib.util.find_spec("triton") is None, reason="needs triton (CUDA builds of torch)")
def test_render_then_import_triton_and_torch():
    done = _python(
        """
        from attribot.config import SceneConfig
        from attribot.sim.world import SimWorld
        with SimWorld(SceneConfig(layout="triplet")) as world:
            world.observe()
            import triton, torch
            world.observe()
        print("ok")
        """
    )
    assert done.returncode == 0 and done.stdout.strip() == "ok", (done.returncode, done.stderr[-2000:])


def test_llvm_libraries_are_loaded_before_the_first_gl_context(tmp_path):
    """A stand-in package with a native library at triton's place: it is in the process's memory map
    before the first context is made, and its Python package is not imported."""
    lib = next(
        (
            p
            for p in ("/lib/x86_64-linux-gnu/libz.so.1", "/usr/lib/x86_64-linux-gnu/libz.so.1")
            if Path(p).exists()
        ),
        None,
    )
    if lib is None:
        pytest.skip("no libz to stand in for libtriton")
    fake = tmp_path / "triton"
    (fake / "_C").mkdir(parents=True)
    (fake / "__init__.py").write_text("raise ImportError('the package must not be imported')\n")
    shutil.copy(lib, fake / "_C" / "libtriton.so")
    done = _python(
        """
        import sys
        from attribot.sim import render
        render._load_llvm_libraries_first()
        maps = open("/proc/self/maps").read()
        print("triton" in sys.modules, "triton/_C/libtriton.so" in maps)
        """,
        PYTHONPATH=str(tmp_path),
    )
    assert done.stdout.split() == ["False", "True"], done.stderr[-2000:]

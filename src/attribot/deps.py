"""Optional dependencies, handled in one place: each extra fails with its exact install line."""

from __future__ import annotations

import importlib
from types import ModuleType

from attribot.errors import MissingDependency

__all__ = ["require", "install_line"]

# module name -> the extra of attribot that installs it
_EXTRA_OF = {
    "torch": "models",
    "transformers": "models",
    "torchvision": "gpu",
    "fastapi": "server",
    "uvicorn": "server",
    "httpx": "server",
    "matplotlib": "plots",
    "ai2thor": "ai2thor",
    "ray": "ray",
    "cv2": "coco",
    "onnxruntime": "coco",
    "onnx": "coco",
}


def install_line(extra: str) -> str:
    """The pip line that installs an extra of attribot: from a clone, since attribot is not on a package
    index (`pip install 'attribot[X]'` would fail)."""
    return f"pip install -e '.[{extra}]' in the attribot clone"


def require(module: str, purpose: str) -> ModuleType:
    """Import `module` or raise `MissingDependency` naming what needs it and the pip line to fix it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        top = module.split(".")[0]
        extra = _EXTRA_OF.get(top)
        fix = install_line(extra) if extra else f"pip install {top}"
        raise MissingDependency(
            f"{purpose} needs the Python package {top!r}, which is not installed", fix
        ) from exc

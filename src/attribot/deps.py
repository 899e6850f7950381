"""Optional dependencies, handled in one place: each extra fails with its exact install line."""

from __future__ import annotations

import importlib
from types import ModuleType

from attribot.errors import MissingDependency

__all__ = ["require"]

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
}


def require(module: str, purpose: str) -> ModuleType:
    """Import `module` or raise `MissingDependency` naming what needs it and the pip line to fix it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        top = module.split(".")[0]
        extra = _EXTRA_OF.get(top)
        fix = f"pip install 'attribot[{extra}]'" if extra else f"pip install {top}"
        raise MissingDependency(
            f"{purpose} needs the Python package {top!r}, which is not installed", fix
        ) from exc

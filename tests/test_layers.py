"""The layering of DESIGN.md holds: a folder is a layer, and no module imports from a layer above its own
(imports inside functions count too: a lazy import is still a dependency)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "attribot"

# lowest first; names on one line share a level
LEVELS: list[set[str]] = [
    {
        "errors",
        "registry",
        "boxes",
        "frame",
        "config",
        "draw",
        "deps",
        "files",
        "shutdown",
        "text",
        "lexicon",
        "video",
        "gridpath",
        "noise",  # noise presets and the world's imperfections: plain data (pydantic)
        "mechanisms",  # the error-catching mechanisms' names and `--checks` parsing: plain data
        "priors",  # the mechanisms' perception priors of their own: a table of package data (pydantic)
        "sensors",  # sensor plug-ins: names, units, what a reading needs (plain records)
        "bridge",  # the robot side: standard library, numpy and the SDK only, nothing of attribot
    },
    {"sim", "control"},
    {"embodiments"},
    {"models"},
    {"skills"},  # the robot session and the error-catching mechanisms, on sightings, targets, detections
    {"api"},
    {"runner"},
    {"planning"},
    {"saved_runs"},  # what --save writes, read back for a replay, and what a saved folder may choose
    {"session"},  # the composition root: wires world, controller, recorder, backends and runner
    {"eval", "server"},
    {"cli", "demo", "__init__"},  # the command line, the web demo and the package's own names (ask, ...)
]
LEVEL_OF = {name: i for i, names in enumerate(LEVELS) for name in names}


def _unit(parts: tuple[str, ...]) -> str:
    """The layer name of a module path inside attribot: its folder, or the module for top-level files."""
    return parts[0].removesuffix(".py")


def _imports(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            continue
        out += [(node.lineno, n.split(".")[1]) for n in names if n.startswith("attribot.")]
    return out


MODULES = sorted(p for p in SRC.rglob("*.py") if "__pycache__" not in p.parts)


def test_every_module_belongs_to_a_layer():
    unknown = {_unit(p.relative_to(SRC).parts) for p in MODULES} - set(LEVEL_OF)
    assert not unknown, f"add these to LEVELS (and to DESIGN.md's layout): {sorted(unknown)}"


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(SRC)))
def test_no_module_imports_from_a_layer_above_its_own(path):
    own = _unit(path.relative_to(SRC).parts)
    upward = [
        f"line {line}: attribot.{target}"
        for line, target in _imports(path)
        if LEVEL_OF.get(target, -1) > LEVEL_OF.get(own, -1)
    ]
    assert not upward, f"{own} imports from a layer above it: {upward}"


# the error-catching mechanisms and the COCO detectors' class mapping know what a person knows of things
# (`attribot.priors`), never the simulator's catalog (DESIGN.md, "Control acts on perception only")
OFF_THE_CATALOG = sorted(
    [
        *(SRC / "api").rglob("*.py"),
        *(SRC / "skills").rglob("*.py"),
        *(SRC / "models" / f"{name}.py" for name in ("closed_set", "coco", "yolov5")),
        SRC / "priors.py",
    ],
)


@pytest.mark.parametrize("path", OFF_THE_CATALOG, ids=lambda p: str(p.relative_to(SRC)))
def test_no_mechanism_reads_the_simulators_catalog(path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module, *(f"{node.module}.{a.name}" for a in node.names)]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            continue
        found += [f"line {node.lineno}: {n}" for n in names if n.startswith("attribot.sim")]
    assert not found, f"{path.relative_to(SRC)} reads the simulator: {found}"

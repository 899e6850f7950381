"""Code stays readable: no function over 60 lines and no class over 400 lines anywhere in the package
(issue 19's limits, kept by every layer since Architecture II)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "attribot"
LIMITED = sorted(p.name for p in SRC.iterdir() if p.is_dir() and not p.name.startswith("_"))
MAX_FUNCTION, MAX_CLASS = 60, 400


def _too_long(folder: str, root: Path = SRC) -> list[str]:
    out = []
    for path in sorted((root / folder).rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                limit = MAX_CLASS if isinstance(node, ast.ClassDef) else MAX_FUNCTION
                lines = (node.end_lineno or node.lineno) - node.lineno + 1
                if lines > limit:
                    out.append(f"{path.relative_to(root)}:{node.lineno} {node.name}: {lines} lines > {limit}")
    return out


@pytest.mark.parametrize("folder", LIMITED)
def test_no_function_or_class_is_too_long(folder):
    assert _too_long(folder) == []


def test_no_top_level_module_has_a_function_or_class_too_long():
    assert [line for line in _too_long(".") if "/" not in line.split(":")[0]] == []


def test_the_check_sees_a_long_function(tmp_path):
    (tmp_path / "pkg").mkdir()
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_FUNCTION))
    (tmp_path / "pkg" / "long.py").write_text(f"def f():\n{body}\n")
    assert [line.split(" ")[1] for line in _too_long("pkg", tmp_path)] == ["f:"]

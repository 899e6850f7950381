"""The runner's pipe protocol has one definition, importable by the worker (which loads no site-packages)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from attribot.runner import Limits, protocol


def test_the_protocol_imports_nothing():
    tree = ast.parse(Path(protocol.__file__).read_text())
    assert not [n for n in ast.walk(tree) if isinstance(n, ast.Import | ast.ImportFrom)]


def test_wire_limits_carry_every_limit_and_nothing_else():
    limits = Limits(wall_s=2.5, memory_mb=300)
    wire = protocol.WireLimits(**limits.model_dump()).to_wire()
    assert wire == limits.model_dump()
    back = protocol.WireLimits.from_wire(wire)
    assert back.wall_s == 2.5 and back.memory_mb == 300
    with pytest.raises(TypeError):
        protocol.WireLimits.from_wire({**wire, "surprise": 1})


def test_neither_end_spells_a_wire_key_itself():
    """Both ends use the protocol's names: no message literal like {"t": ...} or msg.get("m")."""
    import re

    from attribot.runner import calls, host, process, worker, worker_guards, worker_pipe, worker_stubs

    for module in (host, calls, process, worker, worker_pipe, worker_stubs, worker_guards):
        text = Path(module.__file__).read_text()
        assert not re.search(r"""\{\s*"[a-z]"\s*:|\.get\("[a-z]"\)|\["[a-z]"\]""", text), module.__name__


@pytest.mark.parametrize(
    "field", [{"wall_s": 1e9}, {"cpu_s": float("inf")}, {"memory_mb": 1 << 30}, {"max_api_calls": 10**12}]
)
def test_a_program_limit_beyond_its_range_is_refused(field):
    # issue 49: every limit a user can set has a range; a typo does not switch it off
    from pydantic import ValidationError

    with pytest.raises(ValidationError, match="less than or equal|finite"):
        Limits(**field)

"""Argument checks shared by the API classes (each failure names the method, the argument and the fix), and
how a message names a patch."""

from __future__ import annotations

import math
from typing import Any, TypeVar

from attribot.skills.errors import ApiArgumentError

__all__ = ["check_text", "check_number", "check_patch", "check_facade", "patch_named", "MAX_TEXT"]

MAX_TEXT = {"detector": 300, "vqa": 1000, "language": 2000}
"""Longest text accepted per backend role, in characters: an object name for the detector, a question for
visual question answering, a question for the language model. A backend's work grows with its input, so
the cap bounds what one API call can cost the host."""

T = TypeVar("T")


def _given(value: object) -> str:
    """What a program passed, for an error message: plain values as written (cut), anything else by its
    public class name only (never a host object's repr, which shows module paths and addresses)."""
    if value is None or isinstance(value, str | bytes | int | float):
        return f"{type(value).__name__} {value!r:.60}"
    if isinstance(value, list | tuple | dict | set | frozenset):
        return f"{type(value).__name__} of {len(value)} item{'' if len(value) == 1 else 's'}"
    public = next((c.__name__ for c in type(value).__mro__ if not c.__name__.startswith("_")), "object")
    return f"a {public}"


def check_text(value: object, arg: str, method: str, role: str) -> str:
    """`value` stripped, if it is a non-empty str of at most `MAX_TEXT[role]` characters."""
    if not isinstance(value, str):
        raise ApiArgumentError(
            f"{method}() needs {arg} as text, got {_given(value)}",
            f'pass a string, e.g. {method}("cup")'
            if arg == "object_name"
            else f'pass a string, e.g. {method}("What is this?")',
        )
    text = value.strip()
    if not text:
        raise ApiArgumentError(f"{method}() got an empty {arg}", f"pass a non-empty {arg}")
    limit = MAX_TEXT[role]
    if len(text) > limit:
        raise ApiArgumentError(
            f"{method}() got a {arg} of {len(text)} characters, more than {limit}",
            f"shorten the {arg} to at most {limit} characters",
        )
    return text


def check_number(value: object, arg: str, method: str) -> float:
    """`value` as a float, if it is a finite int or float (not a bool)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ApiArgumentError(
            f"{method}() needs {arg} as a number, got {_given(value)}",
            "pass a number, e.g. a patch attribute such as patch.horizontal_center",
        )
    number = float(value)
    if not math.isfinite(number):
        raise ApiArgumentError(f"{method}() got {arg}={number}, which is not finite", "pass a finite number")
    return number


def check_patch(value: object, cls: type[T], arg: str, method: str) -> T:
    """`value` if it is an instance of `cls` (an ImagePatch), else an error that says what to pass."""
    if not isinstance(value, cls):
        raise ApiArgumentError(
            f"{method}() needs {arg} as an {cls.__name__}, got {_given(value)}",
            f'pass a patch returned by image.find(...), e.g. {method}(image.find("cup")[0])',
        )
    return value


def check_facade(cls: type, namespace: dict[str, Any]) -> None:
    """Checked as a program-facing class is defined: each method it offers programs is documented for the
    LLM with an example program, and it names nothing public it does not declare (the host side lives in
    its session); a `TypeError` names what is wrong."""
    declared = {
        *namespace.get("OWN_METHODS", namespace.get("API_METHODS", ())),
        *namespace.get("API_ATTRIBUTES", ()),
        *namespace.get("HOST_METHODS", ()),
        *namespace.get("HOST_ATTRIBUTES", ()),
    }
    public = {n for n in namespace if not n.startswith("_") and not n.isupper()}
    if public - declared:
        raise TypeError(f"{cls.__name__} defines {sorted(public - declared)} without declaring them")
    for method in namespace.get("OWN_METHODS", namespace.get("API_METHODS", ())):
        doc = getattr(namespace.get(method), "__doc__", None) or ""
        if "def execute_command(" not in doc:
            raise TypeError(f"{cls.__name__}.{method} has no docstring with an example program for the LLM")


def patch_named(patch: Any) -> str:
    """A patch as an answer names it: its label, its id where the detector gives one, and its box (two
    objects found under one word, "object", are told apart by where they are)."""
    ident = f" ({patch.object_id})" if patch.object_id else ""
    box = ", ".join(str(round(v)) for v in patch.box)
    return f"the {patch.label or 'object'}{ident} at [{box}]"

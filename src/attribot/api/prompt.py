"""The planner's prompts: `attribot`, generated from the API classes themselves, and `paper`, the structure
of the paper authors' released prompt.

`attribot` (`build_prompt`): the API reference is Python source rendered from `ImagePatch` and `Robot`:
the names in their `API_ATTRIBUTES` / `API_METHODS`, signatures from `inspect`, docstrings (with their
`>>>` examples) as written in the classes. The rest of the prompt (guidelines after the paper and
ViperGPT, the sensors, the query, the answer format) is the template `prompts/program.jinja`, package data
rendered with `StrictUndefined`. There is no other copy of our API text. Robot methods are offered only
when the robot has the sensor they need (`Robot.REQUIRES`); the ones left out are named in one line with
the sensor that would enable them, so that the LLM does not invent them. With `embodied=False` (a still
image) no robot method is offered.

`paper` (`build_paper_prompt`): the template `prompts/paper.jinja`, in our own words with the structure
of the prompt the authors released: their API listing (the paper's dialect: `execute_command(image)`,
`Robot(sensors=[...])` made by the program, robot methods called bare and with object names), their
request and guidelines, and "Instruction: The robot is equipped with {sensors}. {query}". That listing
describes the paper's API as the authors wrote it, which the runner accepts beside ours; the sensors
beyond the paper's get their methods from the sensor registry. `PROMPTS` holds both, under the names of
`attribot.config.PROMPTS` (the `prompt` setting).
"""

from __future__ import annotations

import inspect
import textwrap
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

import jinja2

from attribot.api.patch import ImagePatch
from attribot.api.robot import Robot
from attribot.config import MAX_QUERY_CHARS
from attribot.errors import InputError
from attribot.sensors import SENSORS, check_sensors, sensor_names

__all__ = [
    "build_prompt",
    "build_paper_prompt",
    "api_reference",
    "offered_robot_methods",
    "PromptStyle",
    "PROMPTS",
    "prompt_style",
    "MAX_QUERY_CHARS",
    "ENTRY_POINT",
    "API_CLASS_NAMES",
]

ENTRY_POINT = "execute_command"
"""The function every program defines: `execute_command(image, robot)`."""
API_CLASS_NAMES: tuple[str, ...] = (ImagePatch.__name__, Robot.__name__)
"""The classes both prompts show as Python source; a reply that copies them around its function still
yields the function (`attribot.planning.extract`)."""
_TEMPLATE = "program.jinja"
_PAPER_TEMPLATE = "paper.jinja"


def offered_robot_methods(sensors: Sequence[str], embodied: bool = True) -> tuple[list[str], dict[str, str]]:
    """The Robot methods the prompt offers for `sensors`, and those left out with the sensor each needs."""
    have = check_sensors(sensors)
    if not embodied:
        return [], {}
    offered, missing = [], {}
    for name in Robot.API_METHODS:
        need = Robot.REQUIRES.get(name)
        if need is None or need in have:
            offered.append(name)
        else:
            missing[name] = need
    return offered, missing


def signature_text(func: Callable[..., Any]) -> str:
    """`(self, object_name: str) -> list[ImagePatch]`: parameters and annotations as written in the source."""
    sig = inspect.signature(func)  # annotations stay strings (postponed evaluation in the API modules)
    params = []
    for p in sig.parameters.values():
        text = p.name if p.annotation is inspect.Parameter.empty else f"{p.name}: {_ann(p.annotation)}"
        if p.default is not inspect.Parameter.empty:
            text += f" = {p.default!r}"
        params.append(text)
    ret = "" if sig.return_annotation is inspect.Signature.empty else f" -> {_ann(sig.return_annotation)}"
    return f"({', '.join(params)}){ret}"


def _ann(annotation: object) -> str:
    return annotation if isinstance(annotation, str) else getattr(annotation, "__name__", repr(annotation))


def _doc(obj: object) -> str:
    doc = inspect.getdoc(obj)
    if not doc:
        raise RuntimeError(f"{obj!r} is part of the API and has no docstring")  # a bug in api/, not input
    return doc


def _docstring_block(doc: str, indent: str) -> str:
    return textwrap.indent(f'"""{doc}\n"""', indent)


def render_class(cls: type, attributes: Sequence[str], methods: Sequence[str]) -> str:
    """Python source of `cls` as a program sees it: docstring, attributes with their types and meaning,
    methods with signatures and docstrings (bodies elided)."""
    lines = [f"class {cls.__name__}:", _docstring_block(_doc(cls), "    "), ""]
    for name in attributes:
        prop = inspect.getattr_static(cls, name)
        if not isinstance(prop, property):
            raise RuntimeError(f"{cls.__name__}.{name} is listed in API_ATTRIBUTES and is not a property")
        if prop.fget is None:
            raise RuntimeError(f"{cls.__name__}.{name} is a property without a getter")
        ret = inspect.signature(prop.fget).return_annotation
        lines.append(f"    {name}: {_ann(ret)}  # {_doc(prop)}")
    for name in methods:
        func = getattr(cls, name)
        lines += [
            "",
            f"    def {name}{signature_text(func)}:",
            _docstring_block(_doc(func), "        "),
            "        ...",
        ]
    return "\n".join(lines)


def api_reference(sensors: Sequence[str], embodied: bool = True) -> str:
    """The API part of the prompt: `ImagePatch` and the offered part of `Robot`, as Python source."""
    offered, _ = offered_robot_methods(sensors, embodied)
    return "\n\n\n".join(
        [
            render_class(ImagePatch, ImagePatch.API_ATTRIBUTES, ImagePatch.API_METHODS),
            render_class(Robot, Robot.API_ATTRIBUTES, offered),
        ]
    )


@cache
def _environment() -> jinja2.Environment:
    return jinja2.Environment(
        loader=jinja2.FunctionLoader(_load_template),
        undefined=jinja2.StrictUndefined,
        autoescape=False,  # the output is a plain-text prompt, never HTML
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
    )


def _load_template(name: str) -> str:
    return resources.files("attribot.api").joinpath("prompts", name).read_text(encoding="utf-8")


def build_prompt(query: str, sensors: Sequence[str], *, embodied: bool = True, findable: str = "") -> str:
    """The whole prompt for `query` and a robot with `sensors` (names or aliases of the sensors registered in
    `attribot.sensors.SENSORS`).

    embodied=False says the query runs on a still image: no robot action is offered. `findable` says what
    the detector can find in this world (`Perception.findable`); empty: the prompt says nothing of it.
    """
    text = _query_text(query)
    have = check_sensors(sensors)
    offered, missing = offered_robot_methods(have, embodied)
    return (
        _environment()
        .get_template(_TEMPLATE)
        .render(
            api=api_reference(have, embodied),
            entry_point=ENTRY_POINT,
            sensors=have,
            known_sensors=sensor_names(),
            measures={name: SENSORS.get(name).measures for name in have},
            findable=findable,
            embodied=embodied,
            offered=offered,
            missing=missing,
            query=text,
        )
    )


def _query_text(query: str) -> str:
    """The query on one line, checked: not empty, at most MAX_QUERY_CHARS."""
    if not isinstance(query, str) or not query.strip():
        raise InputError("the query is empty", 'ask a question, e.g. "the second cup from the left"')
    text = " ".join(query.split())
    if len(text) > MAX_QUERY_CHARS:
        raise InputError(
            f"the query has {len(text)} characters, more than {MAX_QUERY_CHARS}", "shorten the query"
        )
    return text


def build_paper_prompt(
    query: str, sensors: Sequence[str], *, embodied: bool = True, findable: str = ""
) -> str:
    """The prompt for `query` in the structure of the paper authors' released prompt (see the module
    docstring), for a robot with `sensors`; `embodied` and `findable` as in `build_prompt`."""
    text = _query_text(query)
    have = check_sensors(sensors)
    extras = [  # the senses read through read_sensor: the paper's own (distance, weight) are in the template
        {
            "method": sense.method,
            "sensor": sensor.name,
            "quantity": sense.quantity,
            "unit": sense.unit,
            "needs": str(sense.needs),
        }
        for sensor in map(SENSORS.get, have)
        if sensor.capability is None
        for sense in sensor.senses
    ]
    aliases = {name: (SENSORS.get(name).aliases or (name,))[0] for name in have}
    return (
        _environment()
        .get_template(_PAPER_TEMPLATE)
        .render(
            entry_point=ENTRY_POINT,
            sensors=have,
            aliases=aliases,
            extras=extras,
            findable=findable,
            embodied=embodied,
            query=text,
        )
    )


@dataclass(frozen=True)
class PromptStyle:
    """One prompt the LLM planner can show: its name, its builder (`(query, sensors, *, embodied,
    findable) -> str`) and the entry point its programs define, as feedback to the model names it."""

    name: str
    build: Callable[..., str]
    entry: str


PROMPTS: dict[str, PromptStyle] = {
    "attribot": PromptStyle("attribot", build_prompt, f"{ENTRY_POINT}(image, robot)"),
    "paper": PromptStyle("paper", build_paper_prompt, f"{ENTRY_POINT}(image)"),
}
"""The prompts by the names the `prompt` setting takes (`attribot.config.PROMPTS`)."""


def prompt_style(name: str) -> PromptStyle:
    """The prompt called `name`; an unknown one is an `InputError` naming those there are."""
    style = PROMPTS.get(name)
    if style is None:
        raise InputError(f"unknown prompt {name!r}", f"choose one of: {', '.join(PROMPTS)}")
    return style

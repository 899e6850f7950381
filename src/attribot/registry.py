"""The one plug-in mechanism: a named registry per kind of plug-in (layouts, backends, planners, ...).

Plug-ins register themselves with a decorator in the module that defines them. A registry knows the
modules that hold its plug-ins and imports them on the first look-up, so importing attribot stays cheap
and free of side effects.
"""

from __future__ import annotations

import importlib
import os
import weakref
from collections.abc import Callable, Iterator, Sequence
from typing import Any, ClassVar, Generic, TypeVar

from attribot.errors import BadPlugin, UnknownName
from attribot.text import comma_names

__all__ = ["Registry", "PLUGINS_ENV", "plugin_modules", "import_plugins"]

T = TypeVar("T")

PLUGINS_ENV = "ATTRIBOT_PLUGINS"
"""Comma-separated modules to import before a command runs (a lab's sensors, worlds, layouts, backends)."""


def plugin_modules() -> list[str]:
    """The modules `ATTRIBOT_PLUGINS` names, in order."""
    return comma_names(os.environ.get(PLUGINS_ENV, ""))


def import_plugins(modules: Sequence[str] | None = None) -> None:
    """Import plug-in `modules` (default: those `ATTRIBOT_PLUGINS` names) in a process a command starts
    (an evaluation's spawned worker, a Ray task on another machine): the command checked them as it
    started (`attribot.cli`), but a child has none of its imports, and a Ray node not even its
    environment, so without this a lab's backend or sensor is unknown there."""
    for name in plugin_modules() if modules is None else modules:
        importlib.import_module(name)


class Registry(Generic[T]):
    """A mapping from names to plug-ins of one kind.

    >>> shapes = Registry[int]("shape")
    >>> _ = shapes.register("box")(3)
    >>> shapes.get("box")
    3
    """

    _every: ClassVar[weakref.WeakSet[Any]] = weakref.WeakSet()

    def __init__(self, kind: str, modules: tuple[str, ...] = ()) -> None:
        self.kind = kind
        self._modules = modules
        self._loaded = not modules
        self._entries: dict[str, T] = {}
        self._aliases: dict[str, str] = {}
        Registry._every.add(self)

    @classmethod
    def load_all(cls) -> None:
        """Register the built-in plug-ins of every registry made so far: after a lab's plug-ins are imported,
        so that one that took a built-in's name is refused now, naming it, not at some later look-up."""
        for registry in list(cls._every):
            registry._load()

    def register(self, name: str, *, aliases: tuple[str, ...] = ()) -> Callable[[T], T]:
        """Decorator that adds `obj` under `name` (and its aliases); a name used twice is a `BadPlugin`."""

        def add(obj: T) -> T:
            for key in (name, *aliases):
                if key in self._entries or key in self._aliases:
                    raise BadPlugin(
                        f"{self.kind} {key!r} is registered twice: attribot's own or an earlier plug-in "
                        "has it",
                        f"give the new {self.kind} another name",
                    )
            self._entries[name] = obj
            for alias in aliases:
                self._aliases[alias] = name
            return obj

        return add

    def unregister(self, name: str) -> T:
        """Remove the plug-in `name` and its aliases (a plug-in registered for a while: a test's); returns
        it. An unknown name raises `UnknownName`."""
        self._load()
        if name not in self._entries:
            raise UnknownName(
                f"no {self.kind} {name!r} is registered", f"registered: {', '.join(self.names())}"
            )
        self._aliases = {a: n for a, n in self._aliases.items() if n != name}
        return self._entries.pop(name)

    def _load(self) -> None:
        if not self._loaded:
            self._loaded = True
            for module in self._modules:
                importlib.import_module(module)

    def get(self, name: str) -> T:
        """The plug-in called `name`; an unknown name raises `UnknownName` listing the known ones."""
        self._load()
        key = self._aliases.get(name, name)
        if key not in self._entries:
            known = ", ".join(self.names()) or "none"
            raise UnknownName(f"unknown {self.kind} {name!r}", f"choose one of: {known}")
        return self._entries[key]

    def names(self) -> list[str]:
        """Registered names, in registration order."""
        self._load()
        return list(self._entries)

    def items(self) -> Iterator[tuple[str, T]]:
        self._load()
        return iter(list(self._entries.items()))

    def __contains__(self, name: object) -> bool:
        self._load()
        return name in self._entries or name in self._aliases

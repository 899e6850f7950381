"""The one plug-in mechanism: a named registry per kind of plug-in (layouts, backends, planners, ...).

Plug-ins register themselves with a decorator in the module that defines them. A registry knows where its
built-in plug-ins live and imports them only when asked, so importing attribot stays cheap and free of side
effects: `homes` maps each built-in name (and alias) to the module that registers it, and a look-up of
that name imports that module alone (an oracle question imports no transformers, detector or robot bridge
code); `modules` are imported, with every home, on the first look-up of any other name and whenever all the
names are listed (the kinds whose users want them all: query families, tasks, sensors). A lab's plug-in
registers by being imported, and a name it takes from a built-in is refused as it registers.
"""

from __future__ import annotations

import importlib
import os
import sys
import weakref
from collections.abc import Callable, Iterator, Mapping, Sequence
from types import FrameType
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

    `homes`: the module that registers each built-in name or alias, imported by a look-up of that name
    alone; listing the names imports them all. `modules`: more modules imported when all are wanted.
    """

    _every: ClassVar[weakref.WeakSet[Any]] = weakref.WeakSet()

    def __init__(
        self, kind: str, modules: tuple[str, ...] = (), *, homes: Mapping[str, str] | None = None
    ) -> None:
        self.kind = kind
        self._homes: dict[str, str] = dict(homes or {})
        self._modules = tuple(dict.fromkeys((*self._homes.values(), *modules)))
        self._loaded = not self._modules
        self._entries: dict[str, T] = {}
        self._aliases: dict[str, str] = {}
        self._origins: dict[str, int] = {}  # a built-in's name -> the position of the module registering it
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
            for key in (name, *aliases):  # a built-in's name: its own module registers it first
                home = self._homes.get(key)
                if home is not None and home not in sys.modules:
                    importlib.import_module(home)
            for key in (name, *aliases):
                if key in self._entries or key in self._aliases:
                    raise BadPlugin(
                        f"{self.kind} {key!r} is registered twice: attribot's own or an earlier plug-in "
                        "has it",
                        f"give the new {self.kind} another name",
                    )
            self._entries[name] = obj
            origin = self._origin()
            if origin is not None:
                self._origins[name] = origin
            for alias in aliases:
                self._aliases[alias] = name
            return obj

        return add

    def unregister(self, name: str) -> T:
        """Remove the plug-in `name` and its aliases (a plug-in registered for a while: a test's); returns
        it. An unknown name raises `UnknownName`."""
        if self._find(name) != name:
            raise UnknownName(
                f"no {self.kind} {name!r} is registered", f"registered: {', '.join(self.names())}"
            )
        self._aliases = {a: n for a, n in self._aliases.items() if n != name}
        return self._entries.pop(name)

    def _origin(self) -> int | None:
        """The position in `_modules` of the built-in module whose import is registering now, or None (a
        lab's plug-in): the nearest caller that is one, as a module may register through a helper."""
        frame: FrameType | None = sys._getframe(2)
        while frame is not None:
            module = frame.f_globals.get("__name__")
            if module in self._modules:
                return self._modules.index(module)
            frame = frame.f_back
        return None

    def _load(self) -> None:
        if not self._loaded:
            self._loaded = True
            for module in self._modules:
                importlib.import_module(module)

    def _find(self, name: str) -> str | None:
        """The registered name that `name` (a name or an alias) stands for, or None: a name not registered
        yet imports its home alone, or, with no home, every module of the registry."""
        key = self._aliases.get(name, name)
        if key not in self._entries and not self._loaded:
            home = self._homes.get(name)
            if home is not None:
                importlib.import_module(home)
                key = self._aliases.get(name, name)
            if key not in self._entries:
                self._load()
                key = self._aliases.get(name, name)
        return key if key in self._entries else None

    def get(self, name: str) -> T:
        """The plug-in called `name`; an unknown name raises `UnknownName` listing the known ones."""
        key = self._find(name)
        if key is None:
            known = ", ".join(self.names()) or "none"
            raise UnknownName(f"unknown {self.kind} {name!r}", f"choose one of: {known}")
        return self._entries[key]

    def names(self) -> list[str]:
        """Registered names: the built-ins in the order of their homes, else of their modules, then the
        others in registration order: the same order whichever was looked up or imported first."""
        self._load()
        rank = {name: i for i, name in enumerate(self._homes)}
        last = len(rank)
        return sorted(
            self._entries,
            key=lambda name: (rank.get(name, last), self._origins.get(name, len(self._modules))),
        )

    def items(self) -> Iterator[tuple[str, T]]:
        return iter([(name, self._entries[name]) for name in self.names()])

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and self._find(name) is not None

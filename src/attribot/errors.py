"""The project's exception types. Every error names the problem and, where there is one, the fix."""

from __future__ import annotations

__all__ = [
    "AttribotError",
    "ConfigError",
    "MissingDependency",
    "UnknownName",
    "UnsupportedAction",
    "InputError",
    "BackendError",
    "InvalidValue",
    "InvalidSetting",
    "BadPlugin",
]


class AttribotError(Exception):
    """Base class: a message for a person, and an optional line that says how to fix it.

    `recoverable`: the error of an action or measurement that ran and failed in the world (a grasp that
    closed on nothing, a rangefinder that saw nothing in range), which a program may catch and carry on
    after; every other error is the program's to fix."""

    recoverable = False

    def __init__(self, message: str, fix: str | None = None) -> None:
        self.message = message
        self.fix = fix
        super().__init__(message if fix is None else f"{message} ({fix})")


class InputError(AttribotError):
    """Bad user input: an empty query, an unreadable image, a bad seed."""


class ConfigError(AttribotError):
    """A configuration that cannot work: an unknown backend spec, a missing model path."""


class UnknownName(AttribotError, KeyError):
    """A name looked up in a registry (layout, backend, category, planner) that is not there."""

    def __str__(self) -> str:  # KeyError would quote the message
        return Exception.__str__(self)


class MissingDependency(AttribotError, ImportError):
    """An optional extra is not installed; the message carries the exact pip line."""


class UnsupportedAction(AttribotError):
    """A world or robot was asked for a capability it does not have; the message names it."""


class BackendError(AttribotError):
    """A model backend or endpoint failed: unreachable, refused the key, timed out, answered garbage."""


class InvalidValue(InputError, ValueError):
    """A config record given a value it cannot take (`SceneConfig(seed=-1)`), naming the field, its limits
    and the fix; a ValueError too, as the validation error it replaces was."""


class InvalidSetting(ConfigError, ValueError):
    """A setting that cannot take its value (from the settings file, an ATTRIBOT_* variable or a keyword),
    naming it and where it came from, and never echoing a secret; a ValueError too."""


class BadPlugin(ConfigError, ValueError):
    """A plug-in that cannot be registered: a name that is taken, a method name a program cannot call."""

"""Errors raised inside API methods. The runner reports every one as category "api" with its message; a
program may catch the recoverable ones (`ActionFailed` and a controller's failed motion) as `ActionFailed`."""

from __future__ import annotations

from attribot.errors import AttribotError, InputError, UnsupportedAction

__all__ = ["ApiError", "ApiArgumentError", "MissingSensor", "PreconditionError", "ActionFailed"]


class ApiError(AttribotError):
    """Base of the errors a program meets when it calls the API."""


class ApiArgumentError(ApiError, InputError):
    """A bad argument: wrong type, empty text, a box outside the image."""


class MissingSensor(ApiError, UnsupportedAction):
    """A robot method needs a sensor this robot was not given."""


class PreconditionError(ApiError):
    """A robot method was called in the wrong state (weighing an object that is not held)."""


class ActionFailed(ApiError):
    """A sensor or action ran and gave no usable result (the rangefinder saw nothing in range)."""

    recoverable = True

"""The plug-in modules of ATTRIBOT_PLUGINS, imported before any command runs."""

from __future__ import annotations

import contextlib
from pathlib import Path

from attribot.cli.output import brief
from attribot.errors import AttribotError


def load_plugins() -> None:
    """Import the modules named in ATTRIBOT_PLUGINS, then every registry's own plug-ins. Whatever a module
    does wrong as it is imported (a name that is no module, an exception, a syntax error, `sys.exit`, a
    name taken from attribot's own) is a `ConfigError` naming the module and what it did; what it prints
    goes to stderr, so that --json output stays JSON."""
    import importlib
    import sys

    from attribot.errors import ConfigError
    from attribot.registry import PLUGINS_ENV, Registry, plugin_modules

    names = plugin_modules()
    fix = f"fix the module, or take it out of {PLUGINS_ENV}"
    for name in names:
        if not all(part.isidentifier() for part in name.split(".")):
            relative = (
                " (a relative name: there is no package for it to be relative to)" if name[0] == "." else ""
            )
            raise ConfigError(
                f"{PLUGINS_ENV} names {brief(name)!r}, which is no module name{relative}",
                f"give absolute module names separated by commas, e.g. {PLUGINS_ENV}=lab_sensors,lab.worlds",
            )
        try:
            with contextlib.redirect_stdout(sys.stderr):
                importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name == name or name.startswith(f"{exc.name}."):  # the module itself, not one it imports
                raise ConfigError(
                    f"{PLUGINS_ENV} names the module {brief(name)!r}, which cannot be imported "
                    f"({brief(str(exc), 200)})",
                    f"put it on PYTHONPATH (or install it), or take it out of {PLUGINS_ENV}",
                ) from None
            raise ConfigError(
                f"the plug-in module {brief(name)!r} failed as it was imported: {_raised(exc)}", fix
            ) from None
        except SystemExit as exc:
            raise ConfigError(
                f"the plug-in module {brief(name)!r} called sys.exit({exc.code!r}) as it was imported"[:300],
                f"a plug-in registers what it adds and returns; {fix}",
            ) from None
        except BaseException as exc:  # noqa: BLE001 (anything a module does as it is imported is its own)
            raise ConfigError(
                f"the plug-in module {brief(name)!r} failed as it was imported: {_raised(exc)}", fix
            ) from None
    if names:
        try:  # a plug-in that took a built-in's name, or a method Robot has, is said now, not later
            Registry.load_all()
            from attribot.api.robot import Robot

            Robot.API_METHODS  # noqa: B018 (installs the plug-ins' sensor methods, refusing a clash)
        except AttribotError as exc:
            raise ConfigError(
                f"a plug-in of {PLUGINS_ENV} ({brief(', '.join(names), 200)}) clashes with attribot's own: "
                f"{brief(exc.message, 300)}",
                exc.fix or fix,
            ) from None


def _raised(exc: BaseException) -> str:
    """What an exception raised in a plug-in says, and where in the plug-in (not inside attribot)."""
    import traceback

    where = ""
    if isinstance(exc, SyntaxError) and exc.filename:
        where = f" ({exc.filename}, line {exc.lineno})"
    else:
        own = str(Path(__file__).resolve().parents[1])  # attribot itself, not only its cli
        frames = [
            f
            for f in traceback.extract_tb(exc.__traceback__)
            if not f.filename.startswith(("<frozen", own)) and "importlib" not in f.filename
        ]
        if frames:
            where = f" ({frames[-1].filename}, line {frames[-1].lineno})"
    text = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    return (text if len(text) <= 300 else text[:297] + "...") + where

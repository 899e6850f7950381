"""The local web demo: a page over `attribot ask` (see `attribot.demo.app`), started by `attribot demo`."""

from __future__ import annotations

from attribot.demo.app import DemoConfig, create_app
from attribot.demo.serve import serve_demo

__all__ = ["DemoConfig", "create_app", "serve_demo"]

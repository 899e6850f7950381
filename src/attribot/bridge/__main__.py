"""`python -m attribot.bridge`: serve a RoboMaster EP on the robot's own computer (Python 3.8 and up).

The full `attribot` command needs Python 3.11; the robot's computer runs the SDK on Python 3.6 to 3.8 and
needs only this package (copy `src/attribot/__init__.py` and `src/attribot/bridge/`), numpy and the SDK:

    python3.8 -m attribot.bridge --token "$(python3 -c 'import secrets; print(secrets.token_hex(16))')" \\
        --port 7777 --host 0.0.0.0 --option load_cell_newtons_per_count=0.0123 --option load_cell_zero=512

It listens on 127.0.0.1 unless `--host` says otherwise; beyond this machine the token must be strong (at
least 16 characters of more than one kind, no obvious word). Each limit has a safe range (`--help`).
"""

from __future__ import annotations

import argparse
import logging
import sys
from typing import Any

from attribot.bridge.guard import TOKEN_FIX, bind_problem
from attribot.bridge.server import LIMIT_RANGES, Limits, RobotServer


def _limit_help(name: str, what: str) -> str:
    _, low, high, unit = LIMIT_RANGES[name]
    return f"{what} ({low:g} to {high:g} {unit})"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m attribot.bridge", description=__doc__.splitlines()[0])
    parser.add_argument("--driver", default="robomaster", choices=["robomaster"])
    parser.add_argument("--token", required=True, help="shared secret the planner's computer must send")
    parser.add_argument("--port", type=int, default=7777, help="TCP port, 1 to 65535")
    parser.add_argument(
        "--host", default="127.0.0.1", help="address to bind (default 127.0.0.1; 0.0.0.0: every interface)"
    )
    parser.add_argument("--max-speed", type=float, default=0.5, help=_limit_help("max_speed", "speed limit"))
    parser.add_argument(
        "--max-turn", type=float, default=1.5, help=_limit_help("max_turn", "turn-rate limit")
    )
    parser.add_argument("--max-accel", type=float, default=2.0, help=_limit_help("max_accel", "accel limit"))
    parser.add_argument(
        "--watchdog", type=float, default=0.5, help=_limit_help("watchdog_s", "stop after this long idle")
    )
    parser.add_argument("--option", action="append", default=[], help="driver option KEY=VALUE")
    args = parser.parse_args(argv)
    if not args.token.strip():
        parser.error("--token is blank: give the shared secret the planner's computer sends")
    if not 0 < args.port < 65536:
        parser.error(f"--port must lie in 1 to 65535, got {args.port}")
    problem = bind_problem(args.host, args.token)
    if problem is not None:
        parser.error(f"{problem}: give a stronger --token ({TOKEN_FIX}), or listen on 127.0.0.1")
    from attribot.bridge.robomaster import RoboMasterDriver, SdkMissing, driver_options

    options: dict[str, Any] = {}
    for item in args.option:
        key, sep, value = item.partition("=")
        if not sep:
            parser.error(f"--option {item!r} is not KEY=VALUE")
        options[key.strip()] = value.strip()
    try:
        limits = Limits(args.max_speed, args.max_turn, args.max_accel, watchdog_s=args.watchdog)
        kwargs = driver_options(options)
    except ValueError as exc:
        parser.error(str(exc))
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(message)s")
    try:
        driver = RoboMasterDriver.connect(**kwargs)
    except SdkMissing as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    try:
        server = RobotServer(driver, args.token, host=args.host, port=args.port, limits=limits)
    except (OSError, ValueError) as exc:
        driver.close()
        print(f"error: cannot serve on {args.host}:{args.port} ({exc})", file=sys.stderr)
        return 2
    print(f"bridge: serving {driver.name} on tcp://{args.host}:{server.address[1]}", file=sys.stderr)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
        driver.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())

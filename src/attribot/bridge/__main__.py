"""`python -m attribot.bridge`: serve a RoboMaster EP on the robot's own computer (Python 3.8 and up).

The full `attribot` command needs Python 3.11; the robot's computer runs the SDK on Python 3.6 to 3.8 and
needs only this package (copy `src/attribot/__init__.py` and `src/attribot/bridge/`), numpy and the SDK:

    python3.8 -m attribot.bridge --token SECRET --port 7777 --host 0.0.0.0 \\
        --option load_cell_newtons_per_count=0.0123 --option load_cell_zero=512
"""

from __future__ import annotations

import argparse
import logging
import sys
from typing import Any

from attribot.bridge.server import Limits, RobotServer


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m attribot.bridge", description=__doc__.splitlines()[0])
    parser.add_argument("--driver", default="robomaster", choices=["robomaster"])
    parser.add_argument("--token", required=True, help="shared secret the planner's computer must send")
    parser.add_argument("--port", type=int, default=7777)
    parser.add_argument("--host", default="0.0.0.0", help="address to bind (default: every interface)")
    parser.add_argument("--max-speed", type=float, default=0.5, help="m/s")
    parser.add_argument("--max-turn", type=float, default=1.5, help="rad/s")
    parser.add_argument("--max-accel", type=float, default=2.0, help="m/s^2")
    parser.add_argument("--watchdog", type=float, default=0.5, help="s without a command before stopping")
    parser.add_argument("--option", action="append", default=[], help="driver option KEY=VALUE")
    args = parser.parse_args(argv)
    if not args.token.strip():
        parser.error("--token is blank: give the shared secret the planner's computer sends")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(message)s")
    from attribot.bridge.robomaster import RoboMasterDriver, driver_options

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
    driver = RoboMasterDriver.connect(**kwargs)
    server = RobotServer(driver, args.token, host=args.host, port=args.port, limits=limits)
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

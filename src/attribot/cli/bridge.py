"""`attribot bridge serve`: the robot side of the robot bridge."""

from __future__ import annotations

from typing import Any

import typer

from attribot.cli.flags import SCENE_FLAGS, only, with_flags
from attribot.cli.output import Command, Group, err_console, fail
from attribot.cli.worlds import scene_config, scene_world

bridge_app = typer.Typer(
    cls=Group,
    help="The robot bridge: `attribot bridge serve` on the robot (see docs/bridge-protocol.md).",
    no_args_is_help=True,
)


def _bridge_driver(driver: str, given: Any) -> Any:
    """The robot `attribot bridge serve` serves: the embedded world's, or a RoboMaster EP's."""
    if driver == "mujoco":
        world = scene_world(scene_config(given))
        from attribot.embodiments.bridge import EmbodimentDriver

        return EmbodimentDriver(world)
    from attribot.bridge.robomaster import SDK_MISSING, RoboMasterDriver, SdkMissing, driver_options

    raw = {k: v for item in given.option or [] for k, _, v in [item.partition("=")]}
    try:
        kwargs = driver_options(raw)
    except ValueError as exc:
        raise fail(str(exc), "see docs/bridge-protocol.md for the robomaster options") from None
    try:
        return RoboMasterDriver.connect(**kwargs)
    except SdkMissing:
        raise fail(SDK_MISSING) from None  # one line: what is missing and how to install it


@bridge_app.command("serve", cls=Command)
@with_flags(only(SCENE_FLAGS, "layout", "seed", "option", "width", "height", "robot"))
def bridge_serve(
    driver: str = typer.Option(..., "--driver", help="mujoco (the embedded world) or robomaster (DJI EP)."),
    token: str = typer.Option(..., "--token", help="Shared secret the planner's computer must send."),
    port: int = typer.Option(7777, "--port", help="TCP port to listen on (1 to 65535)."),
    host: str = typer.Option(
        "127.0.0.1", "--host", help="Address to bind (0.0.0.0: every interface; then a strong --token)."
    ),
    max_speed: float = typer.Option(0.5, "--max-speed", help="Base speed limit, m/s (0.01 to 3.5)."),
    max_turn: float = typer.Option(1.5, "--max-turn", help="Base turn-rate limit, rad/s (0.01 to 10)."),
    max_accel: float = typer.Option(2.0, "--max-accel", help="Base acceleration limit, m/s^2 (0.01 to 10)."),
    watchdog: float = typer.Option(
        0.5, "--watchdog", help="Stop base and arm after this many s without a command (0.05 to 5)."
    ),
    given: Any = None,
) -> None:
    """Serve a robot (or the embedded world) to `attribot ask --world bridge` until interrupted."""
    import logging

    from attribot.bridge.guard import TOKEN_FIX, bind_problem
    from attribot.bridge.server import Limits, RobotServer

    if not token.strip():
        raise fail(
            "--token is blank",
            "give the shared secret the planner's computer sends, e.g. --token $(openssl rand -hex 16)",
        )
    if not 0 < port < 65536:
        raise fail(f"--port must lie in 1..65535, got {port}", "use e.g. --port 7777")
    problem = bind_problem(host, token)
    if problem is not None:
        raise fail(f"{problem}", f"give a stronger --token ({TOKEN_FIX}), or listen on 127.0.0.1")
    try:
        limits = Limits(max_speed=max_speed, max_turn=max_turn, max_accel=max_accel, watchdog_s=watchdog)
    except ValueError as exc:
        raise fail(str(exc), "give a limit within its safe range, e.g. --watchdog 0.5") from None
    if driver not in ("mujoco", "robomaster"):
        raise fail(f"--driver {driver!r} is not a bridge driver", "choose --driver mujoco or robomaster")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(message)s")
    robot = _bridge_driver(driver, given)
    try:
        server = RobotServer(robot, token, host=host, port=port, limits=limits)
    except OSError as exc:
        robot.close()
        raise fail(f"cannot listen on {host}:{port} ({exc.strerror})", "choose another --port") from None
    except ValueError as exc:
        robot.close()
        raise fail(str(exc), TOKEN_FIX) from None
    err_console.print(f"bridge: serving {robot.name} on tcp://{host}:{server.address[1]}", highlight=False)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
        robot.close()

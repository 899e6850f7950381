"""Driving the base on odometry: along a path with a PID per axis, or straight ahead, stopping when it
stalls (something the camera did not see is in the way) or runs out of time."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from attribot.control.base import ControlError, Failure
from attribot.control.pid import PID
from attribot.control.plant import Plant, moved
from attribot.control.spatial import FloorMap, head_towards

__all__ = ["Driver"]


@dataclass
class _Progress:
    """A drive's bookkeeping across its legs: control steps left, and since when the base is watched for a
    stall."""

    budget: int
    stall_steps: int
    stall_from: tuple[float, float, float]


@dataclass
class Driver:
    """Drives the plant's base (see the module docstring)."""

    plant: Plant

    def drive_to(
        self,
        pose: tuple[float, float, float],
        floor: FloorMap | None,
        action: str,
        look_at: np.ndarray | tuple[float, float, float] | None = None,
    ) -> None:
        """Drive to `pose`: along a path on `floor` when given, else straight."""
        path: list[np.ndarray] | None = [np.array(pose[:2])]
        if floor is not None:
            body = self.plant.body(action)
            path = floor.path(np.array(self.plant.pose()[:2]), np.array(pose[:2]), body.radius + 0.02)
            if path is None:
                raise ControlError(
                    f"not reachable: no free way to ({pose[0]:.2f}, {pose[1]:.2f}) on the floor the camera "
                    "sees",
                    "choose a place the robot can drive to",
                    reason=Failure.NOT_REACHABLE,
                )
        self.follow(path or [], pose, None if look_at is None else np.asarray(look_at, float), action)

    def follow(
        self,
        path: list[np.ndarray],
        pose: tuple[float, float, float],
        look_at: np.ndarray | None,
        action: str,
    ) -> None:
        """Follow waypoints with a PID per axis on the odometry pose, ending at `pose` (its yaw on the last
        leg), the head kept on `look_at`; fail when the base stalls or the time runs out."""
        t = self.plant.tuning
        pids = [PID(t.drive_kp, t.drive_ki, out_min=-t.drive_speed, out_max=t.drive_speed) for _ in "xy"]
        yaw_pid = PID(t.yaw_kp, t.yaw_ki, out_min=-t.max_yaw_rate, out_max=t.max_yaw_rate)
        legs = list(path) or [np.array(pose[:2])]
        progress = _Progress(int(t.drive_timeout_s / t.control_s), 0, self.plant.pose())
        for i, wp in enumerate(legs):
            for p in [*pids, yaw_pid]:
                p.reset()
            self._leg(wp, pose, i == len(legs) - 1, look_at, action, (pids[0], pids[1], yaw_pid), progress)
        self.stop()

    def _leg(
        self,
        wp: np.ndarray,
        pose: tuple[float, float, float],
        last: bool,
        look_at: np.ndarray | None,
        action: str,
        pids: tuple[PID, PID, PID],
        progress: _Progress,
    ) -> None:
        """Drive to waypoint `wp` (on the last leg, to `pose` with its yaw)."""
        t, world = self.plant.tuning, self.plant.world
        body = self.plant.body(action)
        dt = t.control_s
        while True:
            x, y, yaw = self.plant.pose()
            ex, ey = float(wp[0] - x), float(wp[1] - y)
            dist = math.hypot(ex, ey)
            want = pose[2] if (last or dist < 0.05) else math.atan2(ey, ex)
            eyaw = math.remainder(want - yaw, math.tau)
            near = t.arrive_tol * 0.5 if last else t.waypoint_tol
            if dist < near and (not last or abs(eyaw) < t.yaw_tol):
                return
            c, s = math.cos(yaw), math.sin(yaw)
            fx, fy = c * ex + s * ey, -s * ex + c * ey  # the error in the robot's frame
            world.command_base(
                pids[0].update(fx, 0.0, dt), pids[1].update(fy, 0.0, dt), pids[2].update(eyaw, 0.0, dt)
            )
            if look_at is not None and not self.plant.headless:
                world.set_head(*head_towards(look_at, (x, y, yaw), body))
            world.step(dt)
            if self._check_progress(progress, dist, pose) and last:
                return  # stalled at the goal: as near as the base gets (odometry drifts)

    def _check_progress(self, progress: _Progress, dist: float, pose: tuple[float, float, float]) -> bool:
        """Count one control step; fail when the base has stalled for `stall_s` away from its waypoint, or
        when the drive's time is up. True when it has stalled within `stall_arrive_m` of the waypoint."""
        t = self.plant.tuning
        progress.budget -= 1
        progress.stall_steps += 1
        if progress.stall_steps * t.control_s >= t.stall_s:
            now = self.plant.pose()
            if not moved(now, progress.stall_from, 0.01, 0.02) and dist <= t.stall_arrive_m:
                return True
            if not moved(now, progress.stall_from, 0.01, 0.02) and dist > 0.05:
                self.stop()
                raise ControlError(
                    f"blocked: the base stopped at ({now[0]:.2f}, {now[1]:.2f}) on its way to "
                    f"({pose[0]:.2f}, {pose[1]:.2f})",
                    "something the camera did not see is in the way; choose another target",
                    reason=Failure.BLOCKED,
                )
            progress.stall_steps, progress.stall_from = 0, now
        if progress.budget <= 0:
            self.stop()
            raise ControlError(
                f"did not converge: the base did not reach ({pose[0]:.2f}, {pose[1]:.2f}) within "
                f"{t.drive_timeout_s:.0f} s",
                "something blocks the way; choose another target",
                reason=Failure.NOT_CONVERGED,
            )
        return False

    def straight(self, metres: float) -> None:
        """Drive straight forward (or back) by `metres` on odometry, whatever is in the way; the head stays
        where it is."""
        t, world = self.plant.tuning, self.plant.world
        x, y, yaw = self.plant.pose()
        goal = (x + metres * math.cos(yaw), y + metres * math.sin(yaw), yaw)
        speed, dt = t.straight_speed * math.copysign(1.0, metres), t.control_s
        for _ in range(int(abs(metres) / t.straight_speed / dt * 2) + 20):
            now = self.plant.pose()
            left = (goal[0] - now[0]) * math.cos(yaw) + (goal[1] - now[1]) * math.sin(yaw)
            if left * speed <= 0.005:
                break
            world.command_base(speed, 0.0, 0.0)
            world.step(dt)
        self.stop()

    def stop(self) -> None:
        """Command the base to stop and let it."""
        self.plant.world.command_base(0.0, 0.0, 0.0)
        self.plant.world.step(self.plant.tuning.stop_s)

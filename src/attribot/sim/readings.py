"""What the simulated robot's rangefinder, wrist force sensor and odometry read, with the world's noise.

Each is a collaborator of a `SimWorld` (see its module docstring for the noise): it reads the world's public
attributes, and draws from the generators the world hands it, in the order the world always drew them.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from attribot.sim.truth import name2id

if TYPE_CHECKING:
    from attribot.sim.world import SimWorld

__all__ = ["Rangefinder", "ForceSensor", "Odometry"]


class Rangefinder:
    """The rangefinder along the optical axis: noise that grows with range, dropouts, a maximum range, and
    a beam off the axis by a pointing error."""

    def __init__(self, world: SimWorld, rng: np.random.Generator) -> None:
        self._world = world
        self._rng = rng
        model = world.model
        self._adr = int(model.sensor_adr[name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, "rangefinder")])

    def read(self) -> float:
        """Metres from the optical centre; inf when nothing is in range (and, with noise, on a dropout)."""
        w = self._world
        mujoco.mj_forward(w.model, w.data)
        n, rng = w.noise, self._rng
        if n.beam_deg:
            r = self._beam(math.radians(n.beam_deg))
        else:
            r = float(w.data.sensordata[self._adr])
        range_max = min(w.body.range_max, n.range_max or math.inf)
        if r < 0 or r > range_max:
            return math.inf
        if n.range_dropout and rng.random() < n.range_dropout:
            return math.inf
        if n.range_std:
            r = max(0.0, r + float(rng.normal(0.0, n.range_std * r)))
        return r

    def _beam(self, sigma: float) -> float:
        """What the beam hits, cast along the optical axis turned by a pointing error of `sigma` radians."""
        w = self._world
        site = w.range_site
        origin = w.data.site_xpos[site].copy()
        frame = w.data.site_xmat[site].reshape(3, 3)
        ex, ey = self._rng.normal(0.0, sigma, 2)
        direction = frame @ np.array([math.tan(ex), math.tan(ey), 1.0])
        direction /= np.linalg.norm(direction)
        geom = np.zeros(1, np.int32)
        body = int(w.model.site_bodyid[site])
        visible = w.ray_groups  # bodies, furniture, room, robot: not collision boxes, not looks
        r = mujoco.mj_ray(w.model, w.data, origin, direction, visible, 1, body, geom)
        return float(r)


class ForceSensor:
    """The wrist force sensor: a bias that the tare removes, a drift since the last tare, noise on every
    reading. Its bias is drawn from `noise_rng` when it is made."""

    def __init__(self, world: SimWorld, rng: np.random.Generator, noise_rng: np.random.Generator) -> None:
        self._world = world
        self._rng = rng  # for the config's force_noise_std
        self._noise_rng = noise_rng  # for the noise's bias, drift and force_std
        model = world.model
        self._adr = int(model.sensor_adr[name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, "wrist_force")])
        self._site = name2id(model, mujoco.mjtObj.mjOBJ_SITE, "ft_site")
        n = world.noise
        self._bias = noise_rng.normal(0.0, n.force_bias, 3) if n.force_bias else np.zeros(3)
        self._drift_rate = np.zeros(3)
        self._tare_time = 0.0
        self._tare = np.zeros(3)

    def _raw(self) -> np.ndarray:
        w = self._world
        mujoco.mj_rnePostConstraint(w.model, w.data)
        mujoco.mj_sensorAcc(w.model, w.data)
        f_site = w.data.sensordata[self._adr : self._adr + 3].copy()
        # MuJoCo reports, in the site frame, the force with which the arm holds the wrist's subtree up;
        # its opposite is the load on the wrist, so that a held mass m adds (0, 0, -m*g) in the world frame
        return -(w.data.site_xmat[self._site].reshape(3, 3) @ f_site)

    def tare(self) -> None:
        """Zero the sensor with what it carries now."""
        self._tare = self._raw() + self._bias
        self._tare_time = float(self._world.data.time)
        if self._world.noise.force_drift:  # each tare starts a new slow drift
            self._drift_rate = self._noise_rng.normal(0.0, self._world.noise.force_drift, 3)

    def read(self) -> np.ndarray:
        """Newtons, world frame, relative to the last tare, with the noise."""
        w = self._world
        since = float(w.data.time) - self._tare_time
        f = self._raw() + self._bias + self._drift_rate * since - self._tare
        if w.force_noise_std > 0:
            f = f + self._rng.normal(0.0, w.force_noise_std, 3)
        if w.noise.force_std:
            f = f + self._noise_rng.normal(0.0, w.noise.force_std, 3)
        return f

    def state(self) -> tuple[np.ndarray, float, np.ndarray]:
        """The last tare, when it was made, and the drift since: for `restore`."""
        return self._tare.copy(), self._tare_time, self._drift_rate.copy()

    def restore(self, state: tuple[np.ndarray, float, np.ndarray]) -> None:
        tare, self._tare_time, drift = state
        self._tare, self._drift_rate = np.array(tare), np.array(drift)


class Odometry:
    """The base pose as the robot believes it: the truth, with a wheel scale error and a heading bias drawn
    from `rng` when it is made, so that its drift grows with the distance travelled."""

    def __init__(self, world: SimWorld, rng: np.random.Generator) -> None:
        self._world = world
        drift = world.noise.odom_drift
        self._scale = 1.0 + float(rng.normal(0.0, drift))
        self._bias = float(rng.normal(0.0, drift))
        self.pose = np.array(world.base_pose(), float)
        self._last = self.pose.copy()

    def track(self) -> None:
        """Add the motion since the last call, through the scale error and heading bias (nothing to do
        without drift: odometry is then the truth)."""
        if not self._world.noise.odom_drift:
            return
        true = np.array(self._world.base_pose(), float)
        delta = true - self._last
        delta[2] = math.remainder(delta[2], math.tau)
        self._last = true
        if not delta.any():
            return
        # the displacement in the robot's frame, as the wheels measure it, turned into the odometry frame
        yaw_true = true[2] - delta[2] / 2
        c, s = math.cos(yaw_true), math.sin(yaw_true)
        fwd, left = c * delta[0] + s * delta[1], -s * delta[0] + c * delta[1]
        fwd, left = fwd * self._scale, left * self._scale
        turn = delta[2] * self._scale + self._bias * math.hypot(fwd, left)
        c, s = math.cos(self.pose[2] + turn / 2), math.sin(self.pose[2] + turn / 2)
        self.pose[0] += c * fwd - s * left
        self.pose[1] += s * fwd + c * left
        self.pose[2] = math.remainder(self.pose[2] + turn, math.tau)

    def read(self) -> tuple[float, float, float]:
        """(x, y, yaw) as the robot believes it."""
        if not self._world.noise.odom_drift:
            return self._world.base_pose()
        return float(self.pose[0]), float(self.pose[1]), float(self.pose[2])

    def restore(self, pose: np.ndarray) -> None:
        """Believe `pose`, with the motion tracked from where the base truly is now."""
        self.pose = np.array(pose, float)
        self._last = np.array(self._world.base_pose(), float)

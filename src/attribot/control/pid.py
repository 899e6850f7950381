"""A PID controller for visual servoing, stepped with the real time between control steps.

What it does that a textbook PID does not, each because a servo loop on a robot needs it:
- output limits, and anti-windup by conditional integration: while the output is saturated, error that
  would push it further into saturation is not integrated (and the integral itself never exceeds what the
  output could use), so the loop does not overshoot after a long saturated approach;
- the derivative acts on the measurement, not on the error, so a new setpoint does not kick the output;
  it is low-pass filtered (time constant `derivative_tau_s`) because pixel and range measurements are noisy;
- `dt` is the measured time of each step (sim time in the simulator, wall time on a robot): a late frame
  integrates more, and no step assumes a fixed rate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from attribot.errors import InputError

__all__ = ["PID"]


@dataclass
class PID:
    """u = kp * e + ki * integral(e) - kd * d(measurement)/dt, with e = setpoint - measurement, clamped to
    [out_min, out_max]. Call `update` once per control step with that step's `dt` (seconds); `reset` before
    reusing it on another target."""

    kp: float
    ki: float = 0.0
    kd: float = 0.0
    out_min: float = -math.inf
    out_max: float = math.inf
    derivative_tau_s: float = 0.0
    integral: float = field(default=0.0, init=False)
    output: float = field(default=0.0, init=False)
    _last_measurement: float | None = field(default=None, init=False, repr=False)
    _derivative: float = field(default=0.0, init=False, repr=False)

    def __post_init__(self) -> None:
        gains = (self.kp, self.ki, self.kd, self.derivative_tau_s)
        if not all(math.isfinite(g) and g >= 0 for g in gains):
            raise InputError(f"PID gains must be finite and >= 0, got {gains}", "give kp, ki, kd, tau >= 0")
        if not self.out_min < self.out_max:
            raise InputError(
                f"PID output limits [{self.out_min}, {self.out_max}] are empty", "give out_min < out_max"
            )

    def reset(self) -> None:
        """Forget the integral, the last measurement and the derivative: a fresh start."""
        self.integral = 0.0
        self.output = 0.0
        self._last_measurement = None
        self._derivative = 0.0

    def update(self, setpoint: float, measurement: float, dt: float) -> float:
        """The output for this step. `dt` is the time since the previous step (> 0, finite)."""
        if not (math.isfinite(dt) and dt > 0):
            raise InputError(f"PID step dt={dt!r} is not a positive time", "pass the measured seconds > 0")
        if not (math.isfinite(setpoint) and math.isfinite(measurement)):
            raise InputError(
                f"PID got setpoint={setpoint!r}, measurement={measurement!r}", "pass finite numbers"
            )
        error = setpoint - measurement
        if self._last_measurement is not None and self.kd > 0:
            raw = -(measurement - self._last_measurement) / dt
            alpha = dt / (self.derivative_tau_s + dt)
            self._derivative += alpha * (raw - self._derivative)
        self._last_measurement = measurement
        unclamped = self.kp * error + self.integral + self.kd * self._derivative
        if self.ki > 0:
            pushing_up = error > 0 and unclamped >= self.out_max
            pushing_down = error < 0 and unclamped <= self.out_min
            if not (pushing_up or pushing_down):
                self.integral += self.ki * error * dt
                self.integral = min(max(self.integral, self.out_min), self.out_max)
            unclamped = self.kp * error + self.integral + self.kd * self._derivative
        self.output = min(max(unclamped, self.out_min), self.out_max)
        return self.output

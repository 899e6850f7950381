"""The readings of a robot session and their statistics: the rangefinder, the force sensor (weight and
fullness), every registered sensor read through `read_sensor`, the uncertainty each measurement claims, and
`settle`, which measures again where a choice rests on values closer than their uncertainty (the
`remeasure`, `verify_actions` and `confidence` mechanisms act here)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import ClassVar

import numpy as np

from attribot.control.base import (
    Target,
)
from attribot.sensors import (
    Need,
    Sense,
    Sensor,
    sense_of_method,
)
from attribot.skills.acting import Acting
from attribot.skills.checks import check_patch, patch_named
from attribot.skills.errors import ActionFailed, ApiArgumentError, PreconditionError
from attribot.skills.named import as_named, by_object, combined, named_twice
from attribot.skills.robot_core import FULL, GRAVITY, Measurement, SessionCore, _own_sense
from attribot.skills.sighting import Sighting

__all__ = ["Measuring"]


class Measuring:
    """The readings of a robot session (see the module docstring): held by the session, they read and
    record through its `core` and arrange what a reading needs through its `acting`."""

    # the readings a measurement combines and the least uncertainty it claims: the senses' records
    FORCE_SAMPLES: ClassVar[int] = _own_sense("weight").readings
    FORCE_SAMPLE_S: ClassVar[float] = 0.05
    FORCE_MAX_SAMPLES: ClassVar[int] = 40  # re-measuring: until the standard error is small, at most this
    FORCE_RESOLUTION_N: ClassVar[float] = round(_own_sense("weight").resolution * GRAVITY, 9)
    RANGE_READINGS: ClassVar[int] = _own_sense("distance").readings
    RANGE_RESOLUTION_M: ClassVar[float] = _own_sense("distance").resolution

    def __init__(self, core: SessionCore, acting: Acting) -> None:
        self.core = core
        self.acting = acting

    def settle(self, chosen: Sighting) -> str | None:
        """Host side, after a program chose `chosen`: `confidence` measures again where the choice rests on
        values closer than their uncertainty (`attribot.skills.safeguards.Confidence`); None when settled,
        otherwise the sentence that says it cannot tell. A choice among measurements of which two names
        took one object (`named_twice`) is never settled, whatever the mechanisms."""
        last = self.last_measurement(chosen)
        twice = None if last is None else self.named_twice(last.kind)
        if last is not None and twice is not None:
            one, other = twice
            return (
                f"{patch_named(one)} and {patch_named(other)} are one object: the detector gave it both "
                f"names, and the {one.label} has no object of its own among those measured, so it is not "
                f"found here; a {last.kind} compared with itself is no answer (ask about each on its own, or "
                "look from elsewhere)"
            )
        return self.core.safeguards.confidence.settle(chosen, self)

    def named_twice(self, kind: str) -> tuple[Sighting, Sighting] | None:
        """Two patches of different names measured for `kind` that show one object where a name has no
        object of its own (`attribot.skills.named.named_twice`), or None."""
        return named_twice(self.core.measured, kind)

    def last_measurement(self, patch: Sighting) -> Measurement | None:
        """The latest measurement of the object of `patch`."""
        return next((m for m, p in reversed(self.core.measured) if p is patch or p.same_object(patch)), None)

    def as_named(self, chosen: Sighting) -> tuple[Sighting, str] | None:
        """Host side, after a program chose `chosen`: the object the question's names choose where it is not
        `chosen`, with the sentence that says why (`attribot.skills.named.as_named`); or None."""
        last = self.last_measurement(chosen)
        return None if last is None else as_named(self.core.measured, last.kind, chosen)

    def combined(self, kind: str) -> list[tuple[float, float, Sighting]]:
        """Each measured object's readings of `kind` combined (inverse-variance mean): (value, sd, patch)."""
        return combined(by_object(self.core.measured, kind))

    def measure_again(self, measurement: Measurement, patch: Sighting) -> None:
        """Measure `patch` again as `measurement` was measured, arranging first what its reading needs."""
        method = measurement.method or _own_sense(measurement.kind).method
        found = sense_of_method(method)
        needs = found[1].needs if found is not None else Need.NOTHING
        if found is not None and not hasattr(self, method):  # a sense read through read_sensor
            sensor, sense = found
            measure: Callable[[Sighting], float] = lambda p: self._sense(sensor, sense, p)  # noqa: E731
        else:
            measure = getattr(self, method)
        if needs is Need.GRASP:
            if self.core.held is not None:
                self.acting.put_down()
            self.acting.go_to_object(patch)
            self.acting.pick_up(patch)
            measure(patch)
            self.acting.put_down()
            return
        if needs is Need.REACH:
            self.acting.go_to_object(patch)
        elif needs is Need.AIM and method != "measure_distance":  # which centres the camera itself
            self.core.focus_on_patch(patch)
        measure(patch)

    def measure_distance(self, patch: Sighting) -> float:
        """The session's side of `Robot.measure_distance` (its docstring is the one programs read)."""
        self.core.need("measure_distance")
        p, target = self.core.object_of_call(patch, "measure_distance")
        self.core.focus(p, target)
        assert self.core.world is not None  # _target checked it
        metres, spread, samples = self._read_range(p)
        self.core.record(
            p,
            kind="distance",
            value=metres,
            unit="m",
            samples=samples,
            uncertainty=spread,
            method="measure_distance",
        )
        return metres

    def _read_range(self, p: Sighting) -> tuple[float, float, int]:
        """The rangefinder's reading of the object the camera is centred on: (metres, one standard
        deviation, readings used). With `remeasure`, several readings are combined (dropouts left out);
        with `verify_actions`, readings where the beam did not hit the object (farther than the depth in
        the object's middle, or nearer than its front: an edge, the wall behind) are left out, re-aiming
        once if none is left."""
        assert self.core.world is not None
        guards = self.core.safeguards
        count = guards.remeasure.readings(self.RANGE_READINGS)
        call = f"measure_distance({p.label or 'patch'})"
        for aim in range(2):
            readings = []
            for _ in range(count):
                r = float(self.core.world.read_distance())
                if math.isfinite(r) and r >= 0:
                    readings.append(r)
                if count > 1:
                    self.core.world.step(0.02)
            if count > 1:
                empty = count - len(readings)
                detail = f"{count} readings, {empty} empty"
                guards.remeasure.note(call, "caught" if empty else "confirmed", detail)
            readings = guards.verify_actions.on_object(
                readings,
                self._centre_depth,
                lambda depth: p.size_at(depth)[0] if p.frame.camera is not None else 0.0,
                call,
            )
            if readings:
                break
            if aim == 0 and guards.aims_again():
                self.core.focus(
                    p, p.target() or self.core.object_of_call(p, "measure_distance")[1]
                )  # aim again, read again
                continue
            break
        if not readings:
            raise ActionFailed(
                f"the distance sensor saw nothing within range when pointed at {p.label or 'the object'}",
                "the object may be too far away or hidden; compare the objects another way",
            )
        values = sorted(readings)
        metres = values[len(values) // 2] if len(values) % 2 else sum(values[len(values) // 2 - 1 :][:2]) / 2
        spread = _std(values) / math.sqrt(len(values)) if len(values) > 1 else 0.0
        floor = self.RANGE_RESOLUTION_M + (0.01 * metres if len(values) == 1 else 0.0)
        return metres, max(spread, floor), len(values)

    def _centre_depth(self) -> float | None:
        """The depth camera's distance to the surface at the image centre (where the object is, once
        focused): the nearest surface in a small window, along the optical axis. None without depth."""
        assert self.core.world is not None
        frame = self.core.world.observe()
        if frame.depth is None:
            return None
        h, w = frame.depth.shape
        win = frame.depth[h // 2 - 2 : h // 2 + 3, w // 2 - 2 : w // 2 + 3]
        finite = win[np.isfinite(win) & (win > 0.05)]
        # the nearest surface, not the middle one: a thin object (a lamp's pole) fills a few pixels of the
        # window, and the wall behind the rest
        return float(np.percentile(finite, 10)) if finite.size else None

    def measure_weight(self, patch: Sighting) -> float:
        """The session's side of `Robot.measure_weight` (its docstring is the one programs read)."""
        self.core.need("measure_weight")
        p, target = self.core.object_of_call(patch, "measure_weight")
        self._held_for(p, target, "measure_weight")
        assert self.core.world is not None
        newtons, error, samples = self._weigh(p)
        kg = newtons / GRAVITY
        self.core.record(
            p,
            kind="weight",
            value=kg,
            unit="kg",
            newtons=newtons,
            samples=samples,
            uncertainty=error / GRAVITY,
            method="measure_weight",
        )
        return kg

    def _held_for(self, p: Sighting, target: Target, method: str) -> None:
        """Refuse a reading that needs `p` in the gripper when it is not there, saying what to call; the
        robot a program made picks it up instead."""
        if self.core.arranging and (self.core.held is None or not self.core.held.same_object(p)):
            self.core.note("picked it up first")
            self.acting.pick_up(p)
            return
        self.core.check(method, p)

    def measure_fullness(self, patch: Sighting) -> float:
        """The session's side of `Robot.measure_fullness` (its docstring is the one programs read)."""
        self.core.need("measure_fullness")
        p, target = self.core.object_of_call(patch, "measure_fullness")
        # what a person knows of containers (`attribot.priors`): what one weighs empty and holds, coarsely
        table = self.core.safeguards.priors
        kind = table.find(p.label or "")
        if kind is None or kind.empty_kg is None or kind.holds_kg is None:
            known = ", ".join(k.name for k in table.kinds.values() if k.container)
            raise ApiArgumentError(
                f"robot.measure_fullness() knows how much an empty {known} weighs, and not a "
                f"{p.label or 'patch without a name'}",
                "weigh it with robot.measure_weight(patch) and compare it with others of its kind",
            )
        self._held_for(p, target, "measure_fullness")
        newtons, error, samples = self._weigh(p)
        lo, hi = kind.empty_kg
        empty_sd = (hi - lo) / math.sqrt(12.0)  # the empty mass of one such container, uniform in its range
        low, high = kind.holds_kg
        capacity = (low + high) / 2.0
        fill = (newtons / GRAVITY - (lo + hi) / 2.0) / capacity
        # what is not known of this one container: its own empty mass, and how much it holds
        spread = math.hypot(error / GRAVITY, empty_sd, fill * (high - low) / math.sqrt(12.0)) / capacity
        value = min(max(fill, 0.0), 1.0)
        self.core.record(
            p,
            kind="fullness",
            value=value,
            unit=FULL,
            newtons=newtons,
            samples=samples,
            uncertainty=spread,
            method="measure_fullness",
        )
        return value

    def _sense(self, sensor: Sensor, sense: Sense, patch: Sighting) -> float:
        """A reading of a registered sensor through its method: checks the sensor, the object and what the
        reading needs, then reads (several readings with `remeasure`) and records the measurement."""
        method = sense.method
        self.core.need(method)
        p, target = self.core.object_of_call(patch, method)
        assert self.core.world is not None  # _target checked it
        arrange = self.core.arranging
        if (
            sense.needs is Need.AIM
            and (self.core.aimed is None or not self.core.aimed.same_object(p))
            and arrange
        ):
            self.core.focus(p, target)
        elif (
            sense.needs is Need.REACH
            and (self.core.near is None or not self.core.near.same_object(p))
            and arrange
        ):
            self.acting.go_to_object(p)
        if sense.needs in (Need.AIM, Need.REACH):
            self.core.check(method, p, sense.needs.value)
        if sense.needs is Need.GRASP:
            self._held_for(p, target, method)
        value, spread, count = self._read_sensor(sensor, sense, p)
        self.core.record(
            p,
            kind=sense.quantity,
            value=value,
            unit=sense.unit,
            samples=count,
            uncertainty=spread,
            method=method,
        )
        return value

    def _read_sensor(self, sensor: Sensor, sense: Sense, p: Sighting) -> tuple[float, float, int]:
        """The sensor's reading of `p`: (value, one standard deviation, readings used). With `remeasure`,
        `sense.readings` readings are combined (the ones that read nothing left out)."""
        assert self.core.world is not None
        guards = self.core.safeguards
        count = guards.remeasure.readings(sense.readings)
        call = f"{sense.method}({p.label or 'patch'})"
        readings = []
        for i in range(count):
            value = float(self.core.world.read_sensor(sensor.name))
            if math.isfinite(value):
                readings.append(value)
            if count > 1 and i + 1 < count and sense.needs is not Need.GRASP:
                self.core.world.step(0.02)
        if count > 1:
            empty = count - len(readings)
            guards.remeasure.note(
                call, "caught" if empty else "confirmed", f"{count} readings, {empty} empty"
            )
        if not readings:
            raise ActionFailed(
                f"the {sensor.name} sensor read nothing from {p.label or 'the object'}",
                "check what the reading needs (" + str(sense.needs) + "), or compare the objects another way",
            )
        mean = sum(readings) / len(readings)
        spread = _std(readings) / math.sqrt(len(readings)) if len(readings) > 1 else 0.0
        return mean, max(spread, sense.resolution, sense.relative * abs(mean)), len(readings)

    def _weigh(self, p: Sighting) -> tuple[float, float, int]:
        """The held load in newtons, its standard error and the readings used. A short window is averaged
        (the reading sways while the arm settles and carries sensor noise); with `remeasure`, readings are
        added until the standard error is small or FORCE_MAX_SAMPLES are taken; with `verify_actions`, a
        load too small to be an object means it slipped out: it is picked up again and weighed again."""
        assert self.core.world is not None
        guards = self.core.safeguards
        call = f"measure_weight({p.label or 'patch'})"
        for attempt in range(2):
            readings = []
            while True:
                for _ in range(self.FORCE_SAMPLES):
                    self.core.world.step(self.FORCE_SAMPLE_S)
                    # signed: a held load pulls down (world -z); folding each noisy reading about zero
                    # would bias a light object upward by as much as the noise
                    readings.append(-float(self.core.world.read_force()[2]))
                mean = sum(readings) / len(readings)
                error = _std(readings) / math.sqrt(len(readings))
                small = error <= max(self.FORCE_RESOLUTION_N, 0.01 * mean)
                if not guards.remeasure.more(len(readings), small, self.FORCE_MAX_SAMPLES):
                    break
            if len(readings) > self.FORCE_SAMPLES:
                guards.remeasure.note(call, "caught", f"{len(readings)} force readings for {mean:.3f} N")
            if not guards.verify_actions.slipped(mean, self.core.gripper_empty(), attempt, call):
                # a weight is never negative: a mean below zero is zero within its error
                return max(mean, 0.0), max(error, self.FORCE_RESOLUTION_N), len(readings)
            self.acting.put_down()
            self.acting.go_to_object(p)
            self.acting.pick_up(p)
        raise AssertionError("unreachable")

    def uncertainty(self, patch: Sighting) -> float:
        """The session's side of `Robot.uncertainty` (its docstring is the one programs read)."""
        p = check_patch(patch, self.core.patch_type, "patch", "uncertainty")
        m = self.last_measurement(p)
        if m is None:
            raise PreconditionError(
                f"robot.uncertainty() has no measurement of {p.label or 'this patch'} yet",
                "call robot.measure_distance(patch) or robot.measure_weight(patch) first",
            )
        return m.uncertainty


def _std(values: Sequence[float]) -> float:
    if len(values) < 2:
        return 0.0
    mean = sum(values) / len(values)
    return math.sqrt(sum((v - mean) ** 2 for v in values) / (len(values) - 1))

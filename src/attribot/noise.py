"""Named noise presets for every part of the pipeline, and the world's own imperfections.

A preset names one level of imperfection for each part a query goes through:

- perception (the oracle detector and VQA, `attribot.models.noise`): per-frame misses, false positives,
  confusions and box jitter; errors that persist with the viewpoint (an object missed from a range of
  viewpoints, a pair of objects confused again and again from there);
- sensing (the world, `WorldNoise`): rangefinder noise that grows with range, dropouts, a maximum range and
  a beam that hits whatever lies on its true line (an edge, the wall behind a thin object); wrist force
  noise, a bias and a slow drift since the last tare; infrared thermometer noise, a bias and a field of view
  that takes in what lies around the object; the gripper's force and closure noise when it squeezes;
- acting (the world, `WorldNoise`): grasps that fail or slip while lifting, odometry that drifts with the
  distance travelled.

`realistic` covers all three; `frame` is the per-frame perception noise alone that earlier releases called
`realistic` (kept so that their runs stay comparable); `perception`, `sensing` and `acting` are the parts
of `realistic` on their own. Every draw is seeded: the same scene, seed and preset give the same errors on
every rerun.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from attribot.errors import ConfigError
from attribot.text import comma_names, one_of, plain_value

__all__ = ["WorldNoise", "PerceptionNoise", "NOISE_PRESETS", "preset", "world_noise"]


class WorldNoise(BaseModel):
    """Seeded imperfections of a world's sensors and actions (all zero: a perfect robot).

    range_std: rangefinder noise, metres of standard deviation per metre of range; range_dropout: the
    chance that a reading returns nothing; range_max: metres beyond which nothing is read (None: the
    sensor's own); beam_deg: standard deviation of the beam's pointing error, degrees (it then reads what
    it really hits); force_std: newtons of noise per force reading; force_bias: newtons, the standard
    deviation of an offset drawn once per world (a tare removes it); force_drift: newtons per second, the
    standard deviation of the drift rate since the last tare; temp_std: degrees Celsius of noise per
    thermometer reading; temp_bias: degrees, the standard deviation of an offset drawn once per world (its
    calibration); temp_spot_deg: the half-angle of the thermometer's field of view, degrees (0: a point; it
    then averages what the spot covers, the background round a small object too); grip_std: newtons of
    noise per gripper force reading; closure_std: metres of noise per gripper closure reading; grasp_fail:
    the chance that a grasp closes on nothing; slip: the chance that a grasped object slips out as the lift
    starts; odom_drift: metres of odometry error (standard deviation) per metre travelled; seed: the draws'
    seed.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    range_std: float = Field(0.0, ge=0.0, le=1.0, allow_inf_nan=False)
    range_dropout: float = Field(0.0, ge=0.0, le=1.0, allow_inf_nan=False)
    range_max: float | None = Field(None, gt=0.0, le=100.0, allow_inf_nan=False)
    beam_deg: float = Field(0.0, ge=0.0, le=10.0, allow_inf_nan=False)
    force_std: float = Field(0.0, ge=0.0, le=100.0, allow_inf_nan=False)
    force_bias: float = Field(0.0, ge=0.0, le=100.0, allow_inf_nan=False)
    force_drift: float = Field(0.0, ge=0.0, le=10.0, allow_inf_nan=False)
    temp_std: float = Field(0.0, ge=0.0, le=50.0, allow_inf_nan=False)
    temp_bias: float = Field(0.0, ge=0.0, le=50.0, allow_inf_nan=False)
    temp_spot_deg: float = Field(0.0, ge=0.0, le=30.0, allow_inf_nan=False)
    grip_std: float = Field(0.0, ge=0.0, le=10.0, allow_inf_nan=False)
    closure_std: float = Field(0.0, ge=0.0, le=0.01, allow_inf_nan=False)
    grasp_fail: float = Field(0.0, ge=0.0, le=1.0, allow_inf_nan=False)
    slip: float = Field(0.0, ge=0.0, le=1.0, allow_inf_nan=False)
    odom_drift: float = Field(0.0, ge=0.0, le=1.0, allow_inf_nan=False)
    seed: int = Field(0, ge=0, le=2**32 - 1)

    @field_validator("*", mode="before")
    @classmethod
    def _no_bool(cls, value: Any) -> Any:
        return plain_value(value, number=True)  # every field is a number: `slip = true` is not 1.0

    @property
    def clean(self) -> bool:
        return all(not v for k, v in self.model_dump().items() if k != "seed")


_PERCEPTION_FRAME = {"miss": 0.1, "false_pos": 0.05, "jitter_px": 4.0, "confuse": 0.05, "wrong": 0.1}
# about what an open-vocabulary detector gets wrong on household scenes: per frame, and from a viewpoint
_PERCEPTION = {
    "miss": 0.05,
    "false_pos": 0.05,
    "jitter_rel": 0.04,
    "confuse": 0.03,
    "miss_view": 0.05,
    "confuse_view": 0.03,
    "wrong": 0.1,
}
# a hobby-grade ToF ranger and load cell, a gripper without tactile sensing, wheel odometry; an infrared
# thermometer of the MLX90614 kind (0.5 degC accuracy, a 2-degree field of view), a gripper servo's
# current and encoder
_SENSING = {
    "range_std": 0.01,
    "range_dropout": 0.1,
    "range_max": 4.0,
    "beam_deg": 0.4,
    "force_std": 0.3,
    "force_bias": 1.0,
    "force_drift": 0.005,
    "temp_std": 0.3,
    "temp_bias": 0.5,
    "temp_spot_deg": 1.0,
    "grip_std": 0.05,
    "closure_std": 0.00005,
}
_ACTING = {"grasp_fail": 0.1, "slip": 0.05, "odom_drift": 0.01}

NOISE_PRESETS: dict[str, dict[str, float]] = {
    "clean": {},
    "frame": _PERCEPTION_FRAME,
    "perception": _PERCEPTION,
    "sensing": _SENSING,
    "acting": _ACTING,
    "realistic": {**_PERCEPTION, **_SENSING, **_ACTING},
}
"""Named levels (`--noise NAME`, `oracle?noise=NAME`); each part takes the options that are its own."""


class PerceptionNoise(BaseModel):
    """A preset's perception noise on the oracle backends (`Settings.perception_noise`), drawn from `seed`:
    what an evaluation condition puts on them for one item, typed rather than written into the backends'
    spec strings. Options a spec gives (`oracle?miss=0.2`) win over the preset's."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    preset: str
    seed: int = Field(0, ge=0, le=2**32 - 1, strict=True)

    @field_validator("preset")
    @classmethod
    def _known_preset(cls, value: str) -> str:
        return one_of(value, NOISE_PRESETS, "noise preset")

    def options(self, known: Iterable[str]) -> dict[str, float | int]:
        """The preset's options among `known` (a backend's noise fields), with the seed."""
        return {**preset(self.preset, among=known), "seed": self.seed}


def preset(name: str, among: Iterable[str] | None = None) -> dict[str, float]:
    """The options of preset `name` (those named in `among` only: a part's own fields); an unknown name raises
    a `ConfigError` listing the presets."""
    if name not in NOISE_PRESETS:
        raise ConfigError(f"unknown noise preset {name!r}", f"choose one of: {', '.join(NOISE_PRESETS)}")
    own = None if among is None else set(among)
    return {k: v for k, v in NOISE_PRESETS[name].items() if own is None or k in own}


def world_noise(spec: str | dict[str, Any] | None, seed: int = 0) -> WorldNoise:
    """`WorldNoise` from a preset name, `KEY=VALUE,...` pairs (a preset may come first: `realistic,slip=0.3`)
    or a dict; the seed is `seed` unless the pairs give one."""
    values: dict[str, Any] = {"seed": seed}
    if isinstance(spec, dict):
        values.update(spec)
    elif spec:
        for part in comma_names(spec):
            if "=" not in part:
                values.update(preset(part, among=WorldNoise.model_fields))
                continue
            key, _, raw = part.partition("=")
            values[key.strip()] = raw.strip()
    try:
        return WorldNoise(**values)
    except ValidationError as exc:
        first = exc.errors()[0]
        name = ".".join(str(p) for p in first.get("loc", ())) or "noise"
        raise ConfigError(
            f"world noise {name}={first.get('input')!r} is not valid: {first.get('msg', 'invalid')}",
            f"give a preset ({', '.join(NOISE_PRESETS)}) or KEY=VALUE pairs of: "
            f"{', '.join(WorldNoise.model_fields)}",
        ) from None

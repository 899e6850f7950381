"""The simulated robot's senses beyond the rangefinder and the wrist force sensor: an infrared thermometer on
the head and a gripper that feels how hard it squeezes. Both read the physics of the scene, never the
catalog.

- The thermometer looks along the camera's optical axis, as the rangefinder does, and reads the surface
  temperature of what its beam really hits (an object's, or the room's where it hits a wall, furniture or
  nothing). With noise, its aim carries the rangefinder's pointing error, its field of view takes in a spot
  around the axis (the background round a small, far object too), and each reading carries noise and a
  calibration offset drawn once per world.
- The squeeze closes the fingers on the held object in steps, on MuJoCo's soft contacts: each object's body
  parts carry contact parameters (`solref`, `solimp`) from its stiffness, and the finger pads touch them
  only while squeezing (the fingers pass through things otherwise). What it reads is what a gripper servo
  reports, its effort (the force) and its position (the closure); the answer is the least-squares slope of
  force against closure, in newtons per millimetre.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import mujoco
import numpy as np

if TYPE_CHECKING:
    from attribot.sim.world import SimWorld

__all__ = [
    "SQUEEZE_IMPEDANCE",
    "squeeze_solref",
    "set_softness",
    "read_temperature",
    "squeeze",
    "SQUEEZE_BIT",
]

SQUEEZE_IMPEDANCE = 0.95
"""The contacts' impedance while squeezing (constant over the penetration: force grows linearly with it)."""
SQUEEZE_BIT = 4
"""The collision bit pads and the held object's body parts share while squeezing (1: the world, 2: the
robot's base)."""
_SQUEEZE_STEPS_M = (0.002, 0.004, 0.006, 0.008, 0.010, 0.013, 0.016)
"""How far past where each finger first touched the squeeze sets its target, step by step."""
_SQUEEZE_DT = 0.001  # a finer time step while squeezing: stiff contacts on light fingers stay stable
_SETTLE_S = 0.12  # per squeezing step
_TOUCH_N = 0.3  # a finger at rest pushing less than this touches nothing yet
_CLOSING_STEP_M = 0.001  # how far a finger closes per step until it touches
_CLOSING_S = 0.05  # long enough for a finger's servo to come to rest, so that its effort is a push


def squeeze_solref(n_per_mm: float, inverse_inertia: float) -> list[float]:
    """MuJoCo's direct contact parameters (-stiffness, -damping) for an object that gives `n_per_mm` newtons
    per millimetre of gripper closure. At rest a soft contact with constant impedance d pushes back
    k / ((1-d) * A) for a unit penetration, A being the inverse inertia MuJoCo weighs it with (the finger's
    body and the object's, `body_invweight0`); two contacts in series, one per finger, close the gripper by
    twice the penetration."""
    k = 2.0 * n_per_mm * 1000.0 * (1.0 - SQUEEZE_IMPEDANCE) * inverse_inertia
    return [-k, -2.0 * math.sqrt(k)]


def set_softness(world: SimWorld) -> None:
    """Give each object's body parts the contact parameters of its stiffness (built once, after the model is
    compiled: the inverse inertias are the compiled model's)."""
    model = world.model
    finger = float(model.body_invweight0[model.geom_bodyid[world.pads[0]]][0])
    for key, placed in world.objects.items():
        inverse = finger + float(model.body_invweight0[world.body_of[key]][0])
        parts = world.geoms_of[key]
        model.geom_solref[parts] = squeeze_solref(placed.stiffness_n_per_mm, inverse)
        model.geom_solimp[parts] = [SQUEEZE_IMPEDANCE, SQUEEZE_IMPEDANCE, 0.001, 0.5, 2.0]


def read_temperature(world: SimWorld) -> float:
    """One reading of the infrared thermometer, degrees Celsius (see the module docstring)."""
    model, data, noise, rng = world.model, world.data, world.noise, world.sense_rng
    mujoco.mj_forward(model, data)
    site = world.range_site
    origin = data.site_xpos[site].copy()
    frame = data.site_xmat[site].reshape(3, 3)
    aim = rng.normal(0.0, math.radians(noise.beam_deg), 2) if noise.beam_deg else np.zeros(2)
    offsets = [(0.0, 0.0)]
    if noise.temp_spot_deg:
        spot = math.radians(noise.temp_spot_deg)
        offsets += [
            (spot * math.cos(a), spot * math.sin(a)) for a in np.linspace(0, math.tau, 8, endpoint=False)
        ]
    body = int(model.site_bodyid[site])
    seen = []
    for ox, oy in offsets:
        direction = frame @ np.array([math.tan(aim[0] + ox), math.tan(aim[1] + oy), 1.0])
        geom = np.zeros(1, np.int32)
        hit = mujoco.mj_ray(
            model, data, origin, direction / np.linalg.norm(direction), world.ray_groups, 1, body, geom
        )
        key = int(world.geom_key[geom[0]]) if hit >= 0 and geom[0] >= 0 else -1
        seen.append(world.objects[key].temperature_c if key >= 0 else world.plan.room_temperature_c)
    celsius = float(np.mean(seen)) + world.temp_bias
    if noise.temp_std:
        celsius += float(rng.normal(0.0, noise.temp_std))
    return celsius


def squeeze(world: SimWorld) -> float:
    """Squeeze the held object and return its stiffness in newtons per millimetre of closure; NaN when
    nothing is held or the fingers never pressed on it."""
    key = world.held
    if key is None:
        return math.nan
    model = world.model
    # the pads press on its main part alone (the largest): a handle or a stem beside it would add contacts
    # in parallel, and the object would seem stiffer than it is
    parts = np.array([max(world.geoms_of[key], key=lambda g: _volume(model, g))])
    pads = world.pads
    # the broad phase filters bodies by the union of their geoms' bits: both levels change, and change back
    fingers, held = model.geom_bodyid[pads], world.body_of[key]
    saved = (
        model.opt.timestep,
        model.geom_contype[pads].copy(),
        model.geom_conaffinity[parts].copy(),
        model.body_contype[fingers].copy(),
        int(model.body_conaffinity[held]),
    )
    start = {name: world.finger_target(name) for name in _FINGERS}
    model.geom_contype[pads] = SQUEEZE_BIT
    model.geom_conaffinity[parts] = saved[2] | SQUEEZE_BIT
    model.body_contype[fingers] = saved[3] | SQUEEZE_BIT
    model.body_conaffinity[held] = saved[4] | SQUEEZE_BIT
    model.opt.timestep = _SQUEEZE_DT
    forces, gaps = [], []
    try:
        touch = _close_until_touching(world)
        for step in _SQUEEZE_STEPS_M:
            for name, at in touch.items():
                world.set_finger(name, at - step)
            world.step(_SETTLE_S)
            force, gap = _grip_reading(world)
            forces.append(force)
            gaps.append(gap)
    finally:
        for name, at in start.items():
            world.set_finger(name, at)
        world.step(_SETTLE_S)
        model.opt.timestep = saved[0]
        model.geom_contype[pads] = saved[1]
        model.geom_conaffinity[parts] = saved[2]
        model.body_contype[fingers] = saved[3]
        model.body_conaffinity[held] = saved[4]
    if max(forces, default=0.0) < _TOUCH_N:
        return math.nan
    slope = np.polyfit(np.asarray(gaps), np.asarray(forces), 1)[0]  # newtons per metre of opening
    return float(-slope / 1000.0)


_FINGERS = ("finger_l", "finger_r")


def _volume(model: mujoco.MjModel, geom: int) -> float:
    """A geom's volume from its type and size (a thin band round a ball has a large bounding sphere and
    little volume: the ball is its main part)."""
    a, b, c = (float(v) for v in model.geom_size[geom])
    kind = model.geom_type[geom]
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return 4.0 / 3.0 * math.pi * a**3
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return math.pi * a**2 * (2 * b + 4.0 / 3.0 * a)
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return math.pi * a**2 * 2 * b
    if kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        return 4.0 / 3.0 * math.pi * a * b * c
    return 8.0 * a * b * c


def _close_until_touching(world: SimWorld) -> dict[str, float]:
    """Close each finger on its own until it presses on the object (as a gripper servo closing at low
    effort does): where each stands then, so that the squeeze starts with both fingers on it."""
    touching: dict[str, float] = {}
    for _ in range(int(0.05 / _CLOSING_STEP_M)):
        for name in _FINGERS:
            if name not in touching:
                world.set_finger(name, world.finger_target(name) - _CLOSING_STEP_M)
        world.step(_CLOSING_S)
        for name in _FINGERS:
            if name not in touching and -world.finger_state(name)[0] >= _TOUCH_N:
                touching[name] = world.finger_target(name)
        if len(touching) == len(_FINGERS):
            break
    return {name: touching.get(name, world.finger_target(name)) for name in _FINGERS}


def _grip_reading(world: SimWorld) -> tuple[float, float]:
    """What the gripper servos report: the mean force with which the fingers press inward (their effort) and
    the gap between them (their positions), with the configured noise."""
    noise, rng = world.noise, world.sense_rng
    force, gap = 0.0, 0.0
    for name in _FINGERS:
        effort, position = world.finger_state(name)
        force += -effort / 2.0  # the servo pushes inward (negative along its opening axis)
        gap += position
    if noise.grip_std:
        force += float(rng.normal(0.0, noise.grip_std))
    if noise.closure_std:
        gap += float(rng.normal(0.0, noise.closure_std))
    return force, gap

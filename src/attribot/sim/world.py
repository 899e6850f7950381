"""The simulated world: one scene, its physics, the robot's actuators and sensors, and ground truth.

`SimWorld` holds the compiled model and its data. Motion goes through actuators (base velocities, head,
lift, arm and finger position targets) and time advances only in `step`. Sensors read the simulation:
the rangefinder casts along the camera's optical axis, the wrist force/torque sensor reports the force
that the arm transmits to the gripper, so a held object's weight reaches it through the grasp weld and
the physics, never from the catalog. Ground truth (object ids, categories, masses, boxes) is available
separately for perception oracles, scoring and scene info.

The config's `noise` (`attribot.noise.WorldNoise`) makes sensing and acting imperfect, with draws from a
generator seeded by the noise seed and the scene seed (a rerun is identical): the rangefinder's noise grows
with range, it drops readings and reads nothing past its maximum, and its beam, off the optical axis by a
small pointing error, reads whatever it really hits; the force sensor carries a bias and drifts from its
last tare; a grasp can close on nothing, or slip as the lift starts and leave the object behind; odometry
(`odometry()`, what a controller reads) drifts in proportion to the distance travelled, while
`base_pose()` stays the truth.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
from pydantic import BaseModel

from attribot.config import SceneConfig
from attribot.errors import InputError
from attribot.frame import CameraInfo, Frame, ObjectTruth
from attribot.sim import senses
from attribot.sim.bodies import body_named
from attribot.sim.looks import BODY_GROUP, LOOK_GROUP
from attribot.sim.render import SceneRenderer
from attribot.sim.scene import (
    ROOM_CAMERA,
    ScenePlan,
    SceneRequest,
    build_model,
    plan_scene,
    resolve_categories,
    scene_requests,
    what_fits,
)

__all__ = ["SimWorld", "SceneInfo", "ObjectInfo", "RobotInfo", "MIN_VISIBLE_PIXELS", "box_from_mask"]

_ATTEMPTS = 30
# what rays hit (rangefinder, view checks, tops): the room, furniture, robot and objects' body parts, drawn
# (group 0) or under their looks (BODY_GROUP); never the looks (LOOK_GROUP), so that sensing is the same
# whatever objects look like
_RAY_GROUPS = np.array([int(g in (0, 1, BODY_GROUP)) for g in range(6)], np.uint8)
assert _RAY_GROUPS[LOOK_GROUP] == 0
MIN_VISIBLE_PIXELS = 20  # fewer visible pixels than this and an object counts as not in view
GRAVITY = 9.81


class ObjectInfo(BaseModel):
    """Truth about one object, as `attribot scene info` prints it (metres, kilograms, pixels)."""

    id: str
    key: int
    category: str
    color: str
    mass_kg: float
    position: list[float]
    box: list[float] | None
    visible_pixels: int
    pickable: bool
    size_m: float
    variant: str = ""
    deceptive: bool = False
    distance_m: float
    surface: str = ""
    row: int | None = None
    col: int | None = None
    odd_one_out: bool | None = None
    odd_kind: str | None = None
    weight_rank: int | None = None
    # what no camera sees (`attribot.sim.catalog`): the world's own state, which the new senses read
    temperature_c: float | None = None  # its surface temperature
    thermal: str = ""  # the word for its temperature (`attribot.lexicon.temperature_state`)
    stiffness_n_per_mm: float | None = None  # force per millimetre of gripper closure
    softness: str = ""  # soft, firm, hard, rigid
    fill: float | None = None  # a container's contents as a share of its capacity (None: no container)
    contents_kg: float | None = None  # the mass of those contents


class RobotInfo(BaseModel):
    base: list[float]  # x, y, yaw
    camera_position: list[float]
    head: list[float]  # pan, tilt


class SceneInfo(BaseModel):
    """What `attribot scene info` prints: the scene's truth in the world frame and the camera's pixels."""

    layout: str
    seed: int
    image_size: list[int]
    objects: list[ObjectInfo]
    robot: RobotInfo
    furniture: list[str]
    room_temperature_c: float | None = None


def box_from_mask(mask: np.ndarray) -> tuple[float, float, float, float] | None:
    """xyxy pixel box (x1, y1 exclusive) around the True pixels of a mask, or None when empty."""
    ys, xs = np.nonzero(mask)
    if xs.size == 0:
        return None
    return float(xs.min()), float(ys.min()), float(xs.max() + 1), float(ys.max() + 1)


def _name2id(model: mujoco.MjModel, kind: mujoco.mjtObj, name: str) -> int:
    i = mujoco.mj_name2id(model, kind, name)
    if i < 0:
        raise RuntimeError(f"the model has no {kind.name} {name!r}")
    return i


def _scene_request(config: SceneConfig) -> SceneRequest:
    """What `config` asks of the scene's layout."""
    vocabulary = config.vocabulary
    return SceneRequest(
        config.objects,
        resolve_categories(config.categories),
        dict(config.options),
        config.robot,
        None if vocabulary is None else frozenset(c.name for c in resolve_categories(vocabulary) or ()),
    )


class SimWorld:
    """One seeded scene with the robot in it. See the module docstring; close it to free the renderer."""

    def __init__(self, config: SceneConfig | None = None, *, settle_s: float = 0.6, **fields: Any) -> None:
        """The scene of `config`, or of a `SceneConfig` built from `fields` (layout=..., seed=..., ...)."""
        if config is None:
            config = SceneConfig.create(**fields)
        elif fields:
            raise TypeError("give a SceneConfig or its fields, not both")
        self.config = config
        self.robot = config.robot
        self.body = body_named(config.robot)
        self._joints = self.body.joints
        self.finger_open = self.body.finger_open
        request = _scene_request(config)
        self.width, self.height, self.profile = config.width, config.height, config.profile
        self.force_noise_std = config.force_noise_std
        self.noise = config.noise
        self._seed_generators(config)
        self._renderer: SceneRenderer | None = None
        self._build_scene(request)
        self.step_hooks: list[Callable[[float], None]] = []  # called with the sim time after every step
        self._slip_at: float | None = None  # when a held object that will slip falls out
        self._draw_lasting_errors()
        self.step(settle_s)
        self._tare = np.zeros(3)
        self._held: int | None = None
        self.pick_record: Any = None  # where the last pick happened, for putting the object back

    def _seed_generators(self, config: SceneConfig) -> None:
        """The generators of the world's draws, seeded by the scene seed (and the noise seed), and the
        thermometer's bias."""
        seed = config.seed
        self._rng = np.random.default_rng([int(seed), 1])
        self._noise_rng = np.random.default_rng([int(config.noise.seed), int(seed), 7])
        # the thermometer's and the gripper's draws come from a generator of their own, so that reading them
        # leaves every other draw (rangefinder, force sensor, grasps, odometry) where it was
        self.sense_rng = np.random.default_rng([int(config.noise.seed), int(seed), 11])
        self.temp_bias = (
            float(self.sense_rng.normal(0.0, config.noise.temp_bias)) if config.noise.temp_bias else 0.0
        )

    def _build_scene(self, request: SceneRequest) -> None:
        """Plan the scene, build its model and put the robot at its start."""
        layout, seed = self.config.layout, self.config.seed
        # a plan whose candidates the first view cannot all see is redrawn (same seed, next attempt)
        error: InputError | None = None
        for attempt, asked in scene_requests(layout, request, _ATTEMPTS):
            try:
                self.plan: ScenePlan = plan_scene(layout, seed, asked, attempt)
            except InputError as exc:
                if self._fixed(layout):
                    raise
                error = exc
                continue
            self.plan.width, self.plan.height = self.width, self.height
            self.model = build_model(self.plan, looks=self.config.looks)
            self.data = mujoco.MjData(self.model)
            self._index()
            self._start()
            if self._fixed(layout) or all(self._in_view(k) for k in self.objects):
                return
            error = InputError(
                f"no {layout} scene for seed {seed} shows all {len(self.objects)} objects to the camera",
                "ask for fewer objects or another seed",
            )
        assert error is not None
        raise InputError(error.message, what_fits(layout, seed, request, _ATTEMPTS)) from error

    def _draw_lasting_errors(self) -> None:
        """The odometry's and the force sensor's errors that last the whole run; odometry starts true."""
        n = self.noise
        # odometry: a wheel scale error and a heading bias, drawn once, so drift grows with distance
        self._odom_scale = 1.0 + float(self._noise_rng.normal(0.0, n.odom_drift))
        self._odom_bias = float(self._noise_rng.normal(0.0, n.odom_drift))
        self._odom = np.array(self.base_pose(), float)
        self._odom_last = self._odom.copy()
        self._force_bias = self._noise_rng.normal(0.0, n.force_bias, 3) if n.force_bias else np.zeros(3)
        self._drift_rate = np.zeros(3)
        self._tare_time = 0.0

    # --- set-up -----------------------------------------------------------------------------------
    @staticmethod
    def _fixed(layout: str) -> bool:
        """Layouts whose plan is exact (no rejection): arrangement and triplet."""
        from attribot.sim.scene import LAYOUTS

        return LAYOUTS.get(layout) is not LAYOUTS.get("household")

    def _in_view(self, key: int, margin: float = 0.04) -> bool:
        """True when rays from the optical centre reach the object first and its centre is in the image."""
        cam, rot = self.camera_pose()
        info = self.camera_info()
        lo, hi = self.object_bounds(key)
        centre = (lo + hi) / 2
        top = np.array([centre[0], centre[1], hi[2] - 0.01 * (hi[2] - lo[2])])
        p = rot.T @ (centre - cam)  # camera frame: x right, y up, z backward
        if p[2] >= -0.05:
            return False
        u = info.cx + info.fx * p[0] / -p[2]
        v = info.cy - info.fy * p[1] / -p[2]
        if not (
            margin * info.width <= u <= (1 - margin) * info.width
            and margin * info.height <= v <= (1 - margin) * info.height
        ):
            return False
        groups = _RAY_GROUPS
        head = int(self.model.cam_bodyid[self.camera_id])  # the camera's own housing is not in the way
        seen = 0
        for target in (centre, top):
            vec = target - cam
            geom = np.array([-1], np.int32)
            mujoco.mj_ray(self.model, self.data, cam, vec / np.linalg.norm(vec), groups, 1, head, geom)
            seen += int(geom[0] >= 0 and self.geom_key[geom[0]] == key)
        return seen >= 1

    def _index(self) -> None:
        m = self.model
        J = mujoco.mjtObj.mjOBJ_JOINT
        A = mujoco.mjtObj.mjOBJ_ACTUATOR
        self._qadr = {n: int(m.jnt_qposadr[_name2id(m, J, n)]) for n in self._joints}
        self._dadr = {n: int(m.jnt_dofadr[_name2id(m, J, n)]) for n in self._qadr}
        self._act = {n: _name2id(m, A, n) for n in self._joints}
        self.camera_id = _name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, self.body.camera)
        self._range_adr = int(m.sensor_adr[_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, "rangefinder")])
        self._force_adr = int(m.sensor_adr[_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, "wrist_force")])
        self._ft_site = _name2id(m, mujoco.mjtObj.mjOBJ_SITE, "ft_site")
        self._probe = _name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "grip_probe")
        self._pads = [_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, f"{n}_pad") for n in ("finger_l", "finger_r")]
        self.pads = np.array(self._pads)
        # when the pads squeeze an object, its contact parameters alone say how it gives (`sim.senses`)
        m.geom_solmix[self.pads] = 0.0
        m.geom_solimp[self.pads] = [senses.SQUEEZE_IMPEDANCE, senses.SQUEEZE_IMPEDANCE, 0.001, 0.5, 2.0]
        self.range_site = _name2id(m, mujoco.mjtObj.mjOBJ_SITE, "range_site")
        self.ray_groups = _RAY_GROUPS
        self.wrist_body = _name2id(m, mujoco.mjtObj.mjOBJ_BODY, "wrist")
        # objects: key -> body id, geoms; geom id -> object key (-1 for everything else)
        self.objects = {o.key: o for o in self.plan.objects}
        self.body_of: dict[int, int] = {}
        self.geoms_of: dict[int, list[int]] = {}
        self.weld_of: dict[int, int] = {}
        self.geom_key = np.full(m.ngeom, -1, np.int32)
        for o in self.plan.objects:
            b = _name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"obj:{o.id}")
            self.body_of[o.key] = b
            gs = [g for g in range(m.ngeom) if m.geom_bodyid[g] == b]
            # the body parts (drawn or not), never the look drawn over them nor the collision box
            self.geoms_of[o.key] = [g for g in gs if m.geom_group[g] in (0, BODY_GROUP)]
            self.geom_key[gs] = o.key
            if o.category.pickable:
                self.weld_of[o.key] = _name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, f"grasp:{o.id}")
        self.key_of_id = {o.id: o.key for o in self.plan.objects}
        # furniture and the floor: geom id -> index into surface_names (-1 for everything else)
        self.surface_names = (*(f.name for f in self.plan.furniture), "floor")
        self.geom_surface = np.full(m.ngeom, -1, np.int16)
        for i, f in enumerate(self.plan.furniture):
            b = _name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"furniture:{f.name}")
            self.geom_surface[m.geom_bodyid == b] = i
        self.geom_surface[_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")] = len(self.plan.furniture)
        senses.set_softness(self)  # how each object gives when squeezed: contact parameters of its parts
        self.truth = {
            o.key: ObjectTruth(id=o.id, category=o.category.name, color=o.color, synonyms=o.category.synonyms)
            for o in self.plan.objects
        }

    def _start(self) -> None:
        d, q = self.data, self._qadr
        x, y, yaw = self.plan.robot
        self._targets = self.body.rest(self.plan.head, self.plan.arm, self.finger_open)
        for name, value in (("base_x", x), ("base_y", y), ("base_yaw", yaw), *self._targets.items()):
            d.qpos[q[name]] = value
        for name in ("base_x", "base_y", "base_yaw"):
            d.ctrl[self._act[name]] = 0.0
        for name, v in self._targets.items():
            d.ctrl[self._act[name]] = v
        self._base_cmd = (0.0, 0.0, 0.0)
        mujoco.mj_forward(self.model, d)

    # --- time and motion --------------------------------------------------------------------------
    def step(self, seconds: float) -> None:
        """Advance the simulation by `seconds`, holding the current commands."""
        if not seconds >= 0 or not math.isfinite(seconds):
            raise InputError(f"cannot step {seconds!r} seconds", "give a finite duration >= 0")
        n = int(round(seconds / self.model.opt.timestep))
        m, d = self.model, self.data
        if self._base_cmd == (0.0, 0.0, 0.0):
            self._set_base_ctrl()
            if n:
                mujoco.mj_step(m, d, nstep=n)
        else:
            # the base command is in the robot frame: re-express it in the world frame as the base turns
            chunk = 5
            while n > 0:
                self._set_base_ctrl()
                k = min(chunk, n)
                mujoco.mj_step(m, d, nstep=k)
                n -= k
        self._track_odometry()
        if self._slip_at is not None and d.time >= self._slip_at and self._held is not None:
            self._let_go()  # the grip gives: it falls out
            self._slip_at = None
            self.set_gripper(0.0)  # and the fingers, still closing, meet each other
        for hook in getattr(self, "step_hooks", ()):
            hook(float(d.time))

    def _track_odometry(self) -> None:
        """Add this step's motion to the odometry, through the wheels' scale error and heading bias (nothing
        to do without drift: odometry is then the truth)."""
        if not self.noise.odom_drift or not hasattr(self, "_odom"):
            return
        true = np.array(self.base_pose(), float)
        delta = true - self._odom_last
        delta[2] = math.remainder(delta[2], math.tau)
        self._odom_last = true
        if not delta.any():
            return
        # the displacement in the robot's frame, as the wheels measure it, turned into the odometry frame
        yaw_true = true[2] - delta[2] / 2
        c, s = math.cos(yaw_true), math.sin(yaw_true)
        fwd, left = c * delta[0] + s * delta[1], -s * delta[0] + c * delta[1]
        fwd, left = fwd * self._odom_scale, left * self._odom_scale
        turn = delta[2] * self._odom_scale + self._odom_bias * math.hypot(fwd, left)
        c, s = math.cos(self._odom[2] + turn / 2), math.sin(self._odom[2] + turn / 2)
        self._odom[0] += c * fwd - s * left
        self._odom[1] += s * fwd + c * left
        self._odom[2] = math.remainder(self._odom[2] + turn, math.tau)

    def robot_state(self) -> dict[str, Any]:
        """The robot's own state (joints, targets, odometry, tare), for `restore_robot`; no objects."""
        q = self._qadr
        return {
            "qpos": {n: float(self.data.qpos[a]) for n, a in q.items()},
            "targets": dict(self._targets),
            "odom": self._odom.copy(),
            "tare": (self._tare.copy(), self._tare_time, self._drift_rate.copy()),
        }

    def restore_robot(self, state: dict[str, Any]) -> None:
        """Put the robot back into `state` (from `robot_state`): where it stood, its head, arm and open
        gripper, and what its odometry believed. What it holds is let go first; objects stay put."""
        if self._held is not None:
            self.release()
        for name, value in state["qpos"].items():
            self.data.qpos[self._qadr[name]] = value
            self.data.qvel[self._dadr[name]] = 0.0
        for name, value in state["targets"].items():
            self._target(name, value)
        self._base_cmd = (0.0, 0.0, 0.0)
        self._set_base_ctrl()
        mujoco.mj_forward(self.model, self.data)
        self._odom = np.array(state["odom"], float)
        self._odom_last = np.array(self.base_pose(), float)
        tare, self._tare_time, drift = state["tare"]
        self._tare, self._drift_rate = np.array(tare), np.array(drift)
        self.step(0.3)

    def odometry(self) -> tuple[float, float, float]:
        """The base pose as the robot believes it (x, y, yaw): the truth plus the drift of its odometry."""
        if not self.noise.odom_drift:
            return self.base_pose()
        return float(self._odom[0]), float(self._odom[1]), float(self._odom[2])

    def _set_base_ctrl(self) -> None:
        vx, vy, wz = self._base_cmd
        yaw = self.data.qpos[self._qadr["base_yaw"]]
        c, s = math.cos(yaw), math.sin(yaw)
        self.data.ctrl[self._act["base_x"]] = c * vx - s * vy
        self.data.ctrl[self._act["base_y"]] = s * vx + c * vy
        self.data.ctrl[self._act["base_yaw"]] = wz

    def command_base(self, vx: float, vy: float, wz: float) -> None:
        """Base velocity in the robot frame (forward m/s, left m/s, ccw rad/s), held until changed."""
        vals = (float(vx), float(vy), float(wz))
        if not all(math.isfinite(v) for v in vals):
            raise InputError(f"base velocity {vals} is not finite", "give finite velocities")
        self._base_cmd = (
            float(np.clip(vx, -1.0, 1.0)),
            float(np.clip(vy, -1.0, 1.0)),
            float(np.clip(wz, -2.0, 2.0)),
        )
        self._set_base_ctrl()

    def _target(self, name: str, value: float) -> None:
        if not math.isfinite(value):
            raise InputError(f"{name} target {value!r} is not finite", "give a finite number")
        lo, hi = self.model.actuator_ctrlrange[self._act[name]]
        v = float(np.clip(value, lo, hi))
        self._targets[name] = v
        self.data.ctrl[self._act[name]] = v

    def set_head(self, pan: float, tilt: float) -> None:
        """Head targets (radians, clipped to the joint ranges): pan left positive, tilt up positive."""
        if not self.body.head:
            raise InputError(f"{self.body.called} has no camera head", "turn the base, or move the arm")
        self._target("head_pan", math.remainder(float(pan), math.tau))
        self._target("head_tilt", float(tilt))

    def set_arm(self, lift: float, extension: float) -> None:
        """Lift height of the carriage and arm extension targets, metres (clipped to the joint ranges); on
        the EP-like robot, the grip point's height and reach (as near as its two links reach)."""
        for name, value in self.body.arm(float(lift), float(extension)).items():
            self._target(name, value)

    def set_gripper(self, opening: float) -> None:
        """Each finger's distance from the centre line, metres (0 closed, 0.07 fully open)."""
        self._target("finger_l", float(opening))
        self._target("finger_r", float(opening))

    def set_finger(self, name: str, opening: float) -> None:
        """One finger's target ("finger_l" or "finger_r"), metres from the centre line."""
        self._target(name, float(opening))

    def finger_target(self, name: str) -> float:
        return float(self._targets[name])

    def finger_state(self, name: str) -> tuple[float, float]:
        """What a finger's servo reports: its effort (newtons along its opening axis) and its position."""
        return float(self.data.actuator_force[self._act[name]]), float(self.data.qpos[self._qadr[name]])

    # --- grasping ------------------------------------------------------------------------------------
    def _geom_distance(self, g1: int, g2: int, cap: float = 0.2) -> float:
        fromto = np.zeros(6)
        return float(mujoco.mj_geomDistance(self.model, self.data, g1, g2, cap, fromto))

    def _object_distance(self, geom: int, key: int, cap: float = 0.2) -> float:
        return min(self._geom_distance(geom, g, cap) for g in self.geoms_of[key])

    def grasp(self) -> bool:
        """Close the fingers on what lies between them; weld it to the wrist when both fingers touch it.

        Returns True when an object is now held. A pickable object counts only when the point between the
        fingertips is within 3 cm of it; the fingers stop where they meet its surface.
        """
        if self._held is not None:
            return True
        near = [(self._object_distance(self._probe, k), k) for k in self.weld_of]
        near = [(dist, k) for dist, k in near if dist < 0.03]
        if near and self.noise.grasp_fail and self._noise_rng.random() < self.noise.grasp_fail:
            near = []  # the fingers slide off: they close on nothing
        if not near:
            self.set_gripper(0.0)
            self.step(0.4)
            return False
        _, key = min(near)
        moving = {0: True, 1: True}
        names = ("finger_l", "finger_r")
        for _ in range(150):
            for i, name in enumerate(names):
                if not moving[i]:
                    continue
                if self._object_distance(self._pads[i], key) <= 0.001:
                    moving[i] = False
                    self._target(name, float(self.data.qpos[self._qadr[name]]))
                else:
                    self._target(name, max(self._targets[name] - 0.004, 0.0))
                    if self._targets[name] == 0.0 and self.data.qpos[self._qadr[name]] < 0.002:
                        moving[i] = False
            self.step(0.012)
            if not any(moving.values()):
                break
        gaps = [self._object_distance(p, key) for p in self._pads]
        # both fingers on it; or a thin object off the centre line: one finger on it, the other closed
        # past it, and the point between the fingertips at the object
        off_centre = min(gaps) < 0.006 and self._object_distance(self._probe, key) < 0.012
        if not (max(gaps) < 0.006 or off_centre):
            return False
        self._weld(key)
        if self.noise.slip and self._noise_rng.random() < self.noise.slip:
            # the grip is too weak: as the lift starts, the object stays behind on its support
            self._slip_at = float(self.data.time) + float(self._noise_rng.uniform(0.05, 0.25))
        self.step(0.3)
        return True

    def _weld(self, key: int) -> None:
        """Activate the weld between wrist and object at their current relative pose."""
        m, d = self.model, self.data
        eq = self.weld_of[key]
        b1, b2 = self.wrist_body, self.body_of[key]
        p1, p2 = d.xpos[b1], d.xpos[b2]
        r1 = d.xmat[b1].reshape(3, 3)
        q1, q2 = d.xquat[b1].copy(), d.xquat[b2].copy()
        rel_pos = r1.T @ (p2 - p1)
        q1inv = np.zeros(4)
        mujoco.mju_negQuat(q1inv, q1)
        rel_q = np.zeros(4)
        mujoco.mju_mulQuat(rel_q, q1inv, q2)
        m.eq_data[eq, 0:3] = 0.0  # anchor at the object's origin
        m.eq_data[eq, 3:6] = rel_pos
        m.eq_data[eq, 6:10] = rel_q
        m.eq_data[eq, 10] = 1.0
        d.eq_active[eq] = 1
        self._held = key

    def release(self) -> None:
        """Drop the weld and open the fingers."""
        if self._held is not None:
            self._let_go()
        self._slip_at = None
        self.set_gripper(self.finger_open)
        self.step(0.3)

    def _let_go(self) -> None:
        """Drop the weld of the held object and wake it. Held still in the gripper, it was ready to sleep;
        unwelded, it would fall asleep at once where it hangs instead of falling onto what is below."""
        assert self._held is not None
        m, d = self.model, self.data
        d.eq_active[self.weld_of[self._held]] = 0
        tree = int(m.body_treeid[self.body_of[self._held]])
        if d.tree_asleep[tree] < 0:
            d.tree_asleep[tree] = -(1 + mujoco.mjMINAWAKE)  # as awake as a tree gets: counting down anew
        else:
            dof = int(m.body_dofadr[self.body_of[self._held]])
            d.qvel[dof : dof + 6] = -0.0  # MuJoCo's documented wake signal (not 0.0 bytewise), no push
        self._held = None

    @property
    def held(self) -> int | None:
        """Key of the object held now, or None."""
        return self._held

    # --- sensors ------------------------------------------------------------------------------------
    def read_distance(self) -> float:
        """Rangefinder along the optical axis, metres from the optical centre; inf when nothing in range
        (and, with noise, when the reading drops out)."""
        mujoco.mj_forward(self.model, self.data)
        n, rng = self.noise, self._noise_rng
        if n.beam_deg:
            r = self._beam(math.radians(n.beam_deg))
        else:
            r = float(self.data.sensordata[self._range_adr])
        range_max = min(self.body.range_max, n.range_max or math.inf)
        if r < 0 or r > range_max:
            return math.inf
        if n.range_dropout and rng.random() < n.range_dropout:
            return math.inf
        if n.range_std:
            r = max(0.0, r + float(rng.normal(0.0, n.range_std * r)))
        return r

    def _beam(self, sigma: float) -> float:
        """What the beam hits, cast along the optical axis turned by a pointing error of `sigma` radians."""
        site = _name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, "range_site")
        origin = self.data.site_xpos[site].copy()
        frame = self.data.site_xmat[site].reshape(3, 3)
        ex, ey = self._noise_rng.normal(0.0, sigma, 2)
        direction = frame @ np.array([math.tan(ex), math.tan(ey), 1.0])
        direction /= np.linalg.norm(direction)
        geom = np.zeros(1, np.int32)
        body = int(self.model.site_bodyid[site])
        visible = _RAY_GROUPS  # bodies, furniture, room, robot: not collision boxes, not looks
        r = mujoco.mj_ray(self.model, self.data, origin, direction, visible, 1, body, geom)
        return float(r)

    def read_temperature(self) -> float:
        """The infrared thermometer along the optical axis, degrees Celsius (`attribot.sim.senses`)."""
        return senses.read_temperature(self)

    def squeeze(self) -> float:
        """Squeeze the held object: newtons per millimetre of closure, NaN with nothing held
        (`attribot.sim.senses`)."""
        return senses.squeeze(self)

    def _raw_force(self) -> np.ndarray:
        mujoco.mj_rnePostConstraint(self.model, self.data)
        mujoco.mj_sensorAcc(self.model, self.data)
        f_site = self.data.sensordata[self._force_adr : self._force_adr + 3].copy()
        # MuJoCo reports, in the site frame, the force with which the arm holds the wrist's subtree up;
        # its opposite is the load on the wrist, so that a held mass m adds (0, 0, -m*g) in the world frame
        return -(self.data.site_xmat[self._ft_site].reshape(3, 3) @ f_site)

    def tare_force(self) -> None:
        """Zero the wrist force sensor with what it carries now (the gripper, and anything it holds)."""
        self._tare = self._raw_force() + self._force_bias
        self._tare_time = float(self.data.time)
        if self.noise.force_drift:  # each tare starts a new slow drift
            self._drift_rate = self._noise_rng.normal(0.0, self.noise.force_drift, 3)

    def read_force(self) -> np.ndarray:
        """Wrist force in newtons, world frame, relative to the last tare, with the configured noise (a bias
        that the tare removes, a drift since the tare, noise on every reading)."""
        since = float(self.data.time) - self._tare_time
        f = self._raw_force() + self._force_bias + self._drift_rate * since - self._tare
        if self.force_noise_std > 0:
            f = f + self._rng.normal(0.0, self.force_noise_std, 3)
        if self.noise.force_std:
            f = f + self._noise_rng.normal(0.0, self.noise.force_std, 3)
        return f

    def joint_states(self) -> dict[str, float]:
        """Joint positions by name; the EP-like robot's arm as its links' elevations (upper_arm, forearm)
        and where its grip point is (lift, arm), as the EP reports its arm."""
        q = self.data.qpos
        out = self.body.reported(
            {n: float(q[a]) for n, a in self._qadr.items() if not n.startswith("finger")}
        )
        out["gripper"] = float((q[self._qadr["finger_l"]] + q[self._qadr["finger_r"]]) / 2)
        return out

    def base_pose(self) -> tuple[float, float, float]:
        q = self.data.qpos
        return (
            float(q[self._qadr["base_x"]]),
            float(q[self._qadr["base_y"]]),
            float(math.remainder(q[self._qadr["base_yaw"]], math.tau)),
        )

    def head(self) -> tuple[float, float]:
        """The camera's pan and tilt: the head's joints; on the EP-like robot, the camera's pitch on the
        arm (it has no pan)."""
        q = self.data.qpos
        pan, tilt = self.body.head_angles({n: float(q[a]) for n, a in self._qadr.items()})
        return float(pan), float(tilt)

    def camera_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World position of the optical centre and the camera's rotation (columns: right, up, backward)."""
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)
        return self.data.cam_xpos[self.camera_id].copy(), self.data.cam_xmat[self.camera_id].reshape(
            3, 3
        ).copy()

    # --- camera ---------------------------------------------------------------------------------------
    def camera_info(self) -> CameraInfo:
        fy = (self.height / 2) / math.tan(math.radians(self.model.cam_fovy[self.camera_id]) / 2)
        return CameraInfo(
            width=self.width, height=self.height, fx=fy, fy=fy, cx=self.width / 2, cy=self.height / 2
        )

    @property
    def renderer(self) -> SceneRenderer:
        if self._renderer is None:
            self._renderer = SceneRenderer(self.model, self.width, self.height, self.profile)
        return self._renderer

    def room_view(self) -> np.ndarray:
        """RGB (H, W, 3) of the fixed third-person room camera: for episode videos, never for the robot."""
        mujoco.mj_forward(self.model, self.data)
        cam = _name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, ROOM_CAMERA)
        out = self.renderer.render(self.data, cam, rgb=True)
        assert out.rgb is not None
        return out.rgb

    def observe(self, *, depth: bool = True, segmentation: bool = True) -> Frame:
        """The head camera's frame: RGB, and depth and segmentation (object keys, -1 elsewhere) with truth."""
        mujoco.mj_forward(self.model, self.data)
        out = self.renderer.render(
            self.data,
            self.camera_id,
            rgb=True,
            depth=depth,
            segmentation=segmentation,
            rays=self.body.beam_in_view,
        )
        seg = surfaces = None
        if out.geom_ids is not None:
            ids = out.geom_ids
            seg = np.where(ids >= 0, self.geom_key[np.clip(ids, 0, None)], -1).astype(np.int32)
            surfaces = np.where(ids >= 0, self.geom_surface[np.clip(ids, 0, None)], -1).astype(np.int16)
        assert out.rgb is not None
        return Frame(
            rgb=out.rgb,
            depth=out.depth,
            segmentation=seg,
            objects=dict(self.truth),
            camera=self.camera_info(),
            surfaces=surfaces,
            surface_names=self.surface_names,
        )

    # --- ground truth ---------------------------------------------------------------------------------
    def object_position(self, key: int) -> np.ndarray:
        """World position of the centre of the object's geometry (its bounding box of geom centres)."""
        return self.object_bounds(key).mean(axis=0)

    def object_bounds(self, key: int) -> np.ndarray:
        """World axis-aligned bounds (2, 3) of the object's visible geoms."""
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        m, d = self.model, self.data
        for g in self.geoms_of[key]:
            r = np.abs(d.geom_xmat[g].reshape(3, 3)) @ _half_extents(m, g)
            lo = np.minimum(lo, d.geom_xpos[g] - r)
            hi = np.maximum(hi, d.geom_xpos[g] + r)
        return np.stack([lo, hi])

    def support_of(self, key: int, tol: float = 0.01) -> str | None:
        """The name of the surface the object stands on now: a piece of furniture's top or board (as the
        plan names its surfaces: "shelf_2", "shelf_2_low"), or "floor"; its lowest point within `tol` of
        the surface's height and its middle over the furniture. None when it stands on none of them (held,
        in the air, on another object)."""
        lo, hi = self.object_bounds(key)
        x, y = (lo[:2] + hi[:2]) / 2
        for f in self.plan.furniture:
            x0, y0, x1, y1 = f.footprint()
            if not (x0 <= x <= x1 and y0 <= y <= y1):
                continue
            for surface in f.surfaces():
                if abs(lo[2] - surface.z) <= tol:
                    return surface.name
        return "floor" if abs(lo[2]) <= tol else None

    def top_of(self, key: int, x: float, y: float) -> float | None:
        """Height of the object's upper surface at world (x, y) by a ray cast downward, or None if missed."""
        groups = _RAY_GROUPS
        lo, hi = self.object_bounds(key)
        start = np.array([x, y, hi[2] + 0.05])
        geom = np.array([-1], np.int32)
        dist = mujoco.mj_ray(self.model, self.data, start, np.array([0.0, 0.0, -1.0]), groups, 1, -1, geom)
        if geom[0] < 0 or self.geom_key[geom[0]] != key:
            return None
        return float(start[2] - dist)

    def scene_info(self, frame: Frame | None = None) -> SceneInfo:
        """The truth of the scene now, with boxes from the segmentation of `frame` (or a fresh frame)."""
        frame = frame or self.observe()
        cam, _ = self.camera_pose()
        objects = []
        for o in self.plan.objects:
            mask = frame.segmentation == o.key if frame.segmentation is not None else np.zeros((1, 1), bool)
            n_px = int(mask.sum())
            box = box_from_mask(mask) if n_px >= MIN_VISIBLE_PIXELS else None
            pos = self.object_position(o.key)
            extras = {k: v for k, v in o.extras.items() if k in ObjectInfo.model_fields}
            objects.append(
                ObjectInfo(
                    id=o.id,
                    key=o.key,
                    category=o.category.name,
                    color=o.color,
                    mass_kg=round(float(self.model.body_mass[self.body_of[o.key]]), 4),
                    position=[round(float(v), 4) for v in pos],
                    box=list(box) if box else None,
                    visible_pixels=n_px,
                    pickable=o.category.pickable,
                    size_m=o.size_m,
                    variant=o.variant,
                    deceptive=o.category.deceptive,
                    distance_m=round(float(np.linalg.norm(pos - cam)), 4),
                    surface=o.surface,
                    temperature_c=o.temperature_c,
                    thermal=o.thermal,
                    stiffness_n_per_mm=o.stiffness_n_per_mm,
                    softness=o.softness,
                    fill=o.fill,
                    contents_kg=None if o.fill is None else round(o.fill * o.category.capacity_kg, 4),
                    **extras,
                )
            )
        x, y, yaw = self.base_pose()
        return SceneInfo(
            layout=self.plan.layout,
            seed=self.plan.seed,
            image_size=[self.width, self.height],
            objects=objects,
            robot=RobotInfo(
                base=[round(x, 4), round(y, 4), round(yaw, 4)],
                camera_position=[round(float(v), 4) for v in cam],
                head=[round(v, 4) for v in self.head()],
            ),
            furniture=[f.name for f in self.plan.furniture],
            room_temperature_c=self.plan.room_temperature_c,
        )

    def close(self) -> None:
        """Free the renderer; safe to call twice."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __enter__(self) -> SimWorld:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _half_extents(m: mujoco.MjModel, g: int) -> np.ndarray:
    s = m.geom_size[g]
    t = m.geom_type[g]
    if t == mujoco.mjtGeom.mjGEOM_SPHERE:
        return np.array([s[0]] * 3)
    if t == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return np.array([s[0], s[0], s[1]])
    if t == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return np.array([s[0], s[0], s[1] + s[0]])
    return np.array(s[:3])

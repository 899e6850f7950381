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

`SimWorld` keeps the model, the motion and the camera; it hands the rangefinder, force sensor and odometry
to `attribot.sim.readings`, grasping to `attribot.sim.grasping`, and the truth and scene info to
`attribot.sim.truth`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

from attribot.config import SceneConfig
from attribot.errors import InputError
from attribot.frame import CameraInfo, Frame, ObjectTruth
from attribot.sim import senses, truth
from attribot.sim.bodies import body_named
from attribot.sim.grasping import Gripper
from attribot.sim.looks import BODY_GROUP, LOOK_GROUP
from attribot.sim.model import ROOM_CAMERA, build_model
from attribot.sim.readings import ForceSensor, Odometry, Rangefinder
from attribot.sim.render import SceneRenderer
from attribot.sim.scene import plan_scene, scene_request, scene_requests, what_fits
from attribot.sim.scene_plan import LAYOUTS, ScenePlan, SceneRequest
from attribot.sim.truth import MIN_VISIBLE_PIXELS, ObjectInfo, RobotInfo, SceneInfo, box_from_mask, name2id

__all__ = ["SimWorld", "SceneInfo", "ObjectInfo", "RobotInfo", "MIN_VISIBLE_PIXELS", "box_from_mask"]

_ATTEMPTS = 30
# what rays hit (rangefinder, view checks, tops): the room, furniture, robot and objects' body parts, drawn
# (group 0) or under their looks (BODY_GROUP); never the looks (LOOK_GROUP), so that sensing is the same
# whatever objects look like
_RAY_GROUPS = np.array([int(g in (0, 1, BODY_GROUP)) for g in range(6)], np.uint8)
assert _RAY_GROUPS[LOOK_GROUP] == 0


def _fixed(layout: str) -> bool:
    """Layouts whose plan is exact (no rejection): arrangement and triplet."""
    return LAYOUTS.get(layout) is not LAYOUTS.get("household")


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
        request = scene_request(config)
        self.width, self.height, self.profile = config.width, config.height, config.profile
        self.force_noise_std = config.force_noise_std
        self.noise = config.noise
        self._seed_generators(config)
        self._renderer: SceneRenderer | None = None
        self._build_scene(request)
        self.step_hooks: list[Callable[[float], None]] = []  # called with the sim time after every step
        self._gripper = Gripper(self, self._noise_rng)
        self._rangefinder = Rangefinder(self, self._noise_rng)
        # drawn once, in this order, from the noise generator: odometry's errors, then the force sensor's bias
        self._odometry = Odometry(self, self._noise_rng)
        self._force = ForceSensor(self, self._rng, self._noise_rng)
        self.step(settle_s)
        self.pick_record: Any = None  # where the last pick happened, for putting the object back

    # --- set-up -----------------------------------------------------------------------------------
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
                if _fixed(layout):
                    raise
                error = exc
                continue
            self.plan.width, self.plan.height = self.width, self.height
            self.model = build_model(self.plan, looks=self.config.looks)
            self.data = mujoco.MjData(self.model)
            self._index()
            self._start()
            if _fixed(layout) or all(truth.in_view(self, k) for k in self.objects):
                return
            error = InputError(
                f"no {layout} scene for seed {seed} shows all {len(self.objects)} objects to the camera",
                "ask for fewer objects or another seed",
            )
        assert error is not None
        raise InputError(error.message, what_fits(layout, seed, request, _ATTEMPTS)) from error

    def _index(self) -> None:
        m = self.model
        J = mujoco.mjtObj.mjOBJ_JOINT
        A = mujoco.mjtObj.mjOBJ_ACTUATOR
        self._qadr = {n: int(m.jnt_qposadr[name2id(m, J, n)]) for n in self._joints}
        self._dadr = {n: int(m.jnt_dofadr[name2id(m, J, n)]) for n in self._qadr}
        self._act = {n: name2id(m, A, n) for n in self._joints}
        self.camera_id = name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, self.body.camera)
        self.pads = np.array(
            [name2id(m, mujoco.mjtObj.mjOBJ_GEOM, f"{n}_pad") for n in ("finger_l", "finger_r")]
        )
        # when the pads squeeze an object, its contact parameters alone say how it gives (`sim.senses`)
        m.geom_solmix[self.pads] = 0.0
        m.geom_solimp[self.pads] = [senses.SQUEEZE_IMPEDANCE, senses.SQUEEZE_IMPEDANCE, 0.001, 0.5, 2.0]
        self.range_site = name2id(m, mujoco.mjtObj.mjOBJ_SITE, "range_site")
        self.ray_groups = _RAY_GROUPS
        self.wrist_body = name2id(m, mujoco.mjtObj.mjOBJ_BODY, "wrist")
        self.objects = {o.key: o for o in self.plan.objects}
        self.body_of, self.geoms_of, self.weld_of, self.geom_key = truth.index_objects(m, self.plan.objects)
        self.key_of_id = {o.id: o.key for o in self.plan.objects}
        self.surface_names, self.geom_surface = truth.index_surfaces(m, self.plan.furniture)
        # the robot's own geoms: a robot knows where its body is from its joint angles and its model
        self.geom_own = m.body_rootid[m.geom_bodyid] == name2id(m, mujoco.mjtObj.mjOBJ_BODY, "robot")
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
        self._odometry.track()
        self._gripper.slip_if_due(d.time)
        for hook in getattr(self, "step_hooks", ()):
            hook(float(d.time))

    def robot_state(self) -> dict[str, Any]:
        """The robot's own state (joints, targets, odometry, tare), for `restore_robot`; no objects."""
        q = self._qadr
        return {
            "qpos": {n: float(self.data.qpos[a]) for n, a in q.items()},
            "targets": dict(self._targets),
            "odom": self._odometry.pose.copy(),
            "tare": self._force.state(),
        }

    def restore_robot(self, state: dict[str, Any]) -> None:
        """Put the robot back into `state` (from `robot_state`): where it stood, its head, arm and open
        gripper, and what its odometry believed. What it holds is let go first; objects stay put."""
        if self.held is not None:
            self.release()
        for name, value in state["qpos"].items():
            self.data.qpos[self._qadr[name]] = value
            self.data.qvel[self._dadr[name]] = 0.0
        for name, value in state["targets"].items():
            self._target(name, value)
        self._base_cmd = (0.0, 0.0, 0.0)
        self._set_base_ctrl()
        mujoco.mj_forward(self.model, self.data)
        self._odometry.restore(state["odom"])
        self._force.restore(state["tare"])
        self.step(0.3)

    def odometry(self) -> tuple[float, float, float]:
        """The base pose as the robot believes it (x, y, yaw): the truth plus the drift of its odometry."""
        return self._odometry.read()

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
    def grasp(self) -> bool:
        """Close the fingers on what lies between them; weld it to the wrist when both fingers touch it.

        Returns True when an object is now held. A pickable object counts only when the point between the
        fingertips is within 3 cm of it; the fingers stop where they meet its surface.
        """
        return self._gripper.grasp()

    def release(self) -> None:
        """Drop the weld and open the fingers."""
        self._gripper.release()

    @property
    def held(self) -> int | None:
        """Key of the object held now, or None."""
        return self._gripper.held

    # --- sensors ------------------------------------------------------------------------------------
    def read_distance(self) -> float:
        """Rangefinder along the optical axis, metres from the optical centre; inf when nothing in range
        (and, with noise, when the reading drops out)."""
        return self._rangefinder.read()

    def read_temperature(self) -> float:
        """The infrared thermometer along the optical axis, degrees Celsius (`attribot.sim.senses`)."""
        return senses.read_temperature(self)

    def squeeze(self) -> float:
        """Squeeze the held object: newtons per millimetre of closure, NaN with nothing held
        (`attribot.sim.senses`)."""
        return senses.squeeze(self)

    def tare_force(self) -> None:
        """Zero the wrist force sensor with what it carries now (the gripper, and anything it holds)."""
        self._force.tare()

    def read_force(self) -> np.ndarray:
        """Wrist force in newtons, world frame, relative to the last tare, with the configured noise (a bias
        that the tare removes, a drift since the tare, noise on every reading)."""
        return self._force.read()

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
        cam = name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, ROOM_CAMERA)
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
        seg = surfaces = own = None
        if out.geom_ids is not None:
            ids = out.geom_ids
            seg = np.where(ids >= 0, self.geom_key[np.clip(ids, 0, None)], -1).astype(np.int32)
            surfaces = np.where(ids >= 0, self.geom_surface[np.clip(ids, 0, None)], -1).astype(np.int16)
            own = (ids >= 0) & self.geom_own[np.clip(ids, 0, None)]
        assert out.rgb is not None
        return Frame(
            rgb=out.rgb,
            depth=out.depth,
            segmentation=seg,
            objects=dict(self.truth),
            camera=self.camera_info(),
            surfaces=surfaces,
            surface_names=self.surface_names,
            own_body=own,
        )

    # --- ground truth ---------------------------------------------------------------------------------
    def object_position(self, key: int) -> np.ndarray:
        """World position of the centre of the object's geometry (its bounding box of geom centres)."""
        return self.object_bounds(key).mean(axis=0)

    def object_bounds(self, key: int) -> np.ndarray:
        """World axis-aligned bounds (2, 3) of the object's visible geoms."""
        return truth.object_bounds(self.model, self.data, self.geoms_of[key])

    def support_of(self, key: int, tol: float = 0.01) -> str | None:
        """The name of the surface the object stands on now: a piece of furniture's top or board (as the
        plan names its surfaces: "shelf_2", "shelf_2_low"), or "floor"; its lowest point within `tol` of
        the surface's height and its middle over the furniture. None when it stands on none of them (held,
        in the air, on another object)."""
        return truth.support_of(self.plan.furniture, self.object_bounds(key), tol)

    def top_of(self, key: int, x: float, y: float) -> float | None:
        """Height of the object's upper surface at world (x, y) by a ray cast downward, or None if missed."""
        return truth.top_of(self, key, x, y)

    def scene_info(self, frame: Frame | None = None) -> SceneInfo:
        """The truth of the scene now, with boxes from the segmentation of `frame` (or a fresh frame)."""
        return truth.scene_info(self, frame)

    def close(self) -> None:
        """Free the renderer; safe to call twice."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __enter__(self) -> SimWorld:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

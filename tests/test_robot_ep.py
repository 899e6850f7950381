"""The RoboMaster EP's own body: a camera riding on a two-link arm, the ToF sensor at the gripper, no head
and no depth. The body model the EP's driver states against the simulator's kinematics, the EP-like scenes,
locating by the beam, and embodied weight queries answered by perception (go_to_object, pick_up,
measure_weight) on that body, directly and over the bridge: the same answers, checked against the world's
truth."""

from __future__ import annotations

import json
import math
import os
import signal
import socket
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager

import mujoco
import numpy as np
import pytest

from attribot.bridge.robomaster_body import EP_BODY
from attribot.bridge.server import Limits, serve_in_thread
from attribot.config import BridgeConfig, SceneConfig, load_settings
from attribot.control.body import BodyGeometry, CameraPose
from attribot.control.ranging import beam_estimate, beam_lift
from attribot.control.spatial import project
from attribot.embodiments.base import Capability
from attribot.embodiments.bridge import TOKEN_ENV, BridgeWorld, EmbodimentDriver
from attribot.embodiments.mujoco import MujocoWorld
from attribot.errors import InputError
from attribot.frame import CameraInfo
from attribot.planning.answer import Answer
from attribot.session import Scene, ask
from attribot.sim.bodies import BODIES
from attribot.sim.scene import plan_scene
from attribot.sim.scene_plan import SceneRequest
from attribot.sim.world import SceneInfo, SimWorld
from conftest import EMPTY_SETTINGS, wait_listening

BODY = BodyGeometry.from_dict(EP_BODY)
ARM = BODY.arm
SENSORS = ["camera", "distance", "force"]
TOKEN = "ep-body"


def test_the_arm_model_reaches_its_whole_box_and_clamps_beyond_it():
    assert ARM is not None
    for lift in np.linspace(*BODY.lift_range, 7):
        for ext in np.linspace(*BODY.arm_range, 5):
            x = BODY.reach_x(float(ext))
            angles = ARM.solve(x, float(lift))
            assert angles is not None and ARM.feasible(*angles), (lift, ext)
            assert ARM.grip_point(*angles) == pytest.approx((x, lift), abs=1e-9)
    assert ARM.solve(1.0, 0.1) is None  # a metre away: out of reach
    far = ARM.nearest(1.0, 0.1)
    assert ARM.feasible(*far) and 0.28 < ARM.grip_point(*far)[0] < 0.31  # stretched out as far as it goes


def test_the_camera_rides_on_the_arm_and_the_beam_on_the_gripper():
    assert ARM is not None
    rest = BODY.camera_pose({"lift": BODY.rest[0], "arm": BODY.rest[1]})
    assert rest.xyz == pytest.approx(BODY.camera_xyz, abs=0.002) and rest.pan == 0.0
    assert -0.15 < rest.tilt < 0.0  # at the SDK's zero pose the camera looks a little down
    low = BODY.camera_pose({"lift": 0.04, "arm": 0.0})
    assert low.xyz[2] < rest.xyz[2] - 0.05 and low.tilt < rest.tilt - 0.5  # lowered, and looking down
    beam = BODY.range_pose({"lift": 0.04, "arm": 0.03})
    assert beam.tilt == 0.0 and beam.pan == 0.0 and beam.xyz[2] == pytest.approx(0.04)
    assert beam.xyz[0] == pytest.approx(BODY.reach_x(0.03) + ARM.rangefinder[0])
    assert beam.xyz[0] > BODY.base_half[0]  # ahead of the chassis: it cannot see its own front


def _site(world: MujocoWorld, name: str) -> np.ndarray:
    sim = world.sim
    mujoco.mj_forward(sim.model, sim.data)
    return sim.data.site_xpos[mujoco.mj_name2id(sim.model, mujoco.mjtObj.mjOBJ_SITE, name)].copy()


def test_the_stated_body_is_the_simulated_robots_kinematics():
    """The body the EP's driver states, checked against the simulator's own camera, grip point and ToF at
    several arm poses: what a controller computes from the joints is where the simulator has them."""
    with MujocoWorld(layout="triplet", seed=1, robot="ep", width=160, height=120) as world:
        assert world.body() == BODY
        assert Capability.HEAD not in world.capabilities() and Capability.DEPTH not in world.capabilities()
        assert world.observe().depth is None
        for lift, ext in [BODY.rest, (0.04, 0.0), (0.22, 0.065), (0.1, 0.03)]:
            world.set_arm(lift, ext)
            world.step(1.5)
            js = world.joint_states()
            assert (js["lift"], js["arm"]) == pytest.approx((lift, ext), abs=0.003)  # it got there
            pose = world.base_pose()
            x, y, yaw = pose.x, pose.y, pose.yaw
            assert abs(x) < 1e-4 and abs(y) < 1e-4 and abs(yaw) < 1e-4  # the base frame is the world's
            view = BODY.camera_pose(js)
            eye, rot = world.sim.camera_pose()
            axis = -rot[:, 2]  # a MuJoCo camera looks along its -z
            assert view.xyz == pytest.approx(eye, abs=1e-4)
            assert view.tilt == pytest.approx(math.atan2(axis[2], math.hypot(axis[0], axis[1])), abs=1e-3)
            grip = _site(world, "grip_site")
            assert (grip[0], grip[2]) == pytest.approx((BODY.reach_x(js["arm"]), js["lift"]), abs=1e-4)
            assert _site(world, "range_site") == pytest.approx(BODY.range_pose(js).xyz, abs=1e-3)


@pytest.mark.parametrize(("layout", "seed"), [("household", 0), ("household", 7), ("triplet", 2)])
def test_ep_scenes_put_objects_its_gripper_holds_on_the_floor_in_its_view(layout, seed):
    config = SceneConfig(layout=layout, seed=seed, robot="ep", width=320, height=240)
    with SimWorld(config) as a, SimWorld(config) as b:
        info = a.scene_info()
        assert info == b.scene_info()  # the same seed, the same scene
        for o, placed in zip(info.objects, a.plan.objects, strict=True):
            assert o.surface == "floor" and o.box is not None, o  # on the floor, in the first view
            assert BODIES.get("ep").holds(placed.category) and o.pickable


def test_what_the_ep_cannot_do_is_refused_naming_the_fix():
    # refused as the config is made (its validator), before any world is built
    with pytest.raises(InputError, match="arrangement layout is not made for the EP-like robot") as exc:
        SceneConfig(layout="arrangement", seed=1, robot="ep")
    assert "household or triplet" in (exc.value.fix or "")
    with pytest.raises(InputError, match="cannot hold laptop"):
        SceneConfig(layout="household", seed=1, robot="ep", categories=("laptop", "mug"))
    # and by the same check where a layout is asked directly
    with pytest.raises(InputError, match="arrangement layout is not made for the EP-like robot"):
        plan_scene("arrangement", 1, SceneRequest(robot="ep"))
    with pytest.raises(InputError, match="robot") as bad:
        SceneConfig.create(robot="walle")
    assert "mast, ep" in (bad.value.fix or "")
    with MujocoWorld(layout="triplet", seed=1, robot="ep", width=160, height=120) as world:
        with pytest.raises(Exception, match="no head capability"):
            world.set_head(0.1, 0.0)


CAM = CameraInfo(width=320, height=240, fx=144.0, fy=144.0, cx=160.0, cy=120.0)


def _box_of(lo: tuple[float, float, float], hi: tuple[float, float, float], view: CameraPose) -> tuple:
    corners = np.array([(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    uv, front = project(corners, CAM, view)
    assert front.all()
    return (uv[:, 0].min(), uv[:, 1].min(), uv[:, 0].max(), uv[:, 1].max())


@pytest.mark.parametrize("pose", [BODY.rest, (0.05, 0.0)])
def test_the_beam_and_the_box_locate_an_object_straight_ahead(pose):
    """A block on the floor straight ahead, seen from the arm's camera (far and level, or close and looking
    down): the beam's reading of its front and the rays of its box give its centre, height and width."""
    lo, hi = (0.60, -0.03, 0.0), (0.66, 0.03, 0.08)  # 6 cm wide and deep, 8 cm tall
    view = BODY.camera_pose({"lift": pose[0], "arm": pose[1]})
    box = _box_of(lo, hi, view)
    lift = beam_lift(box, CAM, view, BODY)
    assert lift is not None and lift == pytest.approx(max(0.04, BODY.lift_range[0]), abs=0.015)  # mid-height
    beam = BODY.range_pose({"lift": lift, "arm": 0.0})
    est = beam_estimate(lo[0] - beam.xyz[0], beam, box, CAM, view, (1.0, 2.0, math.pi / 2))
    assert est is not None
    # in the world frame of a base at (1, 2) facing +y: the block's centre at (1, 2.63)
    assert est.centre[:2] == pytest.approx((1.0, 2.63), abs=0.015)
    assert est.support_z == pytest.approx(0.0, abs=0.01) and est.top_z == pytest.approx(0.08, abs=0.015)
    assert est.radius == pytest.approx(0.03, abs=0.01)


# --- embodied weight queries, directly and over the bridge ---------------------------------------------


def _lightest_query(info: SceneInfo) -> str:
    names = list(dict.fromkeys(o.category for o in info.objects))
    listed = ", ".join(f"the {n}" for n in names[:-1]) + f" and the {names[-1]}"
    return f"Out of {listed}, which one is the most lightweight?"


@contextmanager
def _served(config: SceneConfig) -> Iterator[BridgeConfig]:
    limits = Limits(max_accel=1000.0, max_turn_accel=1000.0, watchdog_s=30.0, simulated=True)
    server, _, thread = serve_in_thread(lambda: EmbodimentDriver(MujocoWorld(config)), TOKEN, limits=limits)
    try:
        yield BridgeConfig(url=f"tcp://127.0.0.1:{server.address[1]}")
    finally:
        server.close()
        thread.join(timeout=30)


def _weights(answer: Answer) -> list[tuple[str, float]]:
    calls = answer.trace
    return [(t["args"][0]["object_id"], t["result"]) for t in calls if t["call"] == "Robot.measure_weight"]


def _weigh_directly_and_over_the_bridge(layout: str, seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    config = SceneConfig(layout=layout, seed=seed, robot="ep")
    with SimWorld(config) as sim:
        info = sim.scene_info()
    query = _lightest_query(info)
    settings = load_settings(detector="oracle", vqa="oracle", language="catalog")
    here = ask(query, Scene(config, sensors=SENSORS), settings)
    monkeypatch.setenv(TOKEN_ENV, TOKEN)
    with _served(config) as bridge:
        over = ask(query, Scene(bridge, sensors=SENSORS), settings)
    assert here.error is None and over.error is None, (here.error, over.error)
    assert here.backends["robot"] == over.backends["robot"] == "servo"
    lightest = min(info.objects, key=lambda o: o.mass_kg)
    assert here.object is not None and over.object is not None
    assert here.object.id == over.object.id == lightest.id, query  # the world's truth, both ways
    weighed, truth = _weights(here), {o.id: o.mass_kg for o in info.objects}
    assert {oid for oid, _ in weighed} == set(truth)  # each one picked up and weighed
    for (oid, kg), (oid_over, kg_over) in zip(weighed, _weights(over), strict=True):
        assert oid == oid_over and kg_over == pytest.approx(kg, rel=0.01)
        assert kg == pytest.approx(truth[oid], rel=0.05, abs=0.005)  # from the force sensor, by physics


def test_an_embodied_weight_query_on_the_ep_body_answers_the_same_directly_and_over_the_bridge(monkeypatch):
    """Out of the egg, the apple and the cactus on the floor: go_to_object, pick_up and measure_weight by
    perception alone, on the EP's geometry (the base turns to centre, the ToF on the gripper ranges)."""
    _weigh_directly_and_over_the_bridge("triplet", 1, monkeypatch)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("layout", "seed"),
    [("household", 0), ("household", 2), ("household", 4), ("household", 6), ("household", 10),
     ("triplet", 0), ("triplet", 5)],
)  # fmt: skip
def test_embodied_weight_queries_on_the_ep_body_over_more_seeds(layout, seed, monkeypatch):
    _weigh_directly_and_over_the_bridge(layout, seed, monkeypatch)


def test_the_ep_world_over_the_bridge_states_the_same_body_and_capabilities():
    config = SceneConfig(layout="triplet", seed=1, robot="ep", width=320, height=240)
    with _served(config) as bridge, BridgeWorld(bridge, token=TOKEN) as over, MujocoWorld(config) as here:
        assert over.body() == here.body() == BODY
        assert over.capabilities() == here.capabilities()
        assert over.joint_states() == here.joint_states()
        assert over.observe().depth is None and over.read_distance() == here.read_distance()


def test_the_ep_is_refused_by_the_privileged_controller(monkeypatch):
    monkeypatch.delenv(TOKEN_ENV, raising=False)
    config = SceneConfig(layout="triplet", seed=1, robot="ep", width=320, height=240)
    settings = load_settings(detector="oracle", vqa="oracle", language="catalog")
    answer = ask(
        "How much does the egg weigh?", Scene(config, sensors=SENSORS, controller="privileged"), settings
    )
    assert answer.error is not None and "cannot move the EP-like robot" in answer.error.message


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "attribot.cli", *args]


@pytest.mark.slow
def test_the_commands_serve_the_ep_body_and_ask_over_the_bridge_as_directly():
    """`attribot bridge serve --driver mujoco --robot ep` and `attribot ask --world bridge` answer an embodied
    weight query as `attribot ask --robot ep` does in the direct world."""
    env = {**os.environ, "ATTRIBOT_CONFIG": str(EMPTY_SETTINGS), TOKEN_ENV: TOKEN}
    scene = ["--layout", "household", "--seed", "7"]
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = int(s.getsockname()[1])
    serving = ["--driver", "mujoco", "--robot", "ep", *scene, "--port", str(port), "--token", TOKEN]
    serve = subprocess.Popen(_cli("bridge", "serve", *serving), stderr=subprocess.PIPE, text=True, env=env)
    query = ["ask", "Out of the potato and the cactus, which one is the most lightweight?"]
    flags = ["--sensors", "camera,distance,force", "--json"]
    try:
        wait_listening(port, serve, "bridge serve")
        url = f"tcp://127.0.0.1:{port}"
        bridged = _cli(*query, "--world", "bridge", "--bridge-url", url, *flags)
        over = subprocess.run(bridged, capture_output=True, text=True, env=env, timeout=600)
    finally:
        serve.send_signal(signal.SIGINT)
        serve.wait(timeout=30)
    direct = _cli(*query, *scene, "--robot", "ep", *flags)
    here = subprocess.run(direct, capture_output=True, text=True, env=env, timeout=600)
    assert over.returncode == 0 and here.returncode == 0, (over.stderr, here.stderr)
    a, b = json.loads(over.stdout), json.loads(here.stdout)
    assert a["error"] is None and a["answer"] == b["answer"] and a["object"]["id"] == "potato_1"
    assert [t["result"] for t in a["trace"] if t["call"] == "Robot.measure_weight"] == pytest.approx(
        [t["result"] for t in b["trace"] if t["call"] == "Robot.measure_weight"], rel=0.01
    )

"""The MuJoCo world: determinism, stability, sensor truth, boxes against projected geometry, headless render.

Worlds are shared per module and images kept small so that this file runs in well under a minute on two
cores. Everything checked here is physical or geometric truth computed independently of the code under
test (slab ray-box intersection, pinhole projection of geom surfaces, masses from the compiled model).
"""

from __future__ import annotations

import math
import os
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from attribot.boxes import iou
from attribot.embodiments.base import EMBODIMENTS, Capability
from attribot.embodiments.mujoco import MujocoWorld
from attribot.errors import InputError, UnknownName
from attribot.sim import scripted
from attribot.sim.render import gl_backend
from attribot.sim.scene_plan import LAYOUTS

W, H = 200, 150
G = 9.81


@pytest.fixture(scope="module")
def triplet():
    with MujocoWorld(layout="triplet", seed=3, width=W, height=H) as world:
        yield world


@pytest.fixture(scope="module")
def triplet_bodies():
    """The triplet with objects drawn as their bodies: what rays measure is then what is drawn."""
    with MujocoWorld(layout="triplet", seed=3, width=W, height=H, looks="primitive") as world:
        yield world


@pytest.fixture(scope="module")
def household():
    with MujocoWorld(layout="household", seed=4, width=W, height=H) as world:
        yield world


# --- helpers computed independently of the world's own code -------------------------------------------


def _surface_points(model: mujoco.MjModel, data: mujoco.MjData, g: int, n: int = 12) -> np.ndarray:
    """Points on the surface of geom `g` in the world frame (boxes: corners and edges; round: rings)."""
    s = model.geom_size[g]
    t = model.geom_type[g]
    u = np.linspace(0, 2 * np.pi, n, endpoint=False)
    if t == mujoco.mjtGeom.mjGEOM_BOX:
        lin = np.linspace(-1, 1, 5)
        pts = (
            np.array([[a, b, c] for a in lin for b in lin for c in lin if max(abs(a), abs(b), abs(c)) == 1])
            * s[:3]
        )
    elif t in (mujoco.mjtGeom.mjGEOM_SPHERE, mujoco.mjtGeom.mjGEOM_ELLIPSOID):
        r = s[:3] if t == mujoco.mjtGeom.mjGEOM_ELLIPSOID else np.array([s[0]] * 3)
        v = np.linspace(0, np.pi, n)
        pts = np.array([[np.cos(a) * np.sin(b), np.sin(a) * np.sin(b), np.cos(b)] for a in u for b in v]) * r
    else:  # cylinder, capsule: rings at the ends (and the caps' poles)
        half = s[1]
        rings = [np.c_[s[0] * np.cos(u), s[0] * np.sin(u), np.full(n, z)] for z in (-half, half)]
        pts = np.vstack(rings)
        if t == mujoco.mjtGeom.mjGEOM_CAPSULE:
            v = np.linspace(0, np.pi / 2, 5)
            caps = [
                np.array(
                    [
                        [
                            s[0] * np.cos(a) * np.cos(b),
                            s[0] * np.sin(a) * np.cos(b),
                            sign * (half + s[0] * np.sin(b)),
                        ]
                        for a in u
                        for b in v
                    ]
                )
                for sign in (-1, 1)
            ]
            pts = np.vstack([pts, *caps])
    return data.geom_xpos[g] + pts @ data.geom_xmat[g].reshape(3, 3).T


def _project(world: MujocoWorld, pts: np.ndarray) -> np.ndarray:
    """Pinhole projection with the world's CameraInfo and the camera pose MuJoCo reports."""
    cam = world.camera_info()
    sim = world.sim
    pos = sim.data.cam_xpos[sim.camera_id]
    rot = sim.data.cam_xmat[sim.camera_id].reshape(3, 3)  # columns: right, up, backward
    p = (pts - pos) @ rot
    z = -p[:, 2]
    return np.c_[cam.cx + cam.fx * p[:, 0] / z, cam.cy - cam.fy * p[:, 1] / z]


def _ray_box(
    origin: np.ndarray, direction: np.ndarray, centre: np.ndarray, rot: np.ndarray, half: np.ndarray
) -> float:
    """Distance along a ray to an oriented box (slab method), inf on a miss."""
    o = rot.T @ (origin - centre)
    d = rot.T @ direction
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (-half - o) / d, (half - o) / d
    tmin, tmax = np.nanmax(np.minimum(t1, t2)), np.nanmin(np.maximum(t1, t2))
    return float(tmin) if tmax >= max(tmin, 0) and tmin > 0 else math.inf


# --- registry and determinism --------------------------------------------------------------------------


def test_registered_as_an_embodiment_with_every_capability():
    assert EMBODIMENTS.get("mujoco") is MujocoWorld
    assert set(LAYOUTS.names()) == {"arrangement", "triplet", "household"}


def test_headless_backend_is_chosen_and_named():
    assert gl_backend() in ("egl", "osmesa")


def _python_choosing_its_own_backend(code: str) -> str:
    """stdout of `code` in a fresh Python with MUJOCO_GL unset, so that it probes; fails on its errors."""
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_backend_is_chosen_automatically_when_mujoco_gl_is_unset():
    code = (
        "import sys; from attribot.sim.render import gl_backend; import attribot.sim.render as r;"
        "assert 'OpenGL' not in sys.modules; from attribot.sim.world import SimWorld;"
        "w = SimWorld(layout='triplet', seed=1, width=64, height=48); f = w.observe(); w.close();"
        "print(gl_backend(), f.rgb.shape, int(f.rgb.std() > 5))"
    )
    stdout = _python_choosing_its_own_backend(code)
    backend, *_ = stdout.split()
    assert backend in ("egl", "osmesa") and stdout.strip().endswith("1")


def test_a_prefetched_probe_is_the_one_the_choice_uses():
    """prefetch_gl_backend starts the EGL probe early; gl_backend collects it instead of probing again,
    and the choice is the one an unprefetched process makes."""
    code = (
        "import attribot.sim.render as r\n"
        "r.prefetch_gl_backend(); first = r._prefetched['egl']\n"
        "r.prefetch_gl_backend(); assert r._prefetched['egl'] is first  # started once\n"
        "started = []\n"
        "real = r._start_probe\n"
        "r._start_probe = lambda b: started.append(b) or real(b)\n"
        "print(r.gl_backend(), started, first.returncode, r._prefetched)\n"
    )
    backend, rest = _python_choosing_its_own_backend(code).split(" ", 1)
    assert backend == gl_backend()
    # EGL works: no probe started after the prefetched one, which ran to success and was collected
    expected = "[] 0 {}" if backend == "egl" else "['osmesa'] 1 {}"
    assert rest.strip() == expected


def test_prefetch_starts_nothing_when_mujoco_gl_decides(monkeypatch):
    import attribot.sim.render as render

    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    monkeypatch.setattr(render, "_chosen", None)
    render.prefetch_gl_backend()
    assert render._prefetched == {} and render.gl_backend() == "osmesa"


def test_no_working_backend_names_the_system_packages(monkeypatch):
    from attribot.errors import ConfigError
    from attribot.sim import render

    monkeypatch.setattr(render, "_chosen", None)
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    monkeypatch.setattr(render, "_probe", lambda backend, started=None: f"lib{backend} not found")
    with pytest.raises(ConfigError) as exc:
        render.gl_backend()
    assert "libegl1" in exc.value.fix and "libosmesa6" in exc.value.fix
    assert "libegl not found" in exc.value.message
    monkeypatch.setenv("MUJOCO_GL", "glfw")
    with pytest.raises(ConfigError, match="MUJOCO_GL='glfw' cannot render headless"):
        render.gl_backend()
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    assert render.gl_backend() == "osmesa"  # an explicit choice is honoured without probing


@pytest.mark.parametrize("layout", ["arrangement", "triplet", "household"])
def test_same_seed_same_scene_and_pixels(layout):
    a = MujocoWorld(layout=layout, seed=11, width=96, height=72)
    b = MujocoWorld(layout=layout, seed=11, width=96, height=72)
    c = MujocoWorld(layout=layout, seed=12, width=96, height=72)
    try:
        fa, fb, fc = a.observe(), b.observe(), c.observe()
        assert np.array_equal(fa.rgb, fb.rgb)
        assert np.array_equal(fa.segmentation, fb.segmentation)
        assert a.scene_info() == b.scene_info()
        assert not np.array_equal(fa.rgb, fc.rgb)
    finally:
        for w in (a, b, c):
            w.close()


@pytest.mark.parametrize("layout", ["arrangement", "triplet", "household"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_every_object_in_the_first_view(layout, seed):
    with MujocoWorld(layout=layout, seed=seed, width=320, height=240) as world:
        info = world.scene_info()
        assert info.objects
        hidden = [o.id for o in info.objects if o.box is None]
        assert not hidden, f"not in view: {hidden}"


def test_arrangement_truth_rows_columns_and_one_odd_one_out():
    # eight pairs of scissors, whose open loops show too few pixels at 200x150 for the smallest to be boxed
    with MujocoWorld(
        layout="arrangement",
        seed=5,
        width=320,
        height=240,
        options={"pattern": "grid", "odd": "size"},
        objects=8,
    ) as world:
        objs = world.scene_info().objects
    assert sum(o.odd_one_out for o in objs) == 1
    assert {(o.row, o.col) for o in objs} == {(r, c) for r in range(2) for c in range(4)}
    cx = {o.id: (o.box[0] + o.box[2]) / 2 for o in objs}
    cy = {o.id: (o.box[1] + o.box[3]) / 2 for o in objs}
    for a in objs:
        for b in objs:
            if a.row == b.row and a.col < b.col:
                assert cx[a.id] < cx[b.id], "col 0 is at the left of the image"
            if a.col == b.col and a.row < b.row:
                assert cy[a.id] < cy[b.id], "row 0 is at the top of the image"
    odd = next(o for o in objs if o.odd_one_out)
    others = [o.size_m for o in objs if not o.odd_one_out]
    assert odd.size_m > 1.3 * max(others) or odd.size_m < 0.75 * min(others)
    assert max(others) / min(others) < 1.2, "controlled size variation"


def test_triplet_weights_clearly_increase(triplet):
    objs = triplet.scene_info().objects
    assert len(objs) == 3
    by_rank = sorted(objs, key=lambda o: o.weight_rank)
    masses = [o.mass_kg for o in by_rank]
    assert masses[1] > 2 * masses[0] and masses[2] > 2 * masses[1]


def test_household_candidates_at_different_distances(household):
    d = sorted(o.distance_m for o in household.scene_info().objects)
    assert 2 <= len(d) <= 6
    assert min(np.diff(d)) > 0.1


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"layout": "castle"}, UnknownName),
        ({"categories": ["unicorn"]}, UnknownName),
        ({"seed": -1}, InputError),
        ({"objects": 99}, InputError),
        ({"layout": "triplet", "objects": 4}, InputError),
        ({"layout": "arrangement", "objects": 20, "categories": ["pot"]}, InputError),
        ({"layout": "arrangement", "options": {"pattern": "spiral"}}, InputError),
        ({"profile": "ugly"}, InputError),
    ],
)
def test_bad_requests_are_clear_errors(kwargs, error):
    args = {"layout": "household", "seed": 0, **kwargs}
    with pytest.raises(error):
        MujocoWorld(layout=args.pop("layout"), seed=args.pop("seed"), width=64, height=48, **args)


# --- physics ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("layout", ["household", "arrangement", "triplet"])
def test_objects_rest_stably_without_interpenetration(layout):
    """From the planned placement, with sleeping off (a sleeping body would pass trivially)."""
    with MujocoWorld(layout=layout, seed=4, width=64, height=48) as world:
        sim = world.sim
        sim.model.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)
        mujoco.mj_resetData(sim.model, sim.data)
        sim._start()
        world.step(0.3)  # placed 0.5 mm above their surface: let them touch down
        keys = list(sim.objects)
        before = {k: sim.data.xpos[sim.body_of[k]].copy() for k in keys}
        world.step(1.5)
        for k in keys:
            moved = np.linalg.norm(sim.data.xpos[sim.body_of[k]] - before[k])
            speed = np.linalg.norm(sim.data.cvel[sim.body_of[k]])
            assert moved < 0.003, f"{sim.objects[k].id} drifted {moved * 1000:.1f} mm"
            assert speed < 0.01
        assert sim.data.ncon > 0
        for i in range(sim.data.ncon):
            con = sim.data.contact[i]
            if sim.geom_key[con.geom1] >= 0 or sim.geom_key[con.geom2] >= 0:
                assert con.dist > -0.003, "objects sink into what they rest on"
                other = con.geom2 if sim.geom_key[con.geom1] >= 0 else con.geom1
                assert sim.geom_key[other] < 0, "objects do not touch each other"


def test_base_head_and_arm_follow_commands(household):
    sim = household.sim
    p0 = household.base_pose()
    x0, y0, yaw0 = p0.x, p0.y, p0.yaw
    household.command_base(0.2, 0.0, 0.0)
    household.step(1.0)
    household.command_base(0.0, 0.0, 0.0)
    household.step(0.5)
    p1 = household.base_pose()
    x1, y1 = p1.x, p1.y
    assert math.hypot(x1 - x0, y1 - y0) == pytest.approx(0.2, abs=0.03)
    assert math.atan2(y1 - y0, x1 - x0) == pytest.approx(yaw0, abs=0.05)  # forward is the base's heading
    household.set_head(0.3, -0.4)
    household.set_arm(0.6, 0.2)
    household.step(1.5)
    js = household.joint_states()
    assert {"head_pan", "head_tilt", "lift", "arm", "gripper", "base_x", "base_y", "base_yaw"} <= set(js)
    assert js["head_pan"] == pytest.approx(0.3, abs=1e-3) and js["head_tilt"] == pytest.approx(-0.4, abs=1e-3)
    assert js["lift"] == pytest.approx(0.6, abs=0.01) and js["arm"] == pytest.approx(0.2, abs=0.01)
    assert sim.held is None and not household.grasp()  # nothing between the fingers
    household.set_arm(0.2, 0.0)
    household.set_head(*sim.plan.head)
    household.command_base(-0.2, 0.0, 0.0)
    household.step(1.0)
    household.command_base(0.0, 0.0, 0.0)
    household.step(1.0)


def test_rangefinder_reads_the_geometric_distance(triplet_bodies):
    triplet = triplet_bodies
    sim = triplet.sim
    m, d = sim.model, sim.data
    boxes = [
        g
        for g in range(m.ngeom)
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
        and m.geom_group[g] < 3
        and m.geom_bodyid[g] not in (mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "head_tilt"),)
    ]
    for key in sim.objects:
        # aim at the centre of the object's biggest part (a bounding box centre may be empty space)
        main = max(sim.geoms_of[key], key=lambda g: float(np.prod(m.geom_size[g][:2])))
        target = d.geom_xpos[main].copy()
        cam, _ = sim.camera_pose()
        v = target - cam
        triplet.set_head(
            math.atan2(v[1], v[0]) - triplet.base_pose().yaw, math.atan2(v[2], math.hypot(v[0], v[1]))
        )
        triplet.step(1.0)
        reading = triplet.read_distance()
        cam, rot = sim.camera_pose()
        axis = -rot[:, 2]
        # independent truth: the nearest box face (table, walls, robot) or, for round parts, MuJoCo's ray
        truth_boxes = min(
            _ray_box(cam, axis, d.geom_xpos[g], d.geom_xmat[g].reshape(3, 3), m.geom_size[g]) for g in boxes
        )
        geomid = np.array([-1], np.int32)
        truth_any = mujoco.mj_ray(
            m,
            d,
            cam,
            axis,
            np.array([1, 1, 0, 0, 1, 0], np.uint8),  # world, robot, object bodies (not their looks)
            1,
            mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "head_tilt"),
            geomid,
        )
        hit_box = m.geom_type[geomid[0]] == mujoco.mjtGeom.mjGEOM_BOX
        truth = truth_boxes if hit_box else truth_any
        assert sim.geom_key[geomid[0]] == key, "the optical axis goes through the object's centre"
        assert reading == pytest.approx(truth, abs=0.01)
        depth = triplet.observe().depth
        assert float(depth[H // 2 - 1 : H // 2 + 1, W // 2 - 1 : W // 2 + 1].mean()) == pytest.approx(
            reading, abs=0.02
        )
    triplet.set_head(*sim.plan.head)
    triplet.step(1.0)


def test_box_geometry_reading_with_a_cube():
    with MujocoWorld(
        layout="arrangement",
        seed=2,
        width=96,
        height=72,
        categories=["toy block"],
        objects=3,
        options={"pattern": "row", "odd": "color"},
    ) as world:
        sim = world.sim
        key = 1
        g = sim.geoms_of[key][0]
        centre = sim.data.geom_xpos[g].copy()
        cam, _ = sim.camera_pose()
        v = centre - cam
        world.set_head(
            math.atan2(v[1], v[0]) - world.base_pose().yaw, math.atan2(v[2], math.hypot(v[0], v[1]))
        )
        world.step(1.0)
        cam, rot = sim.camera_pose()
        truth = _ray_box(
            cam,
            -rot[:, 2],
            sim.data.geom_xpos[g],
            sim.data.geom_xmat[g].reshape(3, 3),
            sim.model.geom_size[g],
        )
        assert math.isfinite(truth)
        assert world.read_distance() == pytest.approx(truth, abs=0.01)


def test_segmentation_boxes_agree_with_projected_geometry(triplet_bodies):
    triplet = triplet_bodies
    frame = triplet.observe()
    sim = triplet.sim
    assert frame.segmentation is not None and frame.camera is not None
    assert set(np.unique(frame.segmentation)) <= {-1, *sim.objects}
    for key in sim.objects:
        mask = frame.segmentation == key
        ys, xs = np.nonzero(mask)
        seg_box = (xs.min(), ys.min(), xs.max() + 1, ys.max() + 1)
        pts = np.vstack([_surface_points(sim.model, sim.data, g) for g in sim.geoms_of[key]])
        uv = _project(triplet, pts)
        proj_box = (uv[:, 0].min(), uv[:, 1].min(), uv[:, 0].max(), uv[:, 1].max())
        assert iou(seg_box, proj_box) > 0.8, (sim.objects[key].id, seg_box, proj_box)
        assert frame.objects[key].category == sim.objects[key].category.name


def test_force_sensor_reads_the_held_weight_from_physics(triplet):
    sim = triplet.sim
    for key, obj in sim.objects.items():
        mass = float(sim.model.body_subtreemass[sim.body_of[key]])
        assert scripted.pick_object(triplet, obj.id)
        assert triplet.held_object() == obj.id
        triplet.step(0.3)
        fz = float(triplet.read_force()[2])
        assert -fz == pytest.approx(mass * G, rel=0.02), obj.id
        # the reading comes from the simulated sensor: changing the body's mass changes it
        sim.model.body_mass[sim.body_of[key]] *= 2
        triplet.step(1.0)
        assert -float(triplet.read_force()[2]) == pytest.approx(2 * mass * G, rel=0.02)
        sim.model.body_mass[sim.body_of[key]] /= 2
        triplet.step(1.0)
        home = sim.data.xpos[sim.body_of[key]].copy()
        scripted.place_back(triplet)
        assert triplet.held_object() is None
        assert abs(float(triplet.read_force()[2])) < 0.02 * mass * G + 0.02
        triplet.step(0.5)
        assert np.linalg.norm(sim.data.cvel[sim.body_of[key]]) < 0.05
        assert abs(sim.data.xpos[sim.body_of[key]][2] - (home[2] - 0.08)) < 0.02, "put back down on the table"


def test_support_of_names_the_surface_each_object_was_placed_on():
    with MujocoWorld(layout="household", seed=4, width=W, height=H) as world:
        sim = world.sim
        for key, obj in sim.objects.items():
            assert sim.support_of(key) == obj.surface, obj.id
        key, obj = next(iter(sim.objects.items()))
        assert scripted.pick_object(world, obj.id)
        assert sim.support_of(key) is None  # lifted: on nothing
        scripted.place_back(world)
        world.step(0.5)
        assert sim.support_of(key) == obj.surface


def test_an_object_let_go_above_the_table_falls_onto_it():
    """Held still in the air, an object is ready to sleep; let go, it must fall, not sleep where it hangs
    (the physics of a placement that lets go a little above a top)."""
    with MujocoWorld(layout="triplet", seed=3, width=W, height=H) as world:
        sim = world.sim
        key, obj = next(iter(sim.objects.items()))
        table_top = sim.plan.furniture[0].size[2]
        assert scripted.pick_object(world, obj.id)
        lift, ext = world.joint_states()["lift"], world.joint_states()["arm"]
        over = sim.object_bounds(key)[0][2] - table_top
        world.set_arm(lift - over + 0.04, ext)  # its bottom 4 cm over the table, held still
        world.step(2.0)
        assert sim.object_bounds(key)[0][2] > table_top + 0.03
        world.release()
        world.step(1.0)
        assert sim.object_bounds(key)[0][2] == pytest.approx(table_top, abs=0.004)


def test_force_noise_is_gaussian_with_the_given_spread():
    with MujocoWorld(layout="triplet", seed=3, width=64, height=48, force_noise_std=0.5) as world:
        world.tare_force()
        reads = np.array([world.read_force() for _ in range(400)])
    assert abs(reads.mean()) < 0.1
    assert reads.std() == pytest.approx(0.5, rel=0.15)


def test_pick_refuses_what_it_cannot_hold():
    with MujocoWorld(
        layout="household", seed=0, width=64, height=48, categories=["suitcase", "mug"], objects=2
    ) as world:
        suitcase = next(o.id for o in world.sim.plan.objects if o.category.name == "suitcase")
        with pytest.raises(scripted.ManipulationError, match="not something the robot can pick up"):
            scripted.pick_object(world, suitcase)
        with pytest.raises(UnknownName):
            scripted.pick_object(world, "unicorn_9")
        with pytest.raises(scripted.ManipulationError, match="holds nothing"):
            scripted.place_back(world)


def test_capabilities_and_frame_layers(household):
    assert household.capabilities() == frozenset(Capability)
    frame = household.observe()
    assert frame.rgb.shape == (H, W, 3) and frame.rgb.dtype == np.uint8
    assert frame.depth.shape == (H, W) and np.isfinite(frame.depth).all()
    assert frame.segmentation.dtype == np.int32
    cam = household.camera_info()
    assert (cam.width, cam.height) == (W, H) and cam.fx == pytest.approx(cam.fy)
    household.close()
    household.close()  # twice is fine


def test_looks_are_drawn_over_the_bodies_and_segmented_as_their_objects():
    """Each object's look covers about the same pixels as its body (IoU of the segmentation boxes), and
    every pixel of a look is its object's in the segmentation."""
    with (
        MujocoWorld(layout="triplet", seed=3, width=W, height=H) as triplet,
        MujocoWorld(layout="triplet", seed=3, width=W, height=H, looks="primitive") as bodies_world,
    ):
        looks, bodies = triplet.observe(), bodies_world.observe()
    assert looks.segmentation is not None and bodies.segmentation is not None
    for key in triplet.sim.objects:
        a, b = looks.segmentation == key, bodies.segmentation == key
        assert a.sum() > 50 and b.sum() > 50
        ya, xa = np.nonzero(a)
        yb, xb = np.nonzero(b)
        box_a = (xa.min(), ya.min(), xa.max() + 1, ya.max() + 1)
        overlap = iou(box_a, (xb.min(), yb.min(), xb.max() + 1, yb.max() + 1))
        assert overlap > 0.6, (triplet.sim.objects[key].id, overlap)
    assert not np.array_equal(looks.rgb, bodies.rgb), "the looks change the pixels"

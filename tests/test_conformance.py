"""Conformance over everything registered: every layout, world, backend kind and planner is found the
same way and keeps the same promises (determinism, finite outputs, protocol shape, clear errors)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from attribot.config import WORLD_CONFIGS, load_settings
from attribot.embodiments.base import EMBODIMENTS, Capability, Embodiment
from attribot.errors import AttribotError, ConfigError, InputError, MissingDependency
from attribot.frame import Frame
from attribot.models.base import ROLES, BackendStatus, LanguageModel, VisualQA, build_backend, probe_backend
from attribot.models.base import Detector as DetectorProtocol
from attribot.planning import PLANNERS, PlanRequest, build_planner
from attribot.runner import check_program
from attribot.sensors import SENSORS, Need, check_sensors, sensor_method_doc
from attribot.sim.scene import LAYOUTS

SMALL = {"width": 160, "height": 120}
PROTOCOLS = {"detector": DetectorProtocol, "vqa": VisualQA, "language": LanguageModel}


@pytest.mark.parametrize("layout", LAYOUTS.names())
def test_every_layout_is_deterministic_and_finite(layout):
    world_cls = EMBODIMENTS.get("mujoco")
    with world_cls(layout=layout, seed=11, **SMALL) as a, world_cls(layout=layout, seed=11, **SMALL) as b:
        fa, fb = a.observe(), b.observe()
        assert np.array_equal(fa.rgb, fb.rgb)
        assert a.scene_info() == b.scene_info()
        assert np.isfinite(fa.depth).all() and (fa.depth > 0).all()
        keys = set(np.unique(fa.segmentation)) - {-1}
        assert keys <= set(fa.objects), "segmentation keys must all name an object"
        ids = {o.id for o in a.scene_info().objects}
        assert {fa.objects[k].id for k in keys} <= ids
    with world_cls(layout=layout, seed=12, **SMALL) as c:
        assert c.scene_info() != a.scene_info(), "another seed gives another scene"


def test_every_world_has_one_typed_config_registered_under_its_name():
    assert sorted(WORLD_CONFIGS.names()) == sorted(EMBODIMENTS.names())
    assert len({id(WORLD_CONFIGS.get(name)) for name in WORLD_CONFIGS.names()}) == len(WORLD_CONFIGS.names())


@pytest.mark.parametrize("name", EMBODIMENTS.names())
def test_every_world_observes_and_refuses_what_it_cannot_do(name):
    kind = WORLD_CONFIGS.get(name)
    try:  # built from its own config, as the session builds it
        built = EMBODIMENTS.get(name)(
            kind.create(**{k: v for k, v in SMALL.items() if k in kind.model_fields})
        )
    except (InputError, ConfigError, MissingDependency) as exc:
        # a world that needs a robot's address or an extra (bridge, ai2thor) says what is missing; their own
        # tests (test_bridge.py, test_ai2thor.py) run them against a loopback robot and a fake controller
        assert name in ("bridge", "ai2thor") and exc.fix
        return
    with built as world:
        assert isinstance(world, Embodiment)
        caps = world.capabilities()
        assert Capability.CAMERA in caps
        frame = world.observe()
        assert isinstance(frame, Frame) and frame.camera is not None
        assert (frame.width, frame.height) == (SMALL["width"], SMALL["height"])
        for cap, call in [
            (Capability.DISTANCE, world.read_distance),
            (Capability.FORCE, world.read_force),
            (Capability.POSE, world.base_pose),
        ]:
            if cap in caps:
                call()
            else:
                with pytest.raises(AttribotError, match=cap.value):
                    call()
    world.close()  # closing twice is safe


@pytest.mark.parametrize(("role", "kind"), [(r, k) for r, reg in ROLES.items() for k in reg.names()])
def test_every_backend_kind_probes_without_raising_and_builds_or_explains(role, kind):
    settings = load_settings()
    status = probe_backend(role, kind, settings)
    assert isinstance(status, BackendStatus) and status.registered and status.detail
    try:
        backend = build_backend(role, kind, settings)
    except ConfigError as exc:  # kinds that need an argument or an endpoint say which
        assert exc.fix or exc.message
        return
    except AttribotError as exc:  # e.g. a missing extra: the message carries the pip line
        assert "pip install" in str(exc) or exc.fix
        return
    assert isinstance(backend, PROTOCOLS[role]) and isinstance(backend.name, str) and backend.name


@pytest.mark.parametrize("name", PLANNERS.names())
def test_every_planner_writes_a_program_the_sandbox_accepts_or_explains(name, tmp_path):
    settings = load_settings(cache_dir=tmp_path)
    request = PlanRequest(query="the heaviest item", sensors=["camera", "force"], embodied=True)
    try:
        planner = build_planner(name, settings)
        plan = planner.plan(request)
    except ConfigError as exc:  # the llm planner with no endpoint configured
        assert "llm" in name and ("base" in str(exc).lower() or "key" in str(exc).lower())
        return
    assert planner.name == name
    assert check_program(plan.program) is None
    assert planner.plan(request).program == plan.program  # deterministic for the same request


@pytest.mark.parametrize("name", EMBODIMENTS.names())
def test_every_world_offers_what_the_servo_controller_uses(name):
    """Every world class has each member of `ServoWorld` (the servo's whole use of a world), with the same
    parameters; a built MuJoCo world passes the runtime check too."""
    import inspect

    from attribot.control.world import ServoWorld

    world_cls = EMBODIMENTS.get(name)
    members = [*ServoWorld.__annotations__, *(m for m in vars(ServoWorld) if not m.startswith("_"))]
    assert {"observe", "step", "set_head", "base_pose", "name"} <= set(members)
    for member in members:
        assert hasattr(world_cls, member), f"{world_cls.__name__} lacks {member}"
        wanted = getattr(ServoWorld, member, None)
        if callable(wanted):
            have = list(inspect.signature(getattr(world_cls, member)).parameters)
            assert have == list(inspect.signature(wanted).parameters), f"{world_cls.__name__}.{member}"
    if name == "mujoco":
        with world_cls(**SMALL) as world:
            assert isinstance(world, ServoWorld)


@pytest.mark.parametrize("name", SENSORS.names())
def test_every_sensor_answers_to_its_names_and_the_mujoco_world_reads_it_or_says_why(name):
    """Every registered sensor: its aliases resolve to it, its method (if any) is documented with an example
    and its preconditions, and where the embedded world offers it a reading is a number, or NaN where the
    reading needs a grasp and nothing is held."""
    sensor = SENSORS.get(name)
    assert check_sensors([name]) == ["camera"] + ([name] if name != "camera" else [])
    for alias in sensor.aliases:
        assert name in check_sensors([alias])
    if sensor.method is not None:
        doc = sensor_method_doc(sensor)
        assert ">>> def execute_command(image, robot):" in doc and f"robot.{sensor.method}(" in doc
        if sensor.needs is Need.AIM:
            assert "focus_on_patch" in doc
        if sensor.needs is Need.GRASP:
            assert "pick_up" in doc
    world_cls = EMBODIMENTS.get("mujoco")
    with world_cls(layout="triplet", seed=3, **SMALL) as world:
        if name not in world.sensors() or sensor.capability is not None:
            return
        value = world.read_sensor(name)
        assert math.isfinite(value) or (math.isnan(value) and sensor.needs is Need.GRASP)

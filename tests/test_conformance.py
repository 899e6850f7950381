"""Conformance over everything registered: every layout, world, backend kind and planner is found the
same way and keeps the same promises (determinism, finite outputs, protocol shape, clear errors)."""

from __future__ import annotations

import inspect
import math
from collections.abc import Iterator

import numpy as np
import pytest
from pydantic import TypeAdapter

from attribot.api import Robot
from attribot.config import (
    WORLD_CONFIGS,
    BridgeConfig,
    SceneConfig,
    WorldConfig,
    load_settings,
    world_config,
)
from attribot.embodiments.base import EMBODIMENTS, Capability, Embodiment
from attribot.errors import (
    AttribotError,
    ConfigError,
    InputError,
    MissingDependency,
    UnknownName,
    UnsupportedAction,
)
from attribot.frame import Frame
from attribot.models.base import ROLES, BackendStatus, LanguageModel, VisualQA, build_backend, probe_backend
from attribot.models.base import Detector as DetectorProtocol
from attribot.planning import PLANNERS, PlanRequest, build_planner
from attribot.runner import check_program
from attribot.sensors import SENSORS, Need, check_sensors, senses, sensor_method_doc
from attribot.session import Scene
from attribot.sim.bodies import BODIES, body_named
from attribot.sim.catalog import find_category
from attribot.sim.scene_plan import LAYOUTS

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
    for name in WORLD_CONFIGS.names():
        assert WORLD_CONFIGS.get(name).world_name() == name  # its tag is its name


def test_world_configs_are_one_union_told_apart_by_their_world_tag(tmp_path):
    bridge = {"world": "bridge", "url": "tcp://127.0.0.1:7777"}
    assert isinstance(TypeAdapter(WorldConfig).validate_python(bridge), BridgeConfig)
    assert world_config({"seed": 3}) == SceneConfig(seed=3) == world_config({"world": "sim", "seed": 3})
    assert world_config(bridge) == BridgeConfig(url="tcp://127.0.0.1:7777")
    with pytest.raises(UnknownName, match="ai2thor"):  # an unknown world lists the known ones
        world_config({"world": "moon"})
    with pytest.raises(InputError, match="layout"):  # the tag chose the bridge's config, which has no layout
        world_config({**bridge, "layout": "triplet"})
    with pytest.raises(InputError, match="configured by a SceneConfig, not a BridgeConfig"):
        Scene(config=BridgeConfig(url="tcp://127.0.0.1:7777"), world="mujoco")
    # a saved scene from before the tag loads; a tag inside it does not choose another world than the one
    # the folder names (whose place the trust check reads)
    assert Scene.from_saved({"world": "mujoco", "config": {"seed": 3}}, tmp_path).config == SceneConfig(
        seed=3
    )
    with pytest.raises(InputError):
        Scene.from_saved({"world": "mujoco", "config": bridge}, tmp_path)
    with pytest.raises(ConfigError, match="ATTRIBOT_BRIDGE_TOKEN"):
        Scene.from_saved({"world": "bridge", "config": {**bridge, "world": "mujoco"}}, tmp_path)


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


def _worlds_reading_sensors() -> Iterator[tuple[str, Embodiment]]:
    """Every world that reads sensors here, built small: the embedded one with each robot body, and the
    bridge to a robot (a loopback robot-side server driving the embedded world)."""
    from attribot.embodiments.bridge import BridgeWorld, EmbodimentDriver
    from test_bridge import TOKEN, serving, url

    for robot in BODIES.names():
        config = SceneConfig(layout="triplet", seed=3, robot=robot, **SMALL)
        with EMBODIMENTS.get("mujoco")(config) as world:
            yield f"mujoco/{robot}", world
    config = SceneConfig(layout="triplet", seed=3, **SMALL)
    with serving(lambda: EmbodimentDriver(EMBODIMENTS.get("mujoco")(config))) as (server, _):
        with BridgeWorld(url=url(server), token=TOKEN) as bridge:
            yield "bridge", bridge


@pytest.mark.parametrize("name", SENSORS.names())
def test_every_sensor_answers_to_its_names_and_every_sense_has_its_documented_method(name):
    """Every registered sensor: its aliases resolve to it; each of its senses has a Robot method a program
    can call, which needs this sensor and is documented with an example and its preconditions (the senses
    of a sensor with a capability have Robot's own methods, the others one written from the record)."""
    sensor = SENSORS.get(name)
    assert check_sensors([name]) == ["camera"] + ([name] if name != "camera" else [])
    for alias in sensor.aliases:
        assert name in check_sensors([alias])
    for sense in sensor.senses:
        assert sense.method in Robot.API_METHODS and Robot.REQUIRES[sense.method] == name
        doc = inspect.getdoc(getattr(Robot, sense.method)) or ""
        if sensor.capability is None:
            assert doc == sensor_method_doc(sensor, sense)
        assert ">>> def execute_command(image, robot):" in doc and f".{sense.method}(" in doc
        if sense.needs is Need.AIM and sensor.capability is None:  # robot.measure_distance aims itself
            assert "focus_on_patch" in doc
        if sense.needs is Need.GRASP:
            assert "pick_up" in doc
        assert sense.words and sense.why and sense.doing, f"{sense.quantity}: words, why, doing"


def test_every_world_reads_every_sensor_it_offers():
    """In every world: the sensors it offers are registered ones, and each one read through `read_sensor`
    gives a number, or NaN where the reading needs a grasp and nothing is held; one it does not offer is
    refused, naming it."""
    seen = set()
    for where, world in _worlds_reading_sensors():
        offered = world.sensors()
        assert "camera" in offered and offered <= set(SENSORS.names()), where
        for name in SENSORS.names():
            sensor = SENSORS.get(name)
            if sensor.capability is not None:
                continue
            if name not in offered:
                with pytest.raises(UnsupportedAction, match=name):
                    world.read_sensor(name)
                continue
            seen.add(name)
            value = world.read_sensor(name)
            grasp = any(s.needs is Need.GRASP for s in sensor.senses)
            assert math.isfinite(value) or (math.isnan(value) and grasp), (where, name, value)
    assert seen == {n for n in SENSORS.names() if SENSORS.get(n).capability is None}, "each is read somewhere"


@pytest.mark.parametrize(("sensor", "sense"), senses(), ids=[q.quantity for _, q in senses()])
def test_every_sense_is_offered_by_the_prompt_and_asked_in_its_words(sensor, sense):
    """The prompt shows a sense's method exactly when the robot has its sensor; the rules planner reads a
    question in the sense's superlative words and writes a program that measures with its method."""
    from attribot.api.prompt import build_prompt

    have = build_prompt("which one?", ["camera", sensor.name])
    assert f"def {sense.method}(self" in have
    without = build_prompt("which one?", ["camera"])
    assert f"def {sense.method}(self" not in without and f"robot.{sense.method}" in without
    planner = build_planner("rules", load_settings())
    superlatives = [w for w, (more, form) in sense.words.items() if form == "superlative"]
    assert superlatives, f"{sense.quantity} has no superlative word to ask with"
    for word in superlatives:
        query = f"which object is the {word}?"
        program = planner.plan(PlanRequest(query=query, sensors=["camera", sensor.name], embodied=True))
        assert f".{sense.method}(" in program.program, (query, program.program)


@pytest.mark.parametrize("name", BODIES.names())
def test_every_robot_body_builds_and_states_what_it_has(name):
    """Every registered robot body: the config accepts its name, a world built with it sees through its
    camera, reports its joints and head as its record says, offers the capabilities it has, and draws a
    scene within its limits (what its gripper holds, where its gripper reaches)."""
    body = BODIES.get(name)
    config = SceneConfig(layout=(body.layouts or ("triplet",))[0], seed=2, robot=name, **SMALL)
    with EMBODIMENTS.get("mujoco")(config) as world:
        caps = world.capabilities()
        assert (Capability.HEAD in caps) is body.head and (Capability.DEPTH in caps) is body.depth
        assert world.body() == body.geometry
        frame = world.observe()
        assert frame.rgb.shape == (SMALL["height"], SMALL["width"], 3)
        assert (frame.depth is not None) is body.depth
        joints = world.joint_states()
        assert {"base_x", "base_y", "base_yaw", "gripper"} <= set(joints)
        assert all(math.isfinite(v) for v in joints.values())
        pan, tilt = world.sim.head()
        assert math.isfinite(pan) and math.isfinite(tilt)
        for o in world.scene_info().objects:
            category = find_category(o.category)
            assert category is not None and body.holds(category)
            assert (o.surface == "floor") is body.on_floor
    if not body.head:
        with EMBODIMENTS.get("mujoco")(config) as world, pytest.raises(InputError, match="no camera head"):
            world.sim.set_head(0.1, 0.0)


def test_an_unknown_robot_body_is_refused_naming_the_registered_ones():
    with pytest.raises(InputError, match="unknown robot") as refused:
        body_named("hexapod")
    assert all(name in refused.value.fix for name in BODIES.names())

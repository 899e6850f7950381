"""Simulator speed: render frames per second, physics real-time factor, scene build time.

Run: `MUJOCO_GL=egl .venv/bin/python benchmarks/bench_sim.py [--quick]`

Prints one line per figure, each with its ratio to a reference measured in the same run (the machine is
shared and noisy, so the ratios are what compare across runs):
- render: a bare scene with one box rendered at 320x240 (RGB, fast profile) is the reference;
- physics: a bare scene with one box resting on a plane is the reference;
- build: compiling that bare scene is the reference.
Targets on the 2-core CI machine: >= 150 fps at 320x240 RGB fast, >= 50x real time with the robot and 20
objects, a scene built in < 0.5 s.
"""

from __future__ import annotations

import argparse
import time

import mujoco

from attribot.sim.render import SceneRenderer, gl_backend
from attribot.sim.world import SimWorld

__all__ = ["main"]


def _bare_spec(width: int = 320, height: int = 240) -> mujoco.MjSpec:
    spec = mujoco.MjSpec()
    spec.visual.global_.offwidth, spec.visual.global_.offheight = width, height
    spec.worldbody.add_light(pos=[0, 0, 3], dir=[0, 0, -1])
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2, 2, 0.1])
    b = spec.worldbody.add_body(pos=[0, 0, 0.1])
    b.add_freejoint()
    b.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.1, 0.1, 0.1], rgba=[0.8, 0.2, 0.2, 1])
    spec.worldbody.add_camera(name="cam", pos=[0, -1.5, 1.0], xyaxes=[1, 0, 0, 0, 0.6, 0.8])
    return spec


def _fps(renderer: SceneRenderer, data: mujoco.MjData, camera: int, frames: int, all_layers: bool) -> float:
    renderer.render(data, camera, depth=all_layers, segmentation=all_layers)  # warm-up
    t = time.perf_counter()
    for _ in range(frames):
        renderer.render(data, camera, depth=all_layers, segmentation=all_layers)
    return frames / (time.perf_counter() - t)


def _rtf(model: mujoco.MjModel, data: mujoco.MjData, sim_seconds: float) -> float:
    n = int(sim_seconds / model.opt.timestep)
    t = time.perf_counter()
    mujoco.mj_step(model, data, nstep=n)
    return n * model.opt.timestep / (time.perf_counter() - t)


def _line(name: str, value: float, unit: str, ref: float) -> None:
    print(f"{name:<44s} {value:10.1f} {unit:<8s} ratio {value / ref:6.3f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer frames and steps (a smoke run)")
    args = ap.parse_args()
    frames = 30 if args.quick else 200
    print(f"# backend {gl_backend()}, mujoco {mujoco.__version__}")

    # references: a bare one-box scene
    t = time.perf_counter()
    bare = _bare_spec(640, 480).compile()
    build_ref = time.perf_counter() - t
    bare_data = mujoco.MjData(bare)
    mujoco.mj_forward(bare, bare_data)
    with SceneRenderer(bare, 320, 240, "fast") as r:
        render_ref = _fps(r, bare_data, 0, frames, False)
    physics_ref = _rtf(bare, bare_data, 2.0 if args.quick else 10.0)
    _line("reference: bare scene render 320x240 rgb", render_ref, "fps", render_ref)
    _line("reference: bare scene physics", physics_ref, "x rt", physics_ref)
    _line("reference: bare scene compile", build_ref * 1000, "ms", build_ref * 1000)

    # rendering the household scene
    for w, h in ((320, 240), (640, 480)):
        world = SimWorld(layout="household", seed=0, width=w, height=h)
        try:
            mujoco.mj_forward(world.model, world.data)
            for profile in ("fast", "pretty"):
                with SceneRenderer(world.model, w, h, profile) as r:
                    for all_layers in (False, True):
                        n = frames if w == 320 else max(frames // 2, 10)
                        fps = _fps(r, world.data, world.camera_id, n, all_layers)
                        layers = "rgb+depth+seg" if all_layers else "rgb"
                        _line(f"render household {w}x{h} {layers} {profile}", fps, "fps", render_ref)
        finally:
            world.close()

    # physics with the robot and 20 objects
    world = SimWorld(
        layout="arrangement",
        seed=0,
        objects=20,
        categories=["apple"],
        options={"pattern": "grid"},
        width=64,
        height=48,
    )
    assert len(world.objects) == 20
    rtf = _rtf(world.model, world.data, 2.0 if args.quick else 10.0)
    _line("physics robot + 20 objects (at rest)", rtf, "x rt", physics_ref)
    world.set_arm(0.8, 0.4)
    world.command_base(0.1, 0.0, 0.1)
    n_s = 2.0 if args.quick else 5.0
    t = time.perf_counter()
    world.step(n_s)
    _line("physics robot + 20 objects (robot moving)", n_s / (time.perf_counter() - t), "x rt", physics_ref)
    # the same with sleeping disabled: every body integrated and collided at every step
    world.command_base(0.0, 0.0, 0.0)
    world.model.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    rtf = _rtf(world.model, world.data, 2.0 if args.quick else 10.0)
    _line("physics robot + 20 objects (sleeping off)", rtf, "x rt", physics_ref)
    world.close()

    # scene build: plan + MjSpec + compile + 0.6 s of settling, and the model alone
    for layout in ("household", "arrangement", "triplet"):
        t = time.perf_counter()
        world = SimWorld(layout=layout, seed=0, width=320, height=240)
        built = time.perf_counter() - t
        world.close()
        _line(f"build {layout} scene (incl. settling)", built * 1000, "ms", build_ref * 1000)


if __name__ == "__main__":
    main()

"""How the simulated gripper takes hold of an object and lets go of it.

A grasp is a weld constraint between the wrist and the object, made when the closing fingers touch it (the
fingers pass through things otherwise). With the world's noise a grasp can close on nothing, or slip as the
lift starts and leave the object behind. `Gripper` is a collaborator of a `SimWorld`: it moves the fingers
through the world's commands and reads its public attributes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from attribot.sim.truth import name2id

if TYPE_CHECKING:
    from attribot.sim.world import SimWorld

__all__ = ["Gripper"]

_FINGERS = ("finger_l", "finger_r")


class Gripper:
    """What the gripper holds, and the grasp, slip and release that change it; a failed or slipping grasp
    is drawn from `rng`."""

    def __init__(self, world: SimWorld, rng: np.random.Generator) -> None:
        self._world = world
        self._rng = rng
        self._probe = name2id(world.model, mujoco.mjtObj.mjOBJ_GEOM, "grip_probe")
        self.held: int | None = None
        self._slip_at: float | None = None  # when a held object that will slip falls out

    def _distance(self, geom: int, key: int, cap: float = 0.2) -> float:
        """The least distance from `geom` to the object's body parts (at most `cap`)."""
        w = self._world
        return min(
            float(mujoco.mj_geomDistance(w.model, w.data, geom, g, cap, np.zeros(6))) for g in w.geoms_of[key]
        )

    def grasp(self) -> bool:
        """Close the fingers on what lies between them and weld it to the wrist: `SimWorld.grasp`."""
        w = self._world
        if self.held is not None:
            return True
        key = self._nearest()
        if key is None:
            w.set_gripper(0.0)
            w.step(0.4)
            return False
        self._close_on(key)
        if not self._touches(key):
            return False
        self._weld(key)
        if w.noise.slip and self._rng.random() < w.noise.slip:
            # the grip is too weak: as the lift starts, the object stays behind on its support
            self._slip_at = float(w.data.time) + float(self._rng.uniform(0.05, 0.25))
        w.step(0.3)
        return True

    def _nearest(self) -> int | None:
        """The pickable object nearest the point between the fingertips, within 3 cm; None when there is
        none, or when the fingers slide off it."""
        near = [(self._distance(self._probe, k), k) for k in self._world.weld_of]
        near = [(dist, k) for dist, k in near if dist < 0.03]
        noise = self._world.noise
        if near and noise.grasp_fail and self._rng.random() < noise.grasp_fail:
            near = []  # the fingers slide off: they close on nothing
        if not near:
            return None
        return min(near)[1]

    def _close_on(self, key: int) -> None:
        """Close each finger step by step until it meets the object's surface or closes fully."""
        w = self._world
        moving = {0: True, 1: True}
        for _ in range(150):
            for i, name in enumerate(_FINGERS):
                if not moving[i]:
                    continue
                if self._distance(int(w.pads[i]), key) <= 0.001:
                    moving[i] = False
                    w.set_finger(name, w.finger_state(name)[1])
                else:
                    w.set_finger(name, max(w.finger_target(name) - 0.004, 0.0))
                    if w.finger_target(name) == 0.0 and w.finger_state(name)[1] < 0.002:
                        moving[i] = False
            w.step(0.012)
            if not any(moving.values()):
                break

    def _touches(self, key: int) -> bool:
        """Whether the closed fingers hold the object: both on it; or, for a thin object off the centre line,
        one finger on it, the other closed past it, and the point between the fingertips at the object."""
        gaps = [self._distance(int(p), key) for p in self._world.pads]
        off_centre = min(gaps) < 0.006 and self._distance(self._probe, key) < 0.012
        return max(gaps) < 0.006 or off_centre

    def _weld(self, key: int) -> None:
        """Activate the weld between wrist and object at their current relative pose."""
        w = self._world
        m, d = w.model, w.data
        eq = w.weld_of[key]
        b1, b2 = w.wrist_body, w.body_of[key]
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
        self.held = key

    def release(self) -> None:
        """Drop the weld and open the fingers."""
        if self.held is not None:
            self._let_go()
        self._slip_at = None
        self._world.set_gripper(self._world.finger_open)
        self._world.step(0.3)

    def slip_if_due(self, time: float) -> None:
        """Let the held object fall out when a slip drawn at the grasp is due at sim time `time`."""
        if self._slip_at is not None and time >= self._slip_at and self.held is not None:
            self._let_go()  # the grip gives: it falls out
            self._slip_at = None
            self._world.set_gripper(0.0)  # and the fingers, still closing, meet each other

    def _let_go(self) -> None:
        """Drop the weld of the held object and wake it. Held still in the gripper, it was ready to sleep;
        unwelded, it would fall asleep at once where it hangs instead of falling onto what is below."""
        assert self.held is not None
        m, d = self._world.model, self._world.data
        body = self._world.body_of[self.held]
        d.eq_active[self._world.weld_of[self.held]] = 0
        tree = int(m.body_treeid[body])
        if d.tree_asleep[tree] < 0:
            d.tree_asleep[tree] = -(1 + mujoco.mjMINAWAKE)  # as awake as a tree gets: counting down anew
        else:
            dof = int(m.body_dofadr[body])
            d.qvel[dof : dof + 6] = -0.0  # MuJoCo's documented wake signal (not 0.0 bytewise), no push
        self.held = None

"""What each robot action needs before the robot moves, checked in one place, and the words of a refusal.

A call that makes no physical sense in the robot's state (picking up with something in the gripper,
weighing what it does not hold, driving to a second object with the first one held, putting an object on
itself, putting down with an empty gripper) is refused here, before anything moves, with a fix that names
the call to make. The fix is written in the dialect the program was written in: `robot.put_down()` where
the program calls the robot it was given (attribot's prompt), `put_down()` where it calls the robot's
methods as bare functions or on a robot it made itself (the paper authors' prompt and ViperGPT's habits).

One case is no refusal: `put_on(p)` given the object the gripper holds means "put it back", as programs
written from the authors' prompt (which has no put_down) use it; `Verdict.PUT_BACK` tells the session so.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING, Literal

from attribot.skills.errors import PreconditionError

if TYPE_CHECKING:
    from attribot.skills.sighting import Sighting

__all__ = ["Dialect", "Verdict", "State", "call_text", "check_action", "refuse"]

Dialect = Literal["attribot", "paper"]
"""How the program calls the robot: `robot.pick_up(p)` on the robot it was given (attribot), or `pick_up(p)`
as a bare function or on a `Robot(sensors=[...])` it made (the paper's and ViperGPT's habits)."""


class Verdict(Enum):
    """What a call needs that the robot's state does not give, where the robot a program made arranges it
    (the paper's robot did) and the robot it was given refuses."""

    MET = "met"
    PUT_BACK = "put back"  # put_on(the held object): put it down where it was picked up
    ALREADY = "already"  # nothing to do: go_to_object or pick_up of the object held


@dataclass(frozen=True)
class State:
    """The robot's state as the checks read it: what it holds, what it stands next to, the dialect."""

    held: Sighting | None
    near: Sighting | None
    dialect: Dialect
    aimed: Sighting | None = None  # what the camera was last centred on, since the robot moved


def call_text(method: str, args: str = "", dialect: Dialect = "attribot") -> str:
    """A call as the program's dialect writes it: `robot.put_down()` or `put_down()`."""
    return f"{'robot.' if dialect == 'attribot' else ''}{method}({args})"


def _right_before(first: str, then: str, d: Dialect) -> str:
    return f"call {call_text(first, 'patch', d)} right before {call_text(then, 'patch', d)}"


def _named(p: Sighting | None) -> str:
    if p is None:
        return "nothing"
    ident = f" ({p.object_id})" if p.object_id else ""
    return f"{p.label or 'an object'}{ident}"


def _same(a: Sighting | None, b: Sighting) -> bool:
    return a is not None and a.same_object(b)


def refuse(message: str, fix: str) -> PreconditionError:
    """The error of a refused call (a function, so that every refusal is built the same way)."""
    return PreconditionError(message, fix)


def check_action(method: str, p: Sighting | None, state: State, reading: str = "grasp") -> Verdict:
    """Whether `method` may run on `p` in `state`: `Verdict.MET`, or what the session does instead
    (`PUT_BACK`, `ALREADY`); a call that makes no physical sense raises `PreconditionError` naming the call
    to make, in the program's dialect. A method that is not an action is a reading, which needs what
    `reading` says (`attribot.sensors.Need`: "aim", "reach" or "grasp")."""
    if method in _ACTIONS:
        return _action_verdict(method, p, state)
    assert p is not None, f"{method} reads an object"
    return _reading_verdict(method, p, state, reading)


_ACTIONS = ("put_down", "put_on", "go_to_object", "pick_up", "push")


def _action_verdict(method: str, p: Sighting | None, state: State) -> Verdict:
    """`check_action` for the robot's actions (`_ACTIONS`)."""
    d, held = state.dialect, state.held
    this = _named(p)
    if method == "put_down":
        if held is None:
            raise refuse(
                f"{call_text('put_down', '', d)} needs an object in the gripper, and it is empty",
                f"call {call_text('pick_up', 'patch', d)} before {call_text('put_down', '', d)}, or leave "
                f"{call_text('put_down', '', d)} out",
            )
        return Verdict.MET
    assert p is not None, f"{method} acts on an object"
    if method == "put_on":
        if held is None:
            raise refuse(
                f"{call_text('put_on', this, d)} needs an object in the gripper, and it is empty",
                f"call {call_text('go_to_object', 'obj', d)} and {call_text('pick_up', 'obj', d)} first, "
                f"then {call_text('put_on', 'patch', d)}",
            )
        return Verdict.PUT_BACK if _same(held, p) else Verdict.MET
    if method == "go_to_object":
        if held is None:
            return Verdict.MET
        if _same(held, p):
            return Verdict.ALREADY
        raise refuse(
            f"{call_text('go_to_object', this, d)} was called with {_named(held)} in the gripper: the robot "
            "does not drive to another object with one held",
            f"to put {_named(held)} on {this}, call {call_text('put_on', 'patch', d)} alone (it reaches "
            f"{this} itself); to go on to {this}, call {call_text('put_down', '', d)} first",
        )
    if method == "pick_up":
        if _same(held, p):
            return Verdict.ALREADY
        if held is not None:
            raise refuse(
                f"{call_text('pick_up', this, d)} needs an empty gripper, and the robot holds {_named(held)}",
                f"call {call_text('put_down', '', d)} first, then {call_text('go_to_object', 'patch', d)} "
                f"and {call_text('pick_up', 'patch', d)}",
            )
        if not _same(state.near, p):
            raise refuse(
                f"{call_text('pick_up', this, d)} needs the robot next to {this}",
                _right_before("go_to_object", "pick_up", d),
            )
        return Verdict.MET
    if method == "push":
        if held is not None:
            raise refuse(
                f"{call_text('push', this, d)} was called with {_named(held)} in the gripper",
                f"call {call_text('put_down', '', d)} first, then {call_text('push', 'patch', d)}",
            )
        return Verdict.MET
    raise AssertionError(f"{method} is not an action")


def _reading_verdict(method: str, p: Sighting, state: State, reading: str) -> Verdict:
    """`check_action` for a reading, which needs the camera aimed at `p`, the robot next to it, or it held."""
    d, held = state.dialect, state.held
    this = _named(p)
    if reading == "aim":
        if not _same(state.aimed, p):
            raise refuse(
                f"{call_text(method, this, d)} reads whatever the camera is centred on, and it is not "
                f"centred on {this}",
                _right_before("focus_on_patch", method, d),
            )
        return Verdict.MET
    if reading == "reach":
        if not _same(state.near, p):
            raise refuse(
                f"{call_text(method, this, d)} needs the robot next to {this}",
                _right_before("go_to_object", method, d),
            )
        return Verdict.MET
    # a reading that needs the object held (measure_weight, measure_fullness, a grasp sense)
    if _same(held, p):
        return Verdict.MET
    holding = f"the robot holds {_named(held)}" if held is not None else "the robot holds nothing"
    first = f"call {call_text('put_down', '', d)} first, then " if held is not None else "call "
    raise refuse(
        f"{call_text(method, this, d)} needs {this} in the gripper, and {holding}",
        f"{first}{call_text('go_to_object', 'patch', d)} and {call_text('pick_up', 'patch', d)} before "
        f"{call_text(method, 'patch', d)}",
    )

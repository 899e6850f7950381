"""The mechanisms that catch perception, sensing and acting errors before they reach the answer.

Each is on by default, can be switched off on its own (for ablations: `--checks all,-look_again`), and
writes what it did into the answer's `checks` log, beside the trace:

- `look_again`: the first image is checked against views from other head poses (`attribot.skills.looking`);
- `look_harder`: a find that comes back empty or unsure looks closer where depth sees objects stand, and
  sets aside a detection where depth sees nothing stand (`attribot.skills.harder`; detectors that read
  pixels);
- `verify_actions`: a grasp that closed on nothing, slipped or lifted another object than the one meant
  is tried again; a distance reading is checked against the depth inside the object's box (the beam may
  have hit an edge or the wall behind);
- `remeasure`: readings are repeated and combined, each measurement with its uncertainty;
- `confidence`: a choice made by comparing measurements whose margin lies inside their uncertainty is
  measured again, and if still unsettled the answer says it cannot tell, naming both values;
- `reset`: a retry starts from the state the first try started from (the robot's pose, head and
  gripper, and the same first image).

Each mechanism is a strategy object: its class's methods are what it does at the points where it acts
(`Remeasure.readings`, `VerifyActions.tries`, `LookAgain.find`, ...), and the robot session calls them
there without asking whether the mechanism is on. Switched off, a mechanism is its `Without...`
subclass, whose methods leave everything as it is. A lab plugs in its own way of doing one with a
subclass: `Safeguards(strategies={Mechanism.REMEASURE: MyRemeasure})` from Python, or, for `attribot ask`
and `attribot eval`, registered in `STRATEGIES` and chosen by the settings' `strategies`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from typing import TYPE_CHECKING, Any, ClassVar, Literal, Protocol, TypeVar

from pydantic import BaseModel, ConfigDict

from attribot.boxes import Box
from attribot.control.base import Target
from attribot.embodiments.base import Embodiment
from attribot.errors import AttribotError, ConfigError, InputError, UnknownName, UnsupportedAction
from attribot.frame import Frame
from attribot.mechanisms import MECHANISMS, Mechanism, parse_checks
from attribot.models.base import GUESSED, Detection, Detector
from attribot.models.cache import cacheable
from attribot.priors import Priors, priors
from attribot.registry import Registry
from attribot.skills.checks import patch_named
from attribot.skills.harder import Nearer, look_harder
from attribot.skills.looking import Survey, View, ask_again, reexamine, refit
from attribot.skills.params import LOOK_HARDER, LookHarderParams
from attribot.text import comma_names

if TYPE_CHECKING:
    from attribot.skills.sighting import Sighting

__all__ = [
    "Mechanism",
    "MECHANISMS",
    "CheckEvent",
    "Safeguard",
    "LookAgain",
    "WithoutLookAgain",
    "LookHarder",
    "WithoutLookHarder",
    "VerifyActions",
    "WithoutVerifyActions",
    "Remeasure",
    "WithoutRemeasure",
    "Confidence",
    "WithoutConfidence",
    "Reset",
    "WithoutReset",
    "Safeguards",
    "STRATEGIES",
    "strategies_named",
    "parse_checks",
]

Outcome = Literal["confirmed", "caught", "unsettled"]


class CheckEvent(BaseModel):
    """One thing a mechanism did: `caught` an error, `confirmed` a result, or left it `unsettled`."""

    model_config = ConfigDict(frozen=True)

    mechanism: Mechanism
    call: str
    outcome: Outcome
    detail: str


class Safeguard:
    """One mechanism's strategy (see the module docstring); it writes what it does into `log`."""

    mechanism: ClassVar[Mechanism]
    # whether an action that came back empty (a rangefinder that read nothing) is aimed and tried again
    aims_again: ClassVar[bool] = False

    def __init__(self, log: Safeguards) -> None:
        self.log = log

    def note(self, call: str, outcome: Outcome, detail: str) -> None:
        self.log.note(self.mechanism, call, outcome, detail)


class LookAgain(Safeguard):
    """`look_again`: a find or a question checked against the image looked at again: the robot's first image
    against the views of a survey around it, any other image (a still one, a later one) a few pixels in."""

    mechanism = Mechanism.LOOK_AGAIN

    def find(
        self, detector: Detector, pixels: Frame, name: str, detections: list[Detection], survey: Survey | None
    ) -> list[Detection]:
        """The detections of `name` in `pixels` once the survey's views around it have looked again; without
        a survey, once the image has, a few pixels in (its boxes averaged). Not both: the views show every
        object anew, pixels and viewpoint, and the crops cost two more detections (and their tiles) per
        find."""
        first = len(detections)
        if survey is None:
            detections, report = reexamine(detector, pixels, name, detections)
        else:
            detections = survey.fuse(detector, name, detections)
            report = survey.reports[-1]
        changed = report.dropped or report.added or report.conflicts
        outcome: Outcome = "caught" if changed else "unsettled" if report.unconfirmed else "confirmed"
        self.note(f"find({name!r})", outcome, f"{report.describe()} ({first} -> {len(detections)})")
        return detections

    def answer(self, ask: Callable[[Frame], str], frame: Frame, question: str) -> str:
        """The answer to `question` about `frame` most of three looks give (`ask` answers one look)."""
        said, disagreed = ask_again(ask, frame)
        self.note(
            f"visual_query({question[:40]!r})",
            "caught" if disagreed else "confirmed",
            f"asked again on two crops a few pixels in: {disagreed} of 2 disagreed with the first answer",
        )
        return said

    def box(self, detector: Detector, frame: Frame, box: Box, name: str, score: float) -> tuple[Box, str]:
        """An answer's box: the object's box in its image (detected at `score`) looked at again
        (`attribot.skills.looking.refit`), and what it is, for the answer's record."""
        fused, looks = refit(detector, frame, box, name, score)
        if looks == 1:
            return box, "the detection in the image (looked at again, no other look saw it there)"
        return fused, f"the mean of {looks} looks at it in the image (its detection and crops around it)"

    def survey(self, world: Embodiment, first: View) -> Survey | None:
        """The views around the robot's first image; None for a robot that does not state where its camera
        sits."""
        try:
            body = world.body()
        except UnsupportedAction:
            return None
        return Survey.take(world, first, body)


class WithoutLookAgain(LookAgain):
    """`look_again` off: the first look stands."""

    def find(
        self, detector: Detector, pixels: Frame, name: str, detections: list[Detection], survey: Survey | None
    ) -> list[Detection]:
        return detections

    def answer(self, ask: Callable[[Frame], str], frame: Frame, question: str) -> str:
        return ask(frame)

    def box(self, detector: Detector, frame: Frame, box: Box, name: str, score: float) -> tuple[Box, str]:
        return box, "the detection in the image"

    def survey(self, world: Embodiment, first: View) -> Survey | None:
        return None


class LookHarder(Safeguard):
    """`look_harder`: a find that comes back empty or unsure looks closer (`attribot.skills.harder`), with
    the values of `params` (a subclass sets its own `LookHarderParams`)."""

    mechanism = Mechanism.LOOK_HARDER
    params: ClassVar[LookHarderParams] = LOOK_HARDER

    def find(
        self, patch: Sighting, name: str, pixels: Frame, detections: list[Detection]
    ) -> tuple[list[Detection], list[Detection]]:
        """The find's detections after looking harder, where the patch is a robot's whole image with depth
        and the detector reads pixels; and those of them it took on weaker evidence than the detector's (a
        faint box, elimination)."""
        detector = patch.perception.detector
        if not patch._whole() or patch.capture is None or not cacheable(detector):
            return detections, []
        claimed = [d for n, d in patch.named.items() if n.lower() != name.lower()]
        sought = sorted(patch.sought - {n.lower() for n in (name, *patch.named)})
        looked = look_harder(
            detector,
            pixels,
            patch.capture,
            name,
            detections,
            patch.nearer,
            claimed,
            sought,
            self.log.priors,
            self.params,
        )
        if looked is None:
            return detections, []
        harder, report = looked
        if harder:
            patch.named[name] = max(harder, key=lambda d: d.score)
        if (
            report.views
            or report.set_aside
            or report.alike
            or report.yielded
            or report.fitted
            or report.doubled
        ):
            caught = (
                report.added
                or report.set_aside
                or report.found_nearer
                or report.taken
                or report.yielded
                or report.fitted
                or report.doubled
            )
            self.note(f"find({name!r})", "caught" if caught else "unsettled", report.describe())
        return harder, report.took

    def nearer(self, drive: Nearer) -> Nearer | None:
        """How a find drives nearer to a candidate, for a robot that can drive (`drive`)."""
        return drive


class WithoutLookHarder(LookHarder):
    """`look_harder` off: a find keeps the detector's answer."""

    def find(
        self, patch: Sighting, name: str, pixels: Frame, detections: list[Detection]
    ) -> tuple[list[Detection], list[Detection]]:
        return detections, []

    def nearer(self, drive: Nearer) -> Nearer | None:
        return None


HeldCheck = Callable[[Target, Target], tuple[bool | None, str]]


class VerifyActions(Safeguard):
    """`verify_actions`: approaches and grasps are tried again when they fail, the object lifted is checked,
    a load too small to be an object is lifted again, and a distance reading is checked against depth."""

    mechanism = Mechanism.VERIFY_ACTIONS
    aims_again = True
    BEAM_TOLERANCE: ClassVar[float] = 0.06  # the beam agrees with depth within this fraction (or 4 cm)

    def tries(self, wanted: int) -> int:
        """How many times an approach or a grasp is tried, of the `wanted` a controller allows."""
        return wanted

    def on_object(
        self,
        readings: list[float],
        centre_depth: Callable[[], float | None],
        front_at: Callable[[float], float],
        call: str,
    ) -> list[float]:
        """The rangefinder's `readings` that hit the object: not farther than the depth in its middle nor
        nearer than its front (`front_at(depth)`: its width there; a bowl's rim before its inside)."""
        depth = centre_depth()
        if depth is None or not readings:
            return readings
        tol = max(0.04, self.BEAM_TOLERANCE * depth)
        front = front_at(depth)
        hits = [r for r in readings if depth - front - tol <= r <= depth + tol]
        if len(hits) < len(readings):
            self.note(
                call,
                "caught",
                f"{len(readings) - len(hits)} beam readings off the object (depth there {depth:.3f} m)",
            )
        return hits

    def held(
        self, check: HeldCheck | None, target: Target, seen_first: Target, call: str
    ) -> tuple[bool | None, str]:
        """Whether the object lifted is the one meant (`check`: the controller's look at it; None when the
        camera cannot tell or the controller cannot look), and what the look saw."""
        if check is None:
            return None, ""
        verdict, detail = check(target, seen_first)
        if verdict is True:
            self.note(call, "confirmed", detail)
        return verdict, detail

    def slipped(self, load: float, empty: bool, attempt: int, call: str) -> bool:
        """Whether a weighing (`load` newtons, the gripper `empty` or not) says the object slipped out and
        is to be lifted again (once: `attempt` 0)."""
        if (load > 0.05 and not empty) or attempt == 1:
            return False
        why = "the gripper has closed on nothing" if empty else f"no load ({load:.3f} N)"
        self.note(call, "caught", f"{why}: it slipped; lifting it again")
        return True


class WithoutVerifyActions(VerifyActions):
    """`verify_actions` off: every action is taken once, at its word."""

    aims_again = False

    def tries(self, wanted: int) -> int:
        return 1

    def on_object(
        self,
        readings: list[float],
        centre_depth: Callable[[], float | None],
        front_at: Callable[[float], float],
        call: str,
    ) -> list[float]:
        return readings

    def held(
        self, check: HeldCheck | None, target: Target, seen_first: Target, call: str
    ) -> tuple[bool | None, str]:
        return None, ""

    def slipped(self, load: float, empty: bool, attempt: int, call: str) -> bool:
        return False


class Remeasure(Safeguard):
    """`remeasure`: readings are repeated and combined, each measurement with its uncertainty."""

    mechanism = Mechanism.REMEASURE
    aims_again = True

    def readings(self, wanted: int) -> int:
        """How many readings a measurement combines, of the `wanted` its sense's record asks for."""
        return wanted

    def more(self, taken: int, settled: bool, most: int) -> bool:
        """Whether a reading that sways (the force while the arm settles) takes more samples: until its
        error is small (`settled`) or `most` are `taken`."""
        return not settled and taken < most


class WithoutRemeasure(Remeasure):
    """`remeasure` off: one reading each."""

    aims_again = False

    def readings(self, wanted: int) -> int:
        return 1

    def more(self, taken: int, settled: bool, most: int) -> bool:
        return False


Value = tuple[float, float, "Sighting"]  # a measured object's combined value, its sd, the object


class Measured(Protocol):
    """What `Confidence` reads and does in a robot session (`attribot.skills.measuring`)."""

    def last_measurement(self, patch: Sighting) -> Any: ...

    def combined(self, kind: str) -> list[Value]: ...

    def measure_again(self, measurement: Any, patch: Sighting) -> None: ...


class Confidence(Safeguard):
    """`confidence`: when a choice rests on measured values (the chosen object's is the largest or smallest
    of its kind, or lies between two) and the margin to the next one lies inside their uncertainty, both
    are measured again (up to ROUNDS times, the readings combined); still unsettled, the answer says it
    cannot tell, naming both values."""

    mechanism = Mechanism.CONFIDENCE
    ROUNDS: ClassVar[int] = 3
    Z: ClassVar[float] = 2.0  # a margin of this many standard deviations settles a comparison

    def settle(self, chosen: Sighting, session: Measured) -> str | None:
        """None when the choice of `chosen` is settled (or there is nothing to settle); otherwise the
        sentence that says it cannot tell."""
        last = session.last_measurement(chosen)
        if last is None:
            return None
        call = f"answer({chosen.label or 'patch'})"
        for round_ in range(self.ROUNDS + 1):
            values = session.combined(last.kind)
            me = next((v for v in values if v[2].same_object(chosen) or v[2] is chosen), None)
            if me is None or len(values) < 2:
                return None
            close = [
                r
                for r in _neighbours(values, me)
                if abs(r[0] - me[0]) <= self.Z * math.hypot(r[1], me[1]) and not _one_named(r[2], chosen)
            ]
            if not close:
                if round_ > 0:
                    self.note(call, "caught", "settled after measuring again")
                return None
            if round_ == self.ROUNDS:
                rival, unit = close[0], last.unit
                text = (
                    f"cannot tell {patch_named(chosen)} ({me[0]:.3f} +/- {me[1]:.3f} {unit}) from "
                    f"{patch_named(rival[2])} ({rival[0]:.3f} +/- {rival[1]:.3f} {unit}): "
                    "the difference lies inside the measurements' uncertainty"
                )
                self.note(call, "unsettled", text)
                return text
            for _value, _error, patch in [me, *close]:
                session.measure_again(last, patch)
        return None


class WithoutConfidence(Confidence):
    """`confidence` off: the program's choice stands."""

    def settle(self, chosen: Sighting, session: Measured) -> str | None:
        return None


class Restorable(Protocol):
    """A robot session that can say what state it is in (`attribot.skills.robot_core`)."""

    def snapshot(self) -> Any: ...


class Reset(Safeguard):
    """`reset`: a retry starts where the first try started."""

    mechanism = Mechanism.RESET

    def start(self, robot: Restorable) -> Any:
        """The state a retry goes back to (None: where the robot is)."""
        return robot.snapshot()

    def restored(self, try_name: str) -> None:
        self.note(try_name, "caught", "the robot was put back where the first try started")

    def not_restored(self, try_name: str) -> None:
        """A world that cannot put its robot back: the retry starts from what it sees now."""
        self.note(try_name, "unsettled", "this world cannot put the robot back")


class WithoutReset(Reset):
    """`reset` off: a retry starts where the last one ended."""

    def start(self, robot: Restorable) -> Any:
        return None

    def not_restored(self, try_name: str) -> None:
        return None


def _one_named(a: Sighting, b: Sighting) -> bool:
    """Whether two measured patches stand for one named object: boxes of one name, one of them a guess (a
    box fainter than the detector's sure score, an inference). "The orange" is one object, its sure box; a
    faint box of the name that measures the same is that orange seen again (or a doubt no answer can name:
    either way the answer is the orange), so no reason to refuse to choose between them."""
    if not a.label or a.label.lower() != b.label.lower():
        return False
    return a.evidence in GUESSED or b.evidence in GUESSED  # a found patch carries `evidence_of` its box


def _neighbours(values: list[Value], me: Value) -> list[Value]:
    """The measured objects next to `me` in order of value: the one the choice was made against."""
    ranked = sorted(values, key=lambda v: v[0])
    i = next(k for k, v in enumerate(ranked) if v is me)
    return [ranked[k] for k in (i - 1, i + 1) if 0 <= k < len(ranked)]


STRATEGIES: Registry[type[Safeguard]] = Registry("safeguard strategy")
"""A lab's strategies by name, for the runs it does not build in Python (`attribot ask`, `attribot eval`):
a plug-in module registers a subclass of a mechanism's class (`STRATEGIES.register("two")(TwoReadings)`), and
the settings' `strategies` (`--strategies two`) put it in place of its mechanism's own."""


def strategies_named(names: str) -> dict[Mechanism, type[Safeguard]]:
    """The registered strategies `names` (comma-separated) chooses, by the mechanism each acts for; two for
    one mechanism are refused."""
    chosen: dict[Mechanism, type[Safeguard]] = {}
    for name in comma_names(names):
        if name not in STRATEGIES:
            raise UnknownName(
                f"unknown safeguard strategy {name!r}",
                "register it with attribot.skills.safeguards.STRATEGIES in a module named in "
                "ATTRIBOT_PLUGINS "
                f"(registered: {', '.join(STRATEGIES.names()) or 'none'})",
            )
        strategy = STRATEGIES.get(name)
        mechanism = getattr(strategy, "mechanism", None)
        if mechanism is None:
            raise InputError(
                f"the strategy {name!r} acts for no mechanism",
                "register a subclass of LookAgain, LookHarder, VerifyActions, Remeasure, Confidence or Reset",
            )
        if mechanism in chosen:
            raise InputError(
                f"two strategies for {mechanism}: {chosen[mechanism].__name__} and {name}",
                f"choose one strategy for {mechanism}",
            )
        chosen[mechanism] = strategy
    return chosen


S = TypeVar("S", bound=Safeguard)
_OFF: dict[type[Safeguard], type[Safeguard]] = {
    LookAgain: WithoutLookAgain,
    LookHarder: WithoutLookHarder,
    VerifyActions: WithoutVerifyActions,
    Remeasure: WithoutRemeasure,
    Confidence: WithoutConfidence,
    Reset: WithoutReset,
}


class Safeguards:
    """The mechanisms of one session as strategies (on: the mechanism's class or the one `strategies` plugs
    in for it; off: its `Without...` class), and the log of what they did."""

    def __init__(
        self,
        enabled: str | Iterable[str] = MECHANISMS,
        strategies: Mapping[Mechanism, type[Safeguard]] | None = None,
        table: Priors | None = None,
    ) -> None:
        on = frozenset(parse_checks(enabled if isinstance(enabled, str) else list(enabled)))
        self.events: list[CheckEvent] = []
        # what the mechanisms know of everyday things (sizes, heights, places, colours): their own table,
        # never the simulator's catalog; scaled for an ablation (`Settings.priors_scale`)
        self.priors: Priors = table if table is not None else priors()
        plugged = dict(strategies or {})
        self.look_again = self._strategy(LookAgain, on, plugged)
        self.look_harder = self._strategy(LookHarder, on, plugged)
        self.verify_actions = self._strategy(VerifyActions, on, plugged)
        self.remeasure = self._strategy(Remeasure, on, plugged)
        self.confidence = self._strategy(Confidence, on, plugged)
        self.reset = self._strategy(Reset, on, plugged)
        if plugged:
            raise InputError(
                f"no mechanism named {', '.join(map(str, plugged))} to plug a strategy in for",
                f"plug strategies in for: {', '.join(MECHANISMS)}",
            )

    def _strategy(
        self, kind: type[S], on: frozenset[Mechanism], plugged: dict[Mechanism, type[Safeguard]]
    ) -> S:
        chosen = plugged.pop(kind.mechanism, kind)
        if not (isinstance(chosen, type) and issubclass(chosen, kind)):
            raise InputError(
                f"the strategy plugged in for {kind.mechanism} is {chosen!r}, not a {kind.__name__}",
                f"subclass attribot.skills.safeguards.{kind.__name__} and override what it does",
            )
        if kind.mechanism not in on:
            chosen = _OFF[kind]
        try:
            return chosen(self)  # type: ignore[return-value]  # _OFF maps each kind to its own subclass
        except AttribotError:
            raise
        except Exception as exc:  # noqa: BLE001 (a plug-in's constructor: told in one line, not a traceback)
            told = " ".join(f"{type(exc).__name__}: {exc}".split())
            raise ConfigError(
                f"the {kind.mechanism} strategy {chosen.__name__} failed as it was made: {told[:300]}",
                "fix the strategy's constructor, or choose another with --strategies",
            ) from None

    def aims_again(self) -> bool:
        """Whether an action that came back empty is aimed and tried again (`verify_actions` or
        `remeasure`)."""
        return self.verify_actions.aims_again or self.remeasure.aims_again

    def note(self, mechanism: Mechanism, call: str, outcome: Outcome, detail: str) -> None:
        self.events.append(CheckEvent(mechanism=mechanism, call=call, outcome=outcome, detail=detail))

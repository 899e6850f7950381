"""The sandboxed runner with a small fake API: values and host objects both ways, the trace, structured
errors with the program's line, the static check, and a runner that keeps serving after every failure."""

from __future__ import annotations

import json
import os
import signal
import textwrap
import time
from typing import ClassVar

import pytest

from attribot.errors import ConfigError, InputError, UnsupportedAction
from attribot.runner import Limits, ProgramRunner, RunError, RunResult, TraceRecord, check_program

# ---- a tiny API that declares its surface the way attribot.api does --------------------------------


class Patch:
    API_ATTRIBUTES: ClassVar[tuple[str, ...]] = ("left", "right", "name")
    API_METHODS: ClassVar[tuple[str, ...]] = ("find", "exists", "crop", "overlaps", "fail", "boom", "weird")

    def __init__(self, left: float = 0.0, right: float = 100.0, name: str = "scene") -> None:
        self.left, self.right, self.name = left, right, name
        self.secret = "host only"

    def find(self, name: str) -> list[Patch]:
        """Three patches for "cup", none otherwise."""
        if name != "cup":
            return []
        return [Patch(10.0 * i, 10.0 * i + 5.0, f"cup{i}") for i in range(3)]

    def exists(self, name: str) -> bool:
        return bool(self.find(name))

    def crop(self, left: float, right: float) -> Patch:
        return Patch(left, right, self.name + "-crop")

    def overlaps(self, other: Patch) -> bool:
        return self.left < other.right and other.left < self.right

    def fail(self) -> None:
        raise UnsupportedAction("the gripper is not available in this world", "use a world with a gripper")

    def boom(self) -> None:
        raise RuntimeError("/home/someone/attribot/secret_module.py exploded at 0x7f")

    def weird(self) -> object:
        return object()  # not something a program can hold

    def host_only(self) -> str:
        return "never callable by a program"

    def summary(self) -> dict:
        return {"name": self.name, "box": [self.left, self.right]}


class Meter:
    API_ATTRIBUTES: ClassVar[tuple[str, ...]] = ("sensors",)
    API_METHODS: ClassVar[tuple[str, ...]] = ("width", "same", "total", "pair")

    def __init__(self) -> None:
        self.sensors = ["camera", "distance"]
        self.seen: list[Patch] = []

    def width(self, patch: Patch) -> float:
        self.seen.append(patch)
        return patch.right - patch.left

    def same(self, patch: Patch) -> Patch:
        return patch

    def total(self, patches: list[Patch], scale: float = 1.0) -> float:
        return scale * sum(p.right - p.left for p in patches)

    def pair(self, patch: Patch) -> tuple[Patch, dict[str, float]]:
        return (patch, {"w": patch.right - patch.left})


LIMITS = Limits(wall_s=1.0, cpu_s=1.0, memory_mb=256, max_output_chars=1000, max_api_calls=50)


@pytest.fixture(scope="module")
def runner():
    with ProgramRunner(classes=[Patch, Meter], limits=LIMITS) as r:
        yield r


def run(runner: ProgramRunner, body: str, args=None) -> RunResult:
    scene, meter = Patch(), Meter()
    return runner.run(textwrap.dedent(body), args=[scene, meter] if args is None else args)


# ---- values and objects both ways --------------------------------------------------------------------


def test_returns_the_host_object_that_find_made(runner):
    res = run(
        runner,
        """
        def execute_command(image, meter):
            cups = image.find("cup")
            return max(cups, key=lambda c: c.left)
        """,
    )
    assert res.ok, res.error
    assert isinstance(res.value_object, Patch) and res.value_object.name == "cup2"
    assert res.value == {"type": "Patch", "name": "cup2", "box": [20.0, 25.0]}
    assert "value_object" not in json.loads(res.model_dump_json())


def test_argument_comes_back_as_the_same_host_object(runner):
    scene, meter = Patch(name="mine"), Meter()
    source = "def execute_command(image, meter):\n    return meter.same(image)\n"
    res = runner.run(source, args=[scene, meter])
    assert res.ok and res.value_object is scene


def test_list_of_objects_and_handles_inside_arguments(runner):
    scene, meter = Patch(), Meter()
    res = runner.run(
        textwrap.dedent("""
        def execute_command(image, meter):
            cups = image.find("cup")
            assert meter.same(cups[1]) is cups[1]   # one stub per host object
            return [cups[0], cups[2]], meter.total(cups, scale=2), meter.width(cups[1])
        """),
        args=[scene, meter],
    )
    assert res.ok, res.error
    objects, total, width = res.value_object
    assert [o.name for o in objects] == ["cup0", "cup2"] and total == 30.0 and width == 5.0
    assert meter.seen[0].name == "cup1"  # the host method got the host object, not a stub
    assert res.value[0][1]["name"] == "cup2"


@pytest.mark.parametrize(
    ("expr", "value"),
    [
        ("3", 3),
        ("2.5", 2.5),
        ("'left'", "left"),
        ("True", True),
        ("None", None),
        ("[1, [2, 'x']]", [1, [2, "x"]]),
        ("{'a': 1, 2: [3]}", {"a": 1, "2": [3]}),
        ("(1, 2)", [1, 2]),
        ("image.left + image.right", 100.0),
        ("meter.sensors", ["camera", "distance"]),
        ("math.sqrt(16)", 4.0),
        ("f'{image.name}:{len(image.find(\"cup\"))}'", "scene:3"),
    ],
)
def test_plain_values(runner, expr, value):
    res = run(runner, f"import math\ndef execute_command(image, meter):\n    return {expr}\n")
    assert res.ok, res.error
    assert res.value == value


def test_tuple_and_dict_results_from_the_host(runner):
    res = run(
        runner,
        """
        def execute_command(image, meter):
            p, d = meter.pair(image.crop(2, 9))
            return p.name, d["w"], p.left
        """,
    )
    assert res.ok and res.value == ["scene-crop", 7.0, 2.0]


def test_print_output_and_attribute_copies(runner):
    res = run(
        runner,
        """
        def execute_command(image, meter):
            print("sensors", meter.sensors, sep="=")
            s = meter.sensors
            s.append("force")              # a copy: the host's list is untouched
            print(image, end="")
            return meter.sensors
        """,
    )
    assert res.ok
    assert res.output == "sensors=['camera', 'distance']\nPatch(left=0.0, right=100.0, name='scene')"
    assert res.value == ["camera", "distance"]


def test_annotations_and_lambda_and_comprehensions(runner):
    res = run(
        runner,
        """
        import math
        from math import floor as fl
        def execute_command(image: ImagePatch, meter: Robot) -> ImagePatch:
            widths: list = [meter.width(c) for c in image.find("cup")]
            by_left = sorted(image.find("cup"), key=lambda c: -c.left)
            x = 3
            x **= 2
            x *= 2
            w = [1, 2]
            w[0] *= 4
            w[1:] *= 2
            return fl(math.pi), widths, [c.name for c in by_left], x, w, {k: v for k, v in enumerate("ab")}
        """,
    )
    assert res.ok, res.error
    assert res.value == [3, [5.0, 5.0, 5.0], ["cup2", "cup1", "cup0"], 18, [4, 2, 2], {"0": "a", "1": "b"}]


def test_program_may_name_its_own_variables_like_builtins(runner):
    res = run(
        runner,
        """
        def execute_command(image, meter):
            type = "cup"
            object = image.find(type)[0]
            id = object.name
            for _ in range(2):
                id = id + "!"
            return id
        """,
    )
    assert res.ok, res.error
    assert res.value == "cup0!!"


def test_entry_point_is_configurable():
    with ProgramRunner(classes=[Patch], limits=LIMITS, entry="main") as r:
        assert r.run("def main(p):\n    return p.name\n", args=[Patch(name="x")]).value == "x"
        res = r.run("def execute_command(p):\n    return 1\n", args=[Patch()])
        assert res.error.category == "syntax" and "def main" in res.error.message
        assert r.run("def f():\n    return 2\n", entry="f").value == 2


# ---- the trace -----------------------------------------------------------------------------------------


def test_trace_records_every_call_with_summaries(runner):
    res = run(
        runner,
        """
        def execute_command(image, meter):
            cups = image.find("cup")
            w = meter.width(cups[0])
            image.exists("plate")
            return w
        """,
    )
    assert res.ok
    assert [t.call for t in res.trace] == ["Patch.find", "Meter.width", "Patch.exists"]
    find, width, exists = res.trace
    assert find.args == ["cup"] and len(find.result) == 3 and find.result[0]["type"] == "Patch"
    assert width.args == [{"type": "Patch", "name": "cup0", "box": [0.0, 5.0]}] and width.result == 5.0
    assert exists.result is False
    assert [t.line for t in res.trace] == [3, 4, 5]
    assert all(isinstance(t, TraceRecord) and t.ms >= 0 for t in res.trace)
    json.dumps([t.model_dump(mode="json") for t in res.trace])  # JSON-ready


def test_trace_keyword_arguments_and_failed_calls(runner):
    res = run(
        runner,
        """
        def execute_command(image, meter):
            meter.total(image.find("cup"), scale=0.5)
            return image.fail()
        """,
    )
    assert [t.call for t in res.trace] == ["Patch.find", "Meter.total", "Patch.fail"]
    assert res.trace[1].args[-1] == {"scale": 0.5} and res.trace[1].result == 7.5
    assert res.trace[2].error and "gripper" in res.trace[2].error and res.trace[2].result is None


# ---- structured errors -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("body", "category", "line", "snippet", "words"),
    [
        (
            "def execute_command(image, meter):\n    x = 1\n    return x / 0\n",
            "runtime",
            3,
            "return x / 0",
            "ZeroDivisionError",
        ),
        (
            "def execute_command(image, meter):\n    return image.find('cup')[7]\n",
            "runtime",
            2,
            "[7]",
            "IndexError",
        ),
        (
            "def helper(p):\n    return p.label\n\ndef execute_command(image, meter):\n"
            "    return helper(image)\n",
            "runtime",
            2,
            "return p.label",
            "left, name, overlaps",
        ),
        (
            "def execute_command(image, meter):\n    raise ValueError('no cup here')\n",
            "runtime",
            2,
            "raise",
            "ValueError: no cup here",
        ),
        (
            "def execute_command(image, meter):\n    return image.host_only()\n",
            "runtime",
            2,
            "host_only",
            "has no attribute 'host_only'",
        ),
        ("def execute_command(image, meter):\n    return image.secret\n", "runtime", 2, "secret", "secret"),
        ("def execute_command(image, meter)\n    return 1\n", "syntax", 1, "def execute_command", "expected"),
        ("def execute_command(image, meter):\n  x = 1\n    return x\n", "syntax", 3, "return x", "indent"),
        ("def main(image, meter):\n    return 1\n", "syntax", None, None, "def execute_command"),
        ("\n\ndef execute_command(image, meter):\n    import os\n", "policy", 4, "import os", "import math"),
        (
            "def execute_command(image, meter):\n    return image.fail()\n",
            "api",
            2,
            "image.fail()",
            "not available in this world (use a world with a gripper)",
        ),
        (
            "def execute_command(image, meter):\n    return image.find()\n",
            "api",
            2,
            "find()",
            "Patch.find(name): missing a required argument: 'name'",
        ),
        (
            "def execute_command(image, meter):\n    return image.crop(1, 2, 3)\n",
            "api",
            2,
            "crop",
            "too many positional arguments",
        ),
        (
            "def execute_command(image, meter):\n    return image.find(len)\n",
            "api",
            2,
            "find(len)",
            "cannot pass a builtin_function_or_method",
        ),
        (
            "def execute_command(image, meter):\n    return image.weird()\n",
            "api",
            2,
            "weird",
            "cannot be passed to a program",
        ),
        (
            "def execute_command(image, meter):\n    return execute_command\n",
            "runtime",
            None,
            None,
            "returned a function",
        ),
        (
            "def execute_command(image, meter):\n    while True:\n        x = 1\n",
            "timeout",
            None,
            None,
            "longer than 1.0 s",
        ),
    ],
)
def test_errors_are_structured(runner, body, category, line, snippet, words):
    res = run(runner, body)
    assert not res.ok and res.value is None
    err = res.error
    assert isinstance(err, RunError)
    assert err.category == category, err
    assert words in err.message
    if line is not None:
        assert err.line == line
    if snippet is not None:
        assert snippet in err.snippet
    if category == "timeout":
        assert err.line in (2, 3)


def test_host_exceptions_carry_no_paths_or_tracebacks(runner):
    res = run(runner, "def execute_command(image, meter):\n    image.boom()\n")
    assert res.error.category == "api"
    assert "RuntimeError" in res.error.message and "exploded" in res.error.message
    assert "/home" not in res.error.message and "Traceback" not in res.error.message


class _Leaky:
    """A host API whose failures and results quote host objects' reprs (module paths, addresses)."""

    API_ATTRIBUTES: ClassVar[tuple[str, ...]] = ()
    API_METHODS: ClassVar[tuple[str, ...]] = ("fails", "refuses")

    def fails(self) -> None:
        raise ValueError(f"cannot use {self!r}")

    def refuses(self) -> None:
        raise UnsupportedAction(f"no way with {self!r}", "use another")


@pytest.mark.parametrize("method", ["fails", "refuses"])
def test_errors_show_no_host_object_repr(method):
    # issue 22 item 5: "<attribot.api.robot._RobotWithSensors object at 0x...>" reached the program
    with ProgramRunner(classes=[_Leaky], limits=LIMITS) as r:
        res = r.run(f"def execute_command(api):\n    return api.{method}()\n", args=[_Leaky()])
    text = res.model_dump_json()
    assert res.error is not None and "<Leaky>" in res.error.message
    assert " object at 0x" not in text and "test_runner" not in text


def test_no_host_path_in_any_error(runner):
    for body in (
        "def execute_command(image, meter):\n    return [][1]\n",
        "def execute_command(image, meter):\n    return image.nothing\n",
        "def execute_command(image, meter):\n    return int('x')\n",
    ):
        text = run(runner, body).error.model_dump_json()
        assert "attribot/" not in text and "site-packages" not in text and "File " not in text


def test_error_keeps_the_output_so_far(runner):
    res = run(runner, "def execute_command(image, meter):\n    print('step 1')\n    return 1 / 0\n")
    assert res.error.output == "step 1\n" and res.output == "step 1\n"


def test_timeout_keeps_output_and_names_the_loop_line(runner):
    body = "def execute_command(image, meter):\n    print('started')\n    while True:\n        x = 1\n"
    res = run(runner, body)
    assert res.error.category == "timeout" and res.error.output == "started\n"
    assert res.error.line in (3, 4)


# ---- the static check on its own -----------------------------------------------------------------------


def test_check_program_accepts_and_refuses():
    assert check_program("import math\ndef execute_command(image, robot):\n    return image\n") is None
    err = check_program("def execute_command(image, robot):\n    return image.__class__\n")
    assert err.category == "policy" and err.line == 2 and "'_'" in err.message
    assert check_program("def run(a):\n    return a\n", entry="run") is None
    assert check_program("x = (").category == "syntax"
    assert check_program("a" * 200, limits=Limits(max_source_chars=100)).category == "limit"
    assert check_program("def execute_command():\n    return '\\x00'\n") is None
    assert check_program("x = 1\x00").category == "syntax"


def test_rules_programs_pass_the_check():
    """The programs the offline planner writes must all be runnable (one per query family)."""
    rules = pytest.importorskip("attribot.planning.rules")
    queries = [
        "the second cup from the left",
        "the heaviest bottle",
        "the biggest box",
        "which one is closer to me, the cup or the bowl?",
    ]
    for query in queries:
        for sensors, embodied in ((("camera",), False), (("camera", "distance", "force"), True)):
            try:
                program = rules.rules_program(query, sensors=sensors, embodied=embodied)
            except InputError:
                continue
            assert check_program(program) is None, (query, program)


# ---- lifecycle -----------------------------------------------------------------------------------------


def test_no_state_passes_between_programs(runner):
    first = run(runner, "seen = [1]\ndef execute_command(image, meter):\n    return 1\n")
    assert first.ok
    res = run(runner, "def execute_command(image, meter):\n    return seen\n")
    assert res.error.category == "runtime" and "seen" in res.error.message


def test_serves_on_after_its_worker_is_killed(runner):
    worker = runner._box[0]
    assert worker is not None and worker.alive()
    os.kill(worker.proc.pid, signal.SIGKILL)
    worker.proc.wait()
    res = run(runner, "def execute_command(image, meter):\n    return image.name\n")
    assert res.ok and res.value == "scene"


def test_a_worker_that_dies_before_taking_the_program_is_replaced(runner, monkeypatch):
    worker = runner._box[0]
    os.kill(worker.proc.pid, signal.SIGKILL)
    worker.proc.wait()
    monkeypatch.setattr(worker, "alive", lambda: True)  # the runner learns it only from the pipe
    res = run(runner, "def execute_command(image, meter):\n    return image.name\n")
    assert res.ok and res.value == "scene"


def test_a_worker_waits_ready_and_each_run_gets_a_fresh_one(runner):
    before = runner._box[0].proc.pid
    assert run(runner, "def execute_command(image, meter):\n    return 0\n").ok
    after = runner._box[0].proc.pid
    assert after != before and runner._box[0].alive()


def test_close_stops_the_worker_and_refuses_runs():
    r = ProgramRunner(classes=[Patch], limits=LIMITS)
    proc = r._box[0].proc
    r.close()
    assert proc.poll() is not None
    with pytest.raises(InputError, match="closed"):
        r.run("def execute_command():\n    return 1\n")


def test_bad_configuration_and_arguments_are_clear_errors():
    class NoSurface:
        pass

    class Private:
        API_ATTRIBUTES = ()
        API_METHODS = ("_hidden",)

    with pytest.raises(ConfigError, match="API_METHODS"):
        ProgramRunner(classes=[NoSurface])
    with pytest.raises(ConfigError, match="_hidden"):
        ProgramRunner(classes=[Private])
    with pytest.raises(ConfigError, match="entry point"):
        ProgramRunner(classes=[Patch], entry="_x")
    with ProgramRunner(classes=[Patch], limits=LIMITS) as r, pytest.raises(InputError, match="Meter"):
        r.run("def execute_command(m):\n    return 1\n", args=[Meter()])


def test_the_child_imports_no_heavy_modules(runner):
    """The worker is started with -I -S: no site-packages, so neither numpy nor attribot can load."""
    res = run(runner, "def execute_command(image, meter):\n    return 1\n")
    assert res.ok
    pid = runner._box[0].proc.pid
    time.sleep(0.2)
    maps = open(f"/proc/{pid}/maps").read()
    assert "numpy" not in maps and "mujoco" not in maps and "pydantic" not in maps


class Grasping:
    """An API class whose action fails in the world (recoverable) or is misused (not)."""

    API_ATTRIBUTES: ClassVar[tuple[str, ...]] = ("name",)
    API_METHODS: ClassVar[tuple[str, ...]] = ("grasp", "misuse")

    def __init__(self) -> None:
        self.name = "robot"

    def grasp(self, k: int) -> int:
        if k % 2:
            from attribot.control.base import ControlError

            raise ControlError(f"grasp failed on {k}", "go to it again")
        return k

    def misuse(self) -> None:
        from attribot.skills.errors import PreconditionError

        raise PreconditionError("the gripper is empty", "pick something up first")


def test_a_program_catches_a_failed_action_as_ActionFailed_and_carries_on():  # noqa: N802
    source = (
        "from typing import List\n"
        "def execute_command(robot):\n"
        "    held: List[int] = []\n"
        "    for k in range(4):\n"
        "        try:\n"
        "            held.append(robot.grasp(k))\n"
        "        except ActionFailed as error:\n"
        "            print(str(error), error.args == (str(error),), isinstance(robot, Grasping))\n"
        "    return held\n"
        "if __name__ == '__main__':\n"
        "    execute_command(None)\n"
    )
    with ProgramRunner(classes=[Grasping]) as runner:
        res = runner.run(source, args=[Grasping()])
        assert res.ok, res.error
        assert res.value == [0, 2]
        assert (
            res.output
            == "grasp failed on 1 (go to it again) True True\ngrasp failed on 3 (go to it again) True True\n"
        )
        assert [t.error for t in res.trace] == [None, "grasp failed on 1 (go to it again)", None,
                                                 "grasp failed on 3 (go to it again)"]  # fmt: skip
        # not caught, a failed action is the API's error on its line; a misuse is never catchable
        bare = runner.run("def execute_command(robot):\n    return robot.grasp(1)\n", args=[Grasping()])
        assert (
            bare.error.category == "api"
            and bare.error.line == 2
            and "grasp failed on 1" in bare.error.message
        )
        misuse = (
            "def execute_command(robot):\n    try:\n        robot.misuse()\n    except ActionFailed:\n"
            "        return 'swallowed'\n"
        )
        refused = runner.run(misuse, args=[Grasping()])
        assert refused.error.category == "api" and "the gripper is empty" in refused.error.message

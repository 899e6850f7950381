"""The plug-in loader (`ATTRIBOT_PLUGINS`, issue 28): whatever a lab's module does wrong as it is imported is
a clear refusal, exit 2 with an `error:` line naming the module and what it did and a `fix:` line; never a
traceback, and never a command skipped with exit 0."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import EMPTY_SETTINGS

SENSOR = "from attribot.sensors import Sense, Sensor, register_sensor\n"


def run_with_plugin(tmp_path: Path, plugins: str, *args: str, **modules: str) -> subprocess.CompletedProcess:
    """`attribot ARGS` in a fresh process with the modules written into `tmp_path` and named in
    ATTRIBOT_PLUGINS (a plug-in changes the process it is imported into: each test gets its own)."""
    for name, source in modules.items():
        path = tmp_path / f"{name.replace('.', '/')}.py"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(source)
    env = {
        **os.environ,
        "ATTRIBOT_CONFIG": str(EMPTY_SETTINGS),
        "ATTRIBOT_PLUGINS": plugins,
        "PYTHONPATH": f"{tmp_path}:{os.environ.get('PYTHONPATH', '')}",
    }
    return subprocess.run(
        [sys.executable, "-m", "attribot.cli", *(args or ("version",))],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )


@pytest.mark.parametrize(
    ("plugins", "modules", "words"),
    [
        ("lab_raises", {"lab_raises": "raise RuntimeError('the lab is closed')\n"},
         ["lab_raises", "RuntimeError: the lab is closed", "lab_raises.py, line 1"]),
        ("lab_syntax", {"lab_syntax": "def broken(:\n    pass\n"}, ["lab_syntax", "SyntaxError", "line 1"]),
        (".relative", {}, ["'.relative', which is no module name", "relative name"]),
        ("lab/path", {}, ["'lab/path', which is no module name"]),
        ("lab_exits", {"lab_exits": "import sys\nsys.exit(0)\n"}, ["lab_exits", "called sys.exit(0)"]),
        ("lab_exits_text", {"lab_exits_text": "raise SystemExit('bye')\n"}, ["called sys.exit('bye')"]),
        ("lab_shadow", {"lab_shadow": SENSOR + "register_sensor(Sensor(name='camera', measures='x'))\n"},
         ["sensor 'camera' is registered twice", "another name"]),
        ("lab_alias", {"lab_alias": SENSOR + "register_sensor(Sensor(name='sonar', measures='x', "
                                              "aliases=('rangefinder',)))\n"},
         ["'rangefinder' is registered twice"]),
        ("lab_init", {"lab_init": SENSOR + "register_sensor(Sensor(name='probe', measures='x', "
                                            "senses=(Sense('x', 'x', method='__init__'),)))\n"},
         ["'__init__' cannot be a method's name"]),
        ("lab_bundle", {"lab_bundle": SENSOR + "register_sensor(Sensor(name='depth camera', "
                                                "measures='x'))\n"},
         ["'depth camera' names several built-in sensors"]),
        ("lab_method", {"lab_method": SENSOR + "register_sensor(Sensor(name='sonar', measures='x', "
                                                "senses=(Sense('range', 'm', method='pick_up'),)))\n"},
         ["robot.pick_up, which Robot has already"]),
        ("lab_held", {"lab_held": SENSOR + "register_sensor(Sensor(name='sonar', measures='x', "
                                            "senses=(Sense('range', 'm', method='held'),)))\n"},
         ["robot.held, which Robot has already"]),
        ("lab_imports", {"lab_imports": "import no_such_dependency\n"},
         ["the plug-in module 'lab_imports' failed", "No module named 'no_such_dependency'"]),
        ("lab_deep", {"lab_deep": "def f(n):\n    return f(n + 1)\nf(0)\n"}, ["RecursionError"]),
        ("lab_stops", {"lab_stops": "raise KeyboardInterrupt\n"}, ["lab_stops", "KeyboardInterrupt"]),
        ("lab_ok,lab_raises", {"lab_ok": "", "lab_raises": "raise ValueError('x' * 5000)\n"},
         ["lab_raises", "ValueError: xxx", "..."]),
    ],
)  # fmt: skip
def test_a_plugin_that_fails_as_it_is_imported_is_refused_clearly(tmp_path, plugins, modules, words):
    done = run_with_plugin(tmp_path, plugins, **modules)
    said = " ".join(done.stderr.split())
    assert done.returncode == 2, (done.returncode, done.stdout, done.stderr)
    assert "Traceback" not in done.stderr and "error:" in said and "fix:" in said, said
    for word in words:
        assert word in said, said
    assert done.stdout == ""  # the command did not run
    assert len(said) < 1500


def test_what_a_plugin_prints_does_not_spoil_json_output(tmp_path):
    import json

    chatty = "print('lab sensors loaded')\n"
    done = run_with_plugin(tmp_path, "lab_chatty", "backends", "--json", lab_chatty=chatty)
    assert done.returncode == 0, done.stderr
    json.loads(done.stdout)
    assert "lab sensors loaded" in done.stderr


def test_a_plugin_that_registers_a_new_sensor_still_works(tmp_path):
    done = run_with_plugin(
        tmp_path,
        " lab_fine , ",
        lab_fine=SENSOR
        + "register_sensor(Sensor(name='sonar', measures='x', senses=(Sense('range', 'm'),)))\n",
    )
    assert done.returncode == 0, done.stderr


def eval_with_plugin(
    tmp_path: Path, module: str, source: str, task: str, *flags: str, executor: str = "--workers=2"
) -> list[dict]:
    """The records of `attribot eval` on the first 2 items of `task`, pa-api, in 2 spawned workers (or as
    `executor` says), with the plug-in `module` (its `source`) named in ATTRIBOT_PLUGINS; the run folder is
    `tmp_path / "run"`."""
    out = tmp_path / "run"
    done = run_with_plugin(
        tmp_path,
        module,
        *("eval", "--suite", "paper", "--tasks", task, "--methods", "pa-api", "--limit", "2"),
        *(*flags, executor, "--out", str(out)),
        **{module: source},
    )
    assert done.returncode == 0, done.stderr
    lines = (out / "records" / f"{task}__pa-api__clean.jsonl").read_text().splitlines()
    return [json.loads(line) for line in lines]


@pytest.mark.parametrize("executor", ["--workers=2", "--executor=ray"])
def test_a_plugin_backend_serves_an_evaluation_in_its_workers(tmp_path, executor):
    """Spawned workers and Ray tasks have none of the command's imports: each job imports the plug-ins it
    names, or every item would fail with an unknown backend."""
    if executor.endswith("ray"):
        pytest.importorskip("ray", reason="the ray extra is not installed")
    lab_detector = (
        "from attribot.models.base import DETECTORS\n"
        "DETECTORS.register('lab_eyes')(lambda arg, settings: DETECTORS.get('oracle')(arg, settings))\n"
    )
    records = eval_with_plugin(
        tmp_path, "lab_eyes", lab_detector, "weight_embodied", "--detector", "lab_eyes", executor=executor
    )
    assert len(records) == 2
    assert all(r["detector"] == "lab_eyes" and r["error"] is None for r in records), records


def test_a_plugin_strategy_serves_an_evaluation_and_its_run_keeps_the_choice(tmp_path):
    lab_strategy = (
        "from attribot.skills.safeguards import STRATEGIES, Remeasure\n"
        "@STRATEGIES.register('lab_two')\n"
        "class TwoReadings(Remeasure):\n"
        "    def readings(self, wanted):\n"
        "        return 2\n"
    )
    records = eval_with_plugin(
        tmp_path, "lab_strategy", lab_strategy, "distance_embodied", "--strategies", "lab_two"
    )
    said = {c["detail"] for r in records for c in r["checks"] if c["mechanism"] == "remeasure"}
    assert len(records) == 2 and said == {"2 readings, 0 empty"}
    assert json.loads((tmp_path / "run" / "run.json").read_text())["strategies"] == "lab_two"


# ---- plug-ins failing later: in eval workers, in a strategy, in a detector (issue 49) --------------------

IN_WORKER = "import multiprocessing\nIN_WORKER = multiprocessing.parent_process() is not None\n"
ORACLE_AS = (
    "from attribot.models.base import DETECTORS\n"
    "class LabEyes:\n"
    "    def __init__(self, arg, settings):\n"
    "        self.inner = DETECTORS.get('oracle')(arg, settings)\n"
    "        self.name = 'lab_eyes'\n"
    "    def __getattr__(self, name):\n"
    "        return getattr(self.inner, name)\n"
)


def _eval_refused(tmp_path: Path, module: str, source: str, *flags: str) -> str:
    out = tmp_path / "run"
    done = run_with_plugin(
        tmp_path,
        module,
        *("eval", "--suite", "paper", "--tasks", "weight_embodied", "--methods", "pa-api", "--limit", "2"),
        *(*flags, "--out", str(out)),
        **{module: source},
    )
    said = " ".join(done.stderr.split())
    assert done.returncode == 2, (done.returncode, done.stderr[-2000:])
    assert "Traceback" not in done.stderr and "error:" in said and "fix:" in said, said[-2000:]
    assert len(said) < 1500, said
    return said


def test_a_plugin_failing_inside_eval_workers_fails_the_run_in_one_line(tmp_path):
    source = IN_WORKER + "if IN_WORKER:\n    raise RuntimeError('no lab licence on this worker')\n"
    said = _eval_refused(tmp_path, "lab_worker", source, "--workers=2")
    assert "no lab licence on this worker" in said and "lab_worker" in said


@pytest.mark.parametrize("workers", ["--workers=2", "--workers=1"])
def test_sys_exit_0_in_a_worker_is_an_error_not_success(tmp_path, workers):
    source = (
        ORACLE_AS
        + "    def detect(self, frame, queries):\n        import sys\n        sys.exit(0)\n"
        + "DETECTORS.register('lab_eyes')(LabEyes)\n"
    )
    said = _eval_refused(tmp_path, "lab_exit", source, "--detector", "lab_eyes", workers)
    assert "sys.exit(0)" in said


def test_a_strategy_whose_constructor_raises_is_a_clear_error(tmp_path):
    source = (
        "from attribot.skills.safeguards import STRATEGIES, Remeasure\n"
        "@STRATEGIES.register('lab_broken')\n"
        "class Broken(Remeasure):\n"
        "    def __init__(self, *args, **kwargs):\n"
        "        raise RuntimeError('calibration file missing')\n"
    )
    done = run_with_plugin(
        tmp_path, "lab_broken", "ask", "Which object is the heaviest?", "--strategies", "lab_broken",
        lab_broken=source,
    )  # fmt: skip
    said = " ".join((done.stdout + done.stderr).split())
    assert "Traceback" not in said and "calibration file missing" in said, said[-2000:]
    assert done.returncode != 0 or "error" in said


def test_a_detector_whose_label_is_not_text_is_a_clear_error(tmp_path):
    source = (
        ORACLE_AS
        + "    def detect(self, frame, queries):\n"
        + "        return [d.model_copy(update={'label': 42}) if hasattr(d, 'model_copy') else d\n"
        + "                for d in self.inner.detect(frame, queries)]\n"
        + "DETECTORS.register('lab_eyes')(LabEyes)\n"
    )
    done = run_with_plugin(
        tmp_path, "lab_labels", "ask", "Which object is the heaviest?", "--detector", "lab_eyes",
        lab_labels=source,
    )  # fmt: skip
    said = " ".join((done.stdout + done.stderr).split())
    assert "Traceback" not in said and "Warning" not in said, said[-2000:]
    assert "the detector 'lab_eyes' returned a detection whose label is 42" in said, said[-2000:]


def test_what_a_plugin_prints_while_it_serves_does_not_spoil_json_output(tmp_path):
    source = (
        ORACLE_AS
        + "    def detect(self, frame, queries):\n"
        + "        print('lab eyes looking at', queries)\n"
        + "        return self.inner.detect(frame, queries)\n"
        + "DETECTORS.register('lab_eyes')(LabEyes)\n"
    )
    done = run_with_plugin(
        tmp_path, "lab_loud", "ask", "Which object is the heaviest?", "--detector", "lab_eyes", "--json",
        lab_loud=source,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    assert json.loads(done.stdout)["answer"] and "lab eyes looking at" in done.stderr


def test_a_5000_character_plugins_variable_gives_a_bounded_error_line(tmp_path):
    for plugins in ("a" * 5000, "lab." + "b" * 4996, ",".join(["x"] * 2500)):
        done = run_with_plugin(tmp_path, plugins)
        assert done.returncode == 2 and "Traceback" not in done.stderr
        assert max(len(line) for line in done.stderr.splitlines()) < 600, done.stderr[:300]


def test_a_worker_that_ends_itself_with_os_exit_is_an_error(tmp_path):
    source = (
        ORACLE_AS
        + "    def detect(self, frame, queries):\n        import os\n        os._exit(0)\n"
        + "DETECTORS.register('lab_eyes')(LabEyes)\n"
    )
    said = _eval_refused(tmp_path, "lab_gone", source, "--detector", "lab_eyes", "--workers=2")
    assert "ended early" in said

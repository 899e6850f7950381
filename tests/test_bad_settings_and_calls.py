"""Configuration and Python API bad inputs (issue 28): a setting's byte that is no character, a key that no
HTTP header can carry, true or false given as a number, a secret of the wrong type, calls with arguments of
the wrong kind. Each is refused naming the problem and the fix (on the command line: exit 2, an `error:` and
a `fix:` line), a secret is never echoed, and the host keeps a bounded trace of what a program passes."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

import attribot
from attribot.cli import app
from attribot.config import SceneConfig, Settings, load_settings
from attribot.errors import AttribotError, ConfigError, InputError
from attribot.session import Scene, Watch

SECRET = "sk-live-do-not-echo-0123456789"
SMALL = SceneConfig(layout="triplet", seed=1, width=64, height=48)


def invoke(args: list[str], env: dict[str, str] | None = None):
    result = CliRunner().invoke(app, args, env=env)
    assert "Traceback" not in result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result


def refused(result, *words: str) -> str:
    said = " ".join(result.output.split())
    assert result.exit_code == 2, result.output
    assert "error:" in said and "fix:" in said, said
    for word in words:
        assert word in said, said
    return said


# ---- settings files and ATTRIBOT_* variables -------------------------------------------------------------


@pytest.mark.parametrize(
    ("content", "words"),
    [
        ("program_wall_s = true\n", ["program_wall_s", "not true or false"]),
        ("llm_max_tries = true\n", ["llm_max_tries", "not true or false"]),
        ("detector_threshold = false\n", ["detector_threshold", "not true or false"]),
        (f"llm_api_key = {len(SECRET)}\n", ["llm_api_key", "not text: int"]),
        (f'remote_token = ["{SECRET}"]\n', ["remote_token", "not text: list"]),
        (f'llm_api_key = "{SECRET} x"\n', ["llm_api_key", "visible ASCII"]),
        (f'llm_api_key = "{SECRET}é"\n', ["llm_api_key", "visible ASCII"]),
        ('llm_base_url = "ftp://example.org/v1"\n', ["llm_base_url", "http(s) URL"]),
        ('llm_base_url = "http://"\n', ["llm_base_url", "http(s) URL"]),
        ('llm_base_url = "http://127.0.0.1:99999/v1"\n', ["llm_base_url", "not a URL"]),
        ('llm_base_url = "javascript:alert(1)"\n', ["llm_base_url", "http(s) URL"]),
        (f'llm_base_url = "http://user:{SECRET}@h/v1 x"\n', ["llm_base_url", "***@"]),
        ('detector = "oracle\\u202e"\n', ["detector", "control characters (\\u202e)"]),
        ('llm_model = "gpt\\n4"\n', ["llm_model", "control characters"]),
        (f'llm_model = "{"x" * 5000}"\n', ["llm_model", "5000 characters"]),
        ('cache_dir = "a\\u0000b"\n', ["cache_dir", "control characters (\\x00)"]),
        # refused where the settings are read, not when the first query runs
        ('checks = "all,-look_agian"\n', ["checks", "unknown check", "look_again, look_harder"]),
    ],
)
def test_bad_values_in_the_settings_file_are_refused_never_echoing_a_secret(tmp_path, content, words):
    cfg = tmp_path / "attribot.toml"
    cfg.write_text(content)
    for command in (["ask", "Where is the mug?"], ["backends"]):
        said = refused(invoke(command, {"ATTRIBOT_CONFIG": str(cfg)}), *words)
        assert SECRET not in said


def test_a_huge_settings_file_is_refused_from_its_size(tmp_path):
    cfg = tmp_path / "attribot.toml"
    with cfg.open("wb") as f:
        f.truncate(300 * 1024 * 1024)
    refused(invoke(["backends"], {"ATTRIBOT_CONFIG": str(cfg)}), "holds 314,572,800 bytes")


@pytest.mark.parametrize(
    ("env", "words"),
    [
        # a byte that is no UTF-8 character, as Python reads it from the environment
        ({"ATTRIBOT_LLM_BASE_URL": "http://h\udcff.example/v1"}, ["ATTRIBOT_LLM_BASE_URL", "not UTF-8"]),
        ({"ATTRIBOT_DETECTOR": "remote:http://h\udc80/"}, ["ATTRIBOT_DETECTOR", "not UTF-8"]),
        ({"ATTRIBOT_LLM_API_KEY": SECRET + "é"}, ["ATTRIBOT_LLM_API_KEY", "visible ASCII"]),
        ({"ATTRIBOT_REMOTE_TOKEN": SECRET + "\r\nX-Evil: 1"}, ["ATTRIBOT_REMOTE_TOKEN", "control"]),
        ({"ATTRIBOT_PROGRAM_WALL_S": "true"}, ["ATTRIBOT_PROGRAM_WALL_S"]),
    ],
)
def test_bad_environment_variables_are_refused_never_echoing_a_secret(env, words, empty_settings):
    for command in (["ask", "Where is the mug?", "--planner", "llm"], ["backends", "--json"]):
        said = refused(invoke(command, env), *words)
        assert SECRET not in said


def test_an_empty_key_variable_means_no_key(empty_settings, monkeypatch):
    monkeypatch.setenv("ATTRIBOT_LLM_API_KEY", "")
    assert load_settings().llm_api_key is None


def test_secrets_are_masked_wherever_settings_are_shown(empty_settings):
    settings = load_settings(llm_api_key=SECRET, remote_token=SECRET)
    assert SECRET not in repr(settings) and SECRET not in str(settings)
    assert SECRET not in settings.model_dump_json() and SECRET not in json.dumps(settings.public_dict())
    assert settings.llm_api_key.get_secret_value() == SECRET  # where it is sent, it is whole


def test_a_key_reaches_the_endpoint_whole(httpserver, empty_settings, tmp_path):
    from conftest import serve_chat_replies

    serve_chat_replies(httpserver, ["def execute_command(image, robot):\n    return 1\n"])
    answer = attribot.ask(
        "Where is the mug?",
        Scene(SMALL),
        planner="llm",
        llm_base_url=httpserver.url_for("/v1"),
        llm_api_key=SECRET,
        llm_model="fake",
        cache_dir=tmp_path / "cache",
    )
    assert answer.attempts >= 1
    (request, _), *_ = httpserver.log
    assert request.headers["Authorization"] == f"Bearer {SECRET}"


# ---- the Python API's bad calls ---------------------------------------------------------------------------


PROGRAM = "def execute_command(image, robot):\n    return 1\n"


@pytest.mark.parametrize(
    ("call", "words"),
    [
        (lambda: attribot.ask("Where is the mug?", Scene(SMALL), "str"), "settings='str' is not"),
        (lambda: attribot.ask("Where is the mug?", Scene(SMALL), {"planner": "rules"}), "is not attribot's"),
        (lambda: attribot.ask("Where is the mug?", Scene(SMALL), watch="x"), "is not a Watch"),
        (lambda: attribot.ask("Where is the mug?", Scene(SMALL), watch=Watch(call=5)), "is not a function"),
        (lambda: attribot.ask("Where is the mug?", Scene(SMALL), save_dir=3), "save_dir must be a path"),
        (lambda: attribot.ask("Where is the mug?", Scene(SMALL), program_wall_s=True), "not true or false"),
        (lambda: attribot.ask("Where is the mug?", Scene(SMALL), llm_api_key=12345678), "not text: int"),
        (lambda: Scene(image=b"photo.png"), "must be a path"),
        (lambda: Scene(image=7), "must be a path"),
        (lambda: Scene(image="photo\x00.png"), "NUL byte"),
        (lambda: Scene(SMALL, sensors=5), "not a list of sensor names"),
        (lambda: Scene(SMALL, sensors=["camera", 5]), "not a list of sensor names"),
        (lambda: Scene(SMALL, still="no"), "not True or False"),
        (lambda: Scene(world=5), "given by its name"),
        (lambda: Scene(SMALL, controller=["servo"]), "given by its name"),
        (lambda: attribot.replay(None), "must be a path"),
        (lambda: attribot.replay(b"run"), "must be a path"),
        (lambda: attribot.ask("Where is the mug?", Scene(SMALL), save_dir=""), "save_dir is empty"),
        (lambda: attribot.run_program(PROGRAM, Scene(SMALL), query=5), "the query must be text"),
        (lambda: attribot.run_program(PROGRAM, Scene(SMALL), query="q" * 10_000), "characters long"),
        (lambda: attribot.run_program(PROGRAM, Scene(SMALL), planner=5), "the planner must be text"),
        (lambda: SceneConfig(seed="3"), "seed"),
        (lambda: SceneConfig(seed=-1), "from 0 to"),
        (lambda: SceneConfig(force_noise_std=True), "not true or false"),
        (lambda: SceneConfig(noise={"slip": True}), "not true or false"),
        (lambda: SceneConfig(layout="household\x1b[2J"), "control characters"),
        (lambda: attribot.BridgeConfig(url="tcp://h:1", timeout_s=True), "not true or false"),
        (lambda: Settings(llm_api_key=SECRET + " "), "visible ASCII"),
        (lambda: load_settings(remote_token=[SECRET]), "not text: list"),
    ],
)
def test_bad_calls_raise_an_error_that_names_the_problem(call, words, empty_settings):
    with pytest.raises(AttribotError) as raised:
        call()
    assert isinstance(raised.value, InputError | ConfigError)
    assert words in str(raised.value) and raised.value.fix
    assert SECRET not in str(raised.value) and SECRET not in repr(raised.value)


def test_config_errors_are_still_value_errors(empty_settings):
    with pytest.raises(ValueError, match="seed"):
        SceneConfig(seed=-1)
    with pytest.raises(ValueError, match="program_wall_s"):
        Settings(program_wall_s=0)


# ---- the host's trace is bounded per call and per run ------------------------------------------------------


class Taker:
    """A host object whose one method takes whatever a program passes."""

    API_ATTRIBUTES: tuple[str, ...] = ()
    API_METHODS: tuple[str, ...] = ("take",)

    def take(self, value: object) -> int:
        return 1


def _trace_chars(result) -> int:
    return sum(len(json.dumps(r.model_dump())) for r in result.trace)


def test_the_trace_keeps_a_bounded_summary_of_each_calls_arguments():
    from attribot.runner import ProgramRunner

    # 40 calls of Robot(sensors=["camera"] * 190000) grew the host by 680 MB: each call's list was kept whole
    program = (
        "def execute_command(taker):\n"
        "    for _ in range(3):\n"
        '        taker.take(["camera"] * 190000)\n'
        '    taker.take({str(k): "x" * 5000 for k in range(300)})\n'
        "    nested = []\n"
        "    for _ in range(40):\n"
        "        nested = [nested, 1]\n"
        "    taker.take(nested)\n"
        "    return 1\n"
    )
    with ProgramRunner(classes=[Taker]) as runner:
        result = runner.run(program, [Taker()])
    assert result.ok, result.error
    first = result.trace[0].args[0]
    assert len(first) <= 51 and first[-1] == "... (190000 items)" and first[0] == "camera"
    assert _trace_chars(result) < 5 * 10_000  # five records of at most about 8,000 characters each


def test_the_trace_of_one_run_is_bounded_however_many_calls_it_makes():
    from attribot.runner import ProgramRunner
    from attribot.runner.calls import TRACE_RUN_CHARS

    program = (
        "def execute_command(taker):\n"
        "    for k in range(600):\n"
        '        taker.take(["x" * 900] * 40)\n'
        "    return 1\n"
    )
    with ProgramRunner(classes=[Taker]) as runner:
        result = runner.run(program, [Taker()])
    assert result.ok, result.error
    assert len(result.trace) == 600  # every call is still recorded
    assert _trace_chars(result) < TRACE_RUN_CHARS + 600 * 200
    assert result.trace[-1].args == ["(not kept: the trace of this run is full)"]
    assert result.trace[-1].result == "(not kept: the trace of this run is full)"
    assert result.trace[-1].call == "Taker.take"


def test_a_saved_answer_with_a_long_argument_keeps_the_trace_small(tmp_path, empty_settings):
    program = tmp_path / "p.py"
    program.write_text(
        "def execute_command(image, robot):\n"
        "    for _ in range(2):\n"
        '        Robot(sensors=["camera"] * 190000)\n'
        "    return 1\n"
    )
    result = invoke(
        ["exec", str(program), "--layout", "triplet", "--width", "64", "--height", "48", "--json"]
    )
    assert result.exit_code == 0, result.output
    assert len(result.stdout) < 100_000 and "(190000 items)" in result.stdout


def test_a_password_in_a_backend_url_is_never_saved_or_shown(empty_settings):
    from attribot.eval.run import fingerprint
    from attribot.skills.perception import Perception

    settings = load_settings(
        detector=f"remote:http://lab:{SECRET}@127.0.0.1:9", llm_base_url=f"http://lab:{SECRET}@h/v1"
    )
    assert SECRET not in json.dumps(settings.public_dict())  # what a --save folder keeps
    assert SECRET not in json.dumps(fingerprint(settings))  # what an eval run keeps
    names = Perception.from_settings(settings).names()  # what every answer names
    assert names["detector"] == "remote:http://***@127.0.0.1:9" and SECRET not in json.dumps(names)

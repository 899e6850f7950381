"""Every bad input ends with exit code 2 and a message naming the problem: no traceback, nothing written."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from attribot.cli import app

_ENV_CLEAR = {k: None for k in ("ATTRIBOT_CONFIG", "ATTRIBOT_PLANNER", "ATTRIBOT_DETECTOR")}


def _invoke(args: list[str], env: dict[str, str | None] | None = None):
    result = CliRunner().invoke(app, args, env={**_ENV_CLEAR, **(env or {})})
    assert "Traceback" not in result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result


# ---- settings: the file, the environment, the flags ------------------------------------------------------


@pytest.mark.parametrize(
    ("content", "words"),
    [
        (b"planner = [", ["not valid TOML"]),
        (b"\xff\xfe = 1\n", ["not UTF-8"]),
        (b"planner = 5\n", ["setting planner = 5", "settings file"]),
        (b"foo = 5\n", ["unknown setting 'foo'"]),
        (b"llm_timeout_s = -3\n", ["llm_timeout_s", "greater than 0"]),
        (b"llm_timeout_s = nan\n", ["llm_timeout_s", "finite"]),
        (b"llm_max_tries = 0\n", ["llm_max_tries"]),
    ],
)
def test_bad_settings_file(tmp_path, content, words):
    cfg = tmp_path / "bad.toml"
    cfg.write_bytes(content)
    result = _invoke(
        ["ask", "Where is the mug?", "--save", str(tmp_path / "out")], {"ATTRIBOT_CONFIG": str(cfg)}
    )
    assert result.exit_code == 2
    for word in words:
        assert word in result.output
    assert str(cfg) in result.output
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("env", "words"),
    [
        ({"ATTRIBOT_LLM_MAX_TRIES": "abc"}, ["llm_max_tries", "ATTRIBOT_LLM_MAX_TRIES"]),
        ({"ATTRIBOT_REMOTE_TIMEOUT_S": "inf"}, ["remote_timeout_s", "ATTRIBOT_REMOTE_TIMEOUT_S"]),
        ({"ATTRIBOT_DETECTOR_THRESHOLD": "2"}, ["detector_threshold"]),
        ({"ATTRIBOT_CONFIG": "/nonexistent/attribot.toml"}, ["ATTRIBOT_CONFIG", "missing"]),
        ({"ATTRIBOT_CONFIG": "/"}, ["ATTRIBOT_CONFIG", "folder"]),
    ],
)
def test_bad_settings_environment(env, words):
    for command in (["ask", "Where is the mug?"], ["backends"]):
        result = _invoke(command, env)
        assert result.exit_code == 2
        for word in words:
            assert word in result.output

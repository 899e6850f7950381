"""`attribot backends`: configured spec, kind and availability of each role, from config file and env."""

from __future__ import annotations

import json

import pytest
from pytest_httpserver import HTTPServer
from typer.testing import CliRunner

from attribot.cli import app
from conftest import free_port


@pytest.fixture
def server():
    srv = HTTPServer(host="127.0.0.1", port=0)
    srv.start()
    yield srv
    srv.stop()


def _run(args, env):
    base = {
        k: None
        for k in (
            "ATTRIBOT_DETECTOR",
            "ATTRIBOT_VQA",
            "ATTRIBOT_LANGUAGE",
            "ATTRIBOT_PLANNER",
            "ATTRIBOT_LLM_BASE_URL",
            "ATTRIBOT_LLM_MODEL",
            "ATTRIBOT_CONFIG",
        )
    }
    return CliRunner().invoke(app, ["backends", *args], env={**base, **env})


def test_config_file_and_env_select_and_probe_each_role(server, tmp_path):
    server.expect_request("/v1/models").respond_with_json(
        {"object": "list", "data": [{"id": "vlm", "object": "model", "created": 0, "owned_by": "me"}]}
    )
    model = tmp_path / "owl"
    model.mkdir()
    (model / "config.json").write_text("{}")
    cfg = tmp_path / "attribot.toml"
    cfg.write_text(
        f'detector = "hf:{model}"\nvqa = "openai:vlm"\nlanguage = "openai:other"\nplanner = "llm"\n'
        f'llm_base_url = "{server.url_for("/v1")}"\nllm_model = "vlm"\nprompt = "paper"\n'
    )
    result = _run(["--json", "--strict"], {"ATTRIBOT_CONFIG": str(cfg), "ATTRIBOT_VQA": "openai:vlm"})
    assert result.exit_code == 0, result.output
    rows = {r["role"]: r for r in json.loads(result.output)}
    assert set(rows) == {"detector", "vqa", "language", "planner"}
    assert rows["detector"] | {"detail": ""} == {
        "role": "detector",
        "spec": f"hf:{model}",
        "kind": "hf",
        "arg": str(model),
        "registered": True,
        "available": True,
        "detail": "",
    }
    assert rows["vqa"]["available"] is True and "serves vlm" in rows["vqa"]["detail"]
    assert rows["language"]["available"] is True and "does not list other" in rows["language"]["detail"]
    assert rows["planner"]["available"] is True and rows["planner"]["arg"] == "vlm"
    assert rows["planner"]["detail"].endswith("; shows the paper prompt")
    assert len(server.log) == 3  # one /models call per endpoint user


def test_env_overrides_file_and_failures_are_reported(tmp_path):
    cfg = tmp_path / "attribot.toml"
    cfg.write_text('detector = "hf:/definitely/not/here"\n')
    env = {
        "ATTRIBOT_CONFIG": str(cfg),
        "ATTRIBOT_VQA": "openai:m",
        "ATTRIBOT_LANGUAGE": "nonsense:x",
        "ATTRIBOT_LLM_BASE_URL": f"http://127.0.0.1:{free_port()}/v1",
    }
    result = _run(["--json"], env)
    assert result.exit_code == 0, result.output
    rows = {r["role"]: r for r in json.loads(result.output)}
    assert rows["detector"]["available"] is False and "does not exist" in rows["detector"]["detail"]
    assert rows["vqa"]["available"] is False and "cannot reach" in rows["vqa"]["detail"]
    assert rows["language"]["registered"] is False and "choose one of" in rows["language"]["detail"]
    assert _run(["--json", "--strict"], env).exit_code == 1


def test_table_shows_every_role(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no ./attribot.toml: the defaults
    result = _run([], {"ATTRIBOT_DETECTOR": "hf:/nope"})
    assert result.exit_code == 0, result.output
    for word in ("detector", "vqa", "language", "planner", "hf:/nope", "no", "defaults"):
        assert word in result.output


def test_invalid_configuration_is_a_clear_error(tmp_path):
    cfg = tmp_path / "attribot.toml"
    cfg.write_text('detector_threshold = "high"\n')
    result = _run([], {"ATTRIBOT_CONFIG": str(cfg)})
    assert result.exit_code == 2
    assert "setting detector_threshold = 'high'" in result.output and str(cfg) in result.output

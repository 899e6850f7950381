"""Folders from elsewhere are a stranger's data (issue 28): a saved run replayed with `attribot exec FOLDER`
or `attribot.replay` sends no key, token or image where its own settings point, reads no file outside
itself and checks sizes before reading; run folders and datasets read by `eval` and `report` likewise.
Every refusal is exit 2 with an `error:` and a `fix:` line, no traceback, and nothing lost."""

from __future__ import annotations

import json
import os
import shutil
import socket
import threading
from pathlib import Path

import pytest
from typer.testing import CliRunner

import attribot
from attribot.cli import app
from attribot.config import SceneConfig, load_settings
from attribot.errors import AttribotError
from attribot.noise import PerceptionNoise
from attribot.planning.answer import Answer
from attribot.saved_runs import save_answer
from attribot.session import Scene, load_saved
from conftest import serve_chat_replies

KEY = "sk-never-leaves-0123456789"
TOKEN = "remote-token-never-leaves-42"
SMALL = SceneConfig(layout="triplet", seed=1, width=64, height=48)
ASKS_VQA = 'def execute_command(image, robot):\n    return image.visual_query("what is this?")\n'
FINDS = 'def execute_command(image, robot):\n    return image.find("object")[0]\n'


def saved_folder(where: Path, program: str = FINDS, **settings: object) -> Path:
    """A folder as `ask --save` writes it (answer, program, settings, run), with `settings` changed as a
    stranger would change them."""
    answer = Answer(query="q", answer="a", planner="file", backends={}, attempts=1, program=program)
    save_answer(answer, where, settings=load_settings(), scene=Scene(SMALL, sensors=["camera"]))
    if settings:
        data = json.loads((where / "settings.json").read_text())
        (where / "settings.json").write_text(json.dumps({**data, **settings}))
    return where


def exec_cli(*args: str, **env: str):
    result = CliRunner().invoke(app, ["exec", *args], env=env or None)
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


# ---- endpoints and backends come from the user's own settings ---------------------------------------------


def test_a_saved_folder_does_not_send_the_api_key_or_images_to_its_own_endpoint(
    tmp_path, httpserver, empty_settings, monkeypatch
):
    serve_chat_replies(httpserver, ["a mug"])
    folder = saved_folder(
        tmp_path / "run", ASKS_VQA, vqa="openai:gpt-4o", llm_base_url=httpserver.url_for("/v1")
    )
    monkeypatch.setenv("ATTRIBOT_LLM_API_KEY", KEY)
    said = refused(exec_cli(str(folder)), "openai:gpt-4o", "does not choose where your keys", "--trust-saved")
    assert KEY not in said and httpserver.log == []
    with pytest.raises(AttribotError, match="does not choose where your keys"):
        attribot.replay(folder)
    assert httpserver.log == []
    # the user who made the folder opts in, by a flag that names the risk
    trusted = exec_cli(str(folder), "--trust-saved-backends", "--json")
    assert trusted.exit_code == 0, trusted.output
    (request, _), *_ = httpserver.log
    assert request.headers["Authorization"] == f"Bearer {KEY}" and "image_url" in request.get_data(
        as_text=True
    )


def test_a_saved_folder_does_not_send_the_remote_token_to_its_own_model_server(
    tmp_path, httpserver, empty_settings, monkeypatch
):
    folder = saved_folder(tmp_path / "run", detector=f"remote:{httpserver.url_for('/')}")
    monkeypatch.setenv("ATTRIBOT_REMOTE_TOKEN", TOKEN)
    said = refused(exec_cli(str(folder)), "remote:http://", "ATTRIBOT_DETECTOR")
    assert TOKEN not in said and httpserver.log == []
    # a user whose own settings name that server replays with it (no flag needed: the choice is theirs)
    monkeypatch.setenv("ATTRIBOT_DETECTOR", f"remote:{httpserver.url_for('/')}")
    _, _, settings, _ = load_saved(folder)
    assert settings.detector == f"remote:{httpserver.url_for('/')}"
    # and a folder saved with a password in that URL (which it does not keep) is yours with your password
    mine = f"remote:http://lab:pw@127.0.0.1:{httpserver.port}/"
    monkeypatch.setenv("ATTRIBOT_DETECTOR", mine)
    saved = saved_folder(tmp_path / "with-password")
    assert "pw@" not in (saved / "settings.json").read_text()
    assert load_saved(saved)[2].detector == mine


@pytest.mark.parametrize(
    ("role", "spec"),
    [
        ("language", "remote:http://user:pw-in-url@127.0.0.1:9/"),
        ("detector", "hf:/etc/attribot-model"),
        ("detector", "coco:/somewhere/else"),
        ("vqa", "openai"),
    ],
)
def test_every_backend_that_reaches_a_place_is_the_users_own(tmp_path, role, spec, empty_settings):
    folder = saved_folder(tmp_path / "run", **{role: spec})
    said = refused(exec_cli(str(folder)), f"names the {role}")
    assert "pw-in-url" not in said  # a password in a URL is never shown


def test_the_folders_own_offline_choices_are_replayed_as_saved(tmp_path, empty_settings):
    folder = saved_folder(
        tmp_path / "run",
        detector="oracle?miss=0.2&seed=3",
        checks="none",
        program_wall_s=12.5,
        perception_noise={"preset": "realistic", "seed": 7},
        planner="llm",
        llm_base_url="http://127.0.0.1:9/v1",
        cache_dir="/tmp/elsewhere",
        coco_dir="/tmp/elsewhere",
    )
    _, _, settings, _ = load_saved(folder)
    assert (settings.detector, settings.checks, settings.program_wall_s) == (
        "oracle?miss=0.2&seed=3",
        (),
        12.5,
    )
    assert settings.perception_noise == PerceptionNoise(preset="realistic", seed=7)
    # what a replay does not need, and what names a place, stays the user's own
    mine = load_settings()
    assert (settings.planner, settings.llm_base_url, settings.cache_dir, settings.coco_dir) == (
        mine.planner,
        mine.llm_base_url,
        mine.cache_dir,
        mine.coco_dir,
    )


def test_a_saved_run_in_a_robots_world_does_not_drive_it_or_send_the_bridge_token(tmp_path, empty_settings):
    connections: list[object] = []
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen()
        server.settimeout(0.2)
        port = server.getsockname()[1]
        stop = threading.Event()

        def accept() -> None:
            while not stop.is_set():
                try:
                    connections.append(server.accept()[0])
                except OSError:
                    pass

        thread = threading.Thread(target=accept, daemon=True)
        thread.start()
        folder = saved_folder(tmp_path / "run")
        run = json.loads((folder / "run.json").read_text())
        run["scene"].update(world="bridge", config={"url": f"tcp://127.0.0.1:{port}"})
        (folder / "run.json").write_text(json.dumps(run))
        said = refused(
            exec_cli(str(folder), ATTRIBOT_BRIDGE_TOKEN="bridge-secret"),
            "bridge world",
            "--world bridge --bridge-url",
        )
        stop.set()
        thread.join()
    assert connections == [] and "bridge-secret" not in said


def test_a_saved_run_in_the_ai2thor_world_needs_trust(tmp_path, empty_settings, monkeypatch):
    # issue 49: its first run downloads a Unity build and executes it; no --trust-saved-backends was needed
    import attribot.embodiments.base as embodiments

    built: list[object] = []
    monkeypatch.setattr(embodiments.EMBODIMENTS, "get", lambda name, *a, **k: built.append(name))
    folder = saved_folder(tmp_path / "run")
    run = json.loads((folder / "run.json").read_text())
    run["scene"].update(world="ai2thor", config={"scene": "FloorPlan1"})
    (folder / "run.json").write_text(json.dumps(run))
    refused(exec_cli(str(folder)), "ai2thor world", "downloads a Unity build", "--trust-saved-backends")
    assert built == []
    with pytest.raises(AttribotError, match="ai2thor"):
        load_saved(folder)


def test_a_saved_run_asking_a_million_objects_is_refused_before_any_work(tmp_path, empty_settings):
    # issue 49: a saved `objects: 1000000` hung the replay
    folder = saved_folder(tmp_path / "run")
    run = json.loads((folder / "run.json").read_text())
    run["scene"]["config"]["objects"] = 1_000_000
    (folder / "run.json").write_text(json.dumps(run))
    refused(exec_cli(str(folder)), "objects", "1 to 30")


# ---- files are read only inside the folder, sizes are checked before reading ------------------------------


def _image_folder(tmp_path: Path) -> Path:
    import numpy as np
    from PIL import Image

    folder = saved_folder(tmp_path / "run")
    Image.fromarray(np.zeros((8, 8, 3), np.uint8)).save(tmp_path / "outside.png")
    run = json.loads((folder / "run.json").read_text())
    run["scene"].update(world=None, config=None, image="input.png")
    (folder / "run.json").write_text(json.dumps(run))
    return folder


@pytest.mark.parametrize("name", ["../outside.png", "{tmp}/outside.png", "link.png", "sub/../../outside.png"])
def test_a_saved_image_outside_the_folder_is_never_read(tmp_path, name, empty_settings):
    folder = _image_folder(tmp_path)
    (folder / "link.png").symlink_to(tmp_path / "outside.png")
    (folder / "sub").mkdir()
    run = json.loads((folder / "run.json").read_text())
    run["scene"]["image"] = name.format(tmp=tmp_path)
    (folder / "run.json").write_text(json.dumps(run))
    refused(exec_cli(str(folder)), "outside", "the saved image")


@pytest.mark.parametrize("name", ["program.py", "run.json", "settings.json"])
def test_a_saved_file_that_is_a_link_out_of_the_folder_is_refused(tmp_path, name, empty_settings):
    folder = saved_folder(tmp_path / "run")
    outside = tmp_path / f"outside-{name}"
    (folder / name).rename(outside)
    (folder / name).symlink_to(outside)
    refused(exec_cli(str(folder)), "a link that leads outside")


@pytest.mark.parametrize(
    ("name", "size", "words"),
    [
        ("program.py", 600 * 1024 * 1024, "holds 629,145,600 bytes"),
        ("run.json", 50 * 1024 * 1024, "holds 52,428,800 bytes"),
        ("settings.json", 50 * 1024 * 1024, "holds 52,428,800 bytes"),
    ],
)
def test_sizes_are_checked_before_reading(tmp_path, name, size, words, empty_settings):
    import tracemalloc

    folder = saved_folder(tmp_path / "run")
    with (folder / name).open("r+b") as f:  # sparse: no disk used, but 600 MB to read
        f.truncate(size)
    tracemalloc.start()
    refused(exec_cli(str(folder)), words)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 20 * 1024 * 1024  # refused from its size, never read


def test_a_fifo_in_a_saved_folder_is_refused_without_waiting(tmp_path, empty_settings):
    folder = saved_folder(tmp_path / "run")
    (folder / "program.py").unlink()
    os.mkfifo(folder / "program.py")
    refused(exec_cli(str(folder)), "FIFO")


@pytest.mark.parametrize(
    ("change", "words"),
    [
        (lambda run: "[" * 100_000 + "]" * 100_000, "nests deeper"),
        (lambda run: "[]", "not one attribot wrote"),
        (lambda run: "{}", "scene: Field required"),
        (lambda run: {**run, "scene": {**run["scene"], "sensors": "camera"}}, "scene.sensors"),
        (lambda run: {**run, "scene": {**run["scene"], "sensors": ["camera"] * 1000}}, "scene.sensors"),
        (lambda run: {**run, "scene": {**run["scene"], "still": "yes"}}, "scene.still"),
        (lambda run: {**run, "scene": {**run["scene"], "config": {"seed": "x"}}}, "seed"),
        (lambda run: {**run, "scene": {**run["scene"], "config": {"width": True}}}, "width"),
        (lambda run: {**run, "scene": {**run["scene"], "world": "mars"}}, "unknown world 'mars'"),
        (lambda run: {**run, "query": 5}, "query"),
        (lambda run: {**run, "query": "q" * 100_000}, "query"),
        (lambda run: {**run, "extra": 1}, "extra"),
        (lambda run: b"\xff\xfe{}", "not UTF-8"),
        (lambda run: "{'a': 1}", "not valid JSON"),
    ],
)
def test_a_tampered_run_json_is_refused_naming_the_problem(tmp_path, change, words, empty_settings):
    folder = saved_folder(tmp_path / "run")
    made = change(json.loads((folder / "run.json").read_text()))
    path = folder / "run.json"
    if isinstance(made, bytes):
        path.write_bytes(made)
    else:
        path.write_text(made if isinstance(made, str) else json.dumps(made))
    refused(exec_cli(str(folder)), words)
    with pytest.raises(AttribotError):
        attribot.replay(folder)


@pytest.mark.parametrize(
    ("settings", "words"),
    [
        ([], "is not a table of settings"),
        ({"program_wall_s": True}, "program_wall_s"),
        ({"program_wall_s": 1e12}, "program_wall_s"),
        ({"checks": ["all"]}, "checks"),
        ({"detector": 5}, "not a backend spec"),
        ({"detector": "oracle\u202e"}, "control characters"),
        ({"surprise": 1}, "surprise"),
        ({"llm_api_key": KEY, "remote_token": TOKEN}, None),  # secrets in a folder are never taken
    ],
)
def test_tampered_saved_settings_are_refused_or_ignored(tmp_path, settings, words, empty_settings):
    folder = saved_folder(tmp_path / "run")
    if isinstance(settings, dict):
        data = {**json.loads((folder / "settings.json").read_text()), **settings}
    else:
        data = settings
    (folder / "settings.json").write_text(json.dumps(data))
    if words is None:
        _, _, loaded, _ = load_saved(folder)
        assert loaded.llm_api_key is None and loaded.remote_token is None
        return
    said = refused(exec_cli(str(folder)), words)
    assert KEY not in said


# ---- run folders and datasets read by eval and report ---------------------------------------------------


@pytest.fixture(scope="module")
def a_run(tmp_path_factory) -> Path:
    """A small evaluation run folder (two items, the ovd method)."""
    from attribot.eval.run import EvalPlan, run_eval

    out = tmp_path_factory.mktemp("run") / "run"
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("ATTRIBOT_CONFIG", str(Path(__file__).parent / "artifacts" / "empty-settings.toml"))
        run_eval(EvalPlan(tasks=("weight_image",), methods=("ovd",), limit=2), load_settings(), out)
    return out


def _copy(run: Path, where: Path) -> Path:
    shutil.copytree(run, where, symlinks=True)
    (where / ".lock").unlink(missing_ok=True)
    return where


def report_cli(*args: str):
    result = CliRunner().invoke(app, ["report", *args])
    assert "Traceback" not in result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result


RECORDS = "records/weight_image__ovd__clean.jsonl"


def _rewrite_first_record(run: Path, **fields: object) -> None:
    path = run / RECORDS
    lines = path.read_text().splitlines()
    lines[0] = json.dumps({**json.loads(lines[0]), **fields})
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize(
    ("fields", "words"),
    [
        ({"id": "../../../../etc/passwd"}, "line 1"),
        ({"true_box": [1, 2, 3]}, "true_box"),
        ({"box": [0, 0, "nan", 1]}, "box"),
        ({"box": [30, 40, 10, 20]}, "x1 >= x0"),
        ({"task": "weight_image/../../x"}, "task"),
        ({"checks": [{}]}, "checks"),
        ({"wall_s": float("nan")}, "wall_s"),
    ],
)
def test_a_report_refuses_records_attribot_did_not_write(a_run, tmp_path, fields, words, empty_settings):
    run = _copy(a_run, tmp_path / "run")
    _rewrite_first_record(run, **fields)
    refused(report_cli(str(run)), words, "is not one attribot wrote")


def test_a_report_reads_no_image_outside_its_run_folder(a_run, tmp_path, empty_settings):
    run = _copy(a_run, tmp_path / "run")
    image = next((run / "dataset" / "images").glob("*.png"))
    shutil.copy(image, tmp_path / "private.png")
    image.unlink()
    image.symlink_to(tmp_path / "private.png")
    refused(report_cli(str(run)), "leads outside")
    assert not (run / "report.html").exists()


def _grow(path: Path, size: int) -> None:
    with path.open("r+b") as f:
        f.truncate(size)


@pytest.mark.parametrize(
    ("make", "resume_refused"),
    [
        (lambda run: os.mkfifo(run / "records" / "x__y__z.jsonl"), False),  # not a file this run reads
        (lambda run: (run / "run.json").write_text("[" * 100_000), True),
        (lambda run: (run / "run.json").write_text("[1, 2]"), True),
        (lambda run: _grow(run / RECORDS, 400 * 1024 * 1024), True),
        (lambda run: (run / RECORDS).write_text("not a record\n" + (run / RECORDS).read_text()), True),
    ],
    ids=["fifo", "deep run.json", "run.json not a table", "huge records", "garbage line"],
)
def test_a_report_and_a_resumed_run_refuse_a_broken_run_folder(
    a_run, tmp_path, make, resume_refused, empty_settings
):
    from attribot.eval.run import EvalPlan, run_eval

    run = _copy(a_run, tmp_path / "run")
    make(run)
    refused(report_cli(str(run)))
    plan = EvalPlan(tasks=("weight_image",), methods=("ovd",), limit=2)
    if resume_refused:
        with pytest.raises(AttribotError):
            run_eval(plan, load_settings(), run)
    else:
        assert run_eval(plan, load_settings(), run).skipped == 2


def test_the_reports_numbers_block_cannot_be_ended_by_a_records_text(a_run, tmp_path, empty_settings):
    run = _copy(a_run, tmp_path / "run")
    _rewrite_first_record(run, status="not run", right=False, error="</script><!--<script>alert(1)</script>")
    assert report_cli(str(run)).exit_code == 0
    page = (run / "report.html").read_text()
    block = page[page.index('<script type="application/json" id="summary">') :]
    block = block[len('<script type="application/json" id="summary">') : block.index("</script>")]
    assert "<" not in block and "alert(1)" in block


def test_a_dataset_whose_item_ids_are_paths_writes_nothing_outside_the_run(a_run, tmp_path, empty_settings):
    from attribot.eval.run import EvalPlan, run_eval

    dataset = _copy(a_run / "dataset", tmp_path / "dataset")
    lines = (dataset / "manifest.jsonl").read_text().splitlines()
    lines[0] = json.dumps({**json.loads(lines[0]), "id": "../../escaped"})
    (dataset / "manifest.jsonl").write_text("\n".join(lines) + "\n")
    with pytest.raises(AttribotError, match="line 1"):
        run_eval(EvalPlan(tasks=("weight_image",), methods=("ovd",), limit=2), load_settings(),
                 tmp_path / "out" / "run", dataset=dataset)  # fmt: skip
    assert not (tmp_path / "escaped.png").exists() and not (tmp_path / "out" / "escaped.png").exists()


def test_an_eval_on_a_full_disk_stops_cleanly_keeps_its_records_and_resumes(a_run, tmp_path, empty_settings):
    import resource
    import subprocess
    import sys

    run = _copy(a_run, tmp_path / "run")
    kept = (run / RECORDS).read_bytes()
    command = [sys.executable, "-m", "attribot.cli", "eval", "--tasks", "weight_image",
               "--methods", "ovd,vqa", "--limit", "2", "--out", str(run)]  # fmt: skip

    def no_room() -> None:  # the kernel refuses to let a file grow past 200 bytes: the first record fills it
        resource.setrlimit(resource.RLIMIT_FSIZE, (200, 200))

    full = subprocess.run(command, capture_output=True, text=True, preexec_fn=no_room, timeout=600)
    said = " ".join(full.stderr.split())
    assert full.returncode == 2 and "Traceback" not in said, said
    assert "error:" in said and "fix:" in said and "File too large" in said, said
    assert "stopped after 2 records, which are kept" in said and "resumes where it stopped" in said
    assert (run / RECORDS).read_bytes() == kept  # nothing written before is lost
    again = subprocess.run(command, capture_output=True, text=True, timeout=600)  # room again: it resumes
    assert again.returncode == 0, again.stderr
    assert "2 records written, 2 already done" in " ".join(again.stdout.split())
    assert (run / RECORDS).read_bytes() == kept
    assert [r.id for r in _records(run / "records" / "weight_image__vqa__clean.jsonl")] == [
        "weight_image-000",
        "weight_image-001",
    ]


def _records(path: Path) -> list:
    from attribot.eval.methods import Record

    return [Record.model_validate_json(line) for line in path.read_text().splitlines()]


@pytest.mark.parametrize("link", [".lock", "records/weight_image__vqa__clean.jsonl"])
def test_a_run_writes_nothing_through_a_link_out_of_its_folder(a_run, tmp_path, link, empty_settings):
    from attribot.eval.run import EvalPlan, run_eval

    run = _copy(a_run, tmp_path / "run")
    precious = tmp_path / "precious.txt"
    precious.write_text("keep me\n")
    (run / link).symlink_to(precious)
    with pytest.raises(AttribotError):
        run_eval(EvalPlan(tasks=("weight_image",), methods=("ovd", "vqa"), limit=2), load_settings(), run)
    assert precious.read_text() == "keep me\n"


def test_more_workers_than_the_machine_can_run_are_refused_before_any_work(tmp_path, empty_settings):
    from attribot.eval.run import EvalPlan, run_eval

    with pytest.raises(AttribotError, match="--workers 100000 starts more processes"):
        run_eval(EvalPlan(tasks=("weight_image",), limit=1), load_settings(), tmp_path / "run", workers=10**5)
    assert not (tmp_path / "run").exists()


def test_a_run_folder_whose_parts_are_files_is_refused_not_a_traceback(tmp_path, empty_settings):
    out = tmp_path / "run"
    out.mkdir()
    (out / "dataset").write_text("not a folder")
    done = CliRunner().invoke(
        app, ["eval", "--tasks", "weight_image", "--methods", "ovd", "--limit", "1", "--out", str(out)]
    )
    assert "Traceback" not in done.output and isinstance(done.exception, SystemExit | None)
    refused(done, "dataset", "check that path")
    assert (out / "dataset").read_text() == "not a folder"


def test_dataset_show_draws_no_image_from_outside_the_dataset(a_run, tmp_path, empty_settings):
    dataset = _copy(a_run / "dataset", tmp_path / "dataset")
    image = next((dataset / "images").glob("*.png"))
    shutil.copy(image, tmp_path / "private.png")
    image.unlink()
    image.symlink_to(tmp_path / "private.png")
    done = CliRunner().invoke(
        app, ["dataset", "show", str(dataset), image.stem, "--out", str(tmp_path / "o")]
    )
    refused(done, "leads outside")
    assert not (tmp_path / "o").exists()


def test_a_run_folders_dataset_link_does_not_lead_its_images_out(tmp_path, empty_settings):
    # issue 49: nothing attribot writes follows a link it did not make
    from attribot.eval.run import EvalPlan, run_eval

    outside = tmp_path / "outside"
    outside.mkdir()
    run = tmp_path / "run"
    run.mkdir()
    (run / "dataset").symlink_to(outside)
    plan = EvalPlan(tasks=("weight_image",), methods=("ovd",), limit=1)
    with pytest.raises(AttribotError, match="is a link"):
        run_eval(plan, load_settings(), run)
    assert list(outside.iterdir()) == []

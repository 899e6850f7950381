"""What a new user meets first (issue 21): help that shows no value type on plain flags and answers -h,
a missing image said as such, `dataset show` writing where it is asked; and the worlds and their options
coming from the registered configs (issue 19)."""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest
import typer
from typer.testing import CliRunner

from attribot.cli import app
from attribot.config import WORLD_CONFIGS
from conftest import cli


def _invoke(args: list[str]):
    return CliRunner().invoke(app, args)


@pytest.mark.parametrize(
    "args",
    [
        [],
        ["ask"],
        ["exec"],
        ["scene", "render"],
        ["scene"],
        ["dataset", "show"],
        ["eval"],
        ["bridge", "serve"],
    ],
)
def test_help_answers_dash_h_and_shows_no_type_on_plain_flags(args):
    short, long = _invoke([*args, "-h"]), _invoke([*args, "--help"])
    assert short.exit_code == long.exit_code == 0 and short.output == long.output
    assert "<bool>" not in short.output and "<list[str]>" not in short.output
    assert "-h" in short.output


def test_ask_help_lists_the_registered_worlds_and_one_copy_of_each_flag():
    text = _invoke(["ask", "-h"]).output
    words = " ".join(text.replace("│", " ").split())  # the help's table borders stand between wrapped lines
    assert f"World to ask in: {', '.join(WORLD_CONFIGS.names())}" in words
    flags = [line.split()[1] for line in text.splitlines() if line.startswith("│ --")]  # the first column
    assert len(flags) == len(set(flags)) and {
        "--seed",
        "--world",
        "--detector",
        "--planner",
        "--json",
    } <= set(flags)


def test_flags_of_settings_and_scene_fields_take_their_name_type_and_help_from_the_model():
    from attribot.cli.flags import BACKEND_FLAGS, PLANNER_FLAGS, SCENE_FLAGS
    from attribot.config import SceneConfig, Settings

    from_model = 0
    for flag in (*SCENE_FLAGS, *BACKEND_FLAGS, *PLANNER_FLAGS):
        model = Settings if flag.name in Settings.model_fields else SceneConfig
        field = model.model_fields.get(flag.name)
        if field is None or not field.description:  # a flag the CLI reads itself (--option, --world-noise)
            continue
        from_model += 1
        assert flag.option.param_decls == ("--" + flag.name.replace("_", "-"),)
        typed = field.annotation in (int, float, str) or field.annotation in (int | None, str | None)
        assert flag.annotation == (field.annotation if typed else str) | None  # --checks: text it reads
        assert flag.option.default is None
        assert flag.option.help == field.description
    described = [n for m in (Settings, SceneConfig) for n, f in m.model_fields.items() if f.description]
    assert from_model == len(described) == 23  # every described field is a flag, and only those
    text = " ".join(_invoke(["ask", "-h"]).output.replace("│", " ").split())
    assert "Detector backend spec (oracle, coco, yolov5s, hf:MODEL, remote:URL)." in text


def test_a_new_described_setting_is_a_flag_with_no_second_declaration(monkeypatch):
    # a setting is declared once: a field with a description in the settings is a flag of the commands
    # that take settings, its name, help and type the field's, and its value reaches the settings
    from typing import Annotated

    from pydantic import Field

    from attribot.cli.flags import field_flags, settings_of, with_flags
    from attribot.cli.output import Command
    from attribot.config import CommandLine, Settings

    class MoreSettings(Settings):
        extra_knob_s: Annotated[float, CommandLine("SECONDS")] = Field(
            1.5, gt=0, description="A knob added after the command was written."
        )
        quiet_knob: int = 3  # no description: no flag

    flags = field_flags(MoreSettings, "run")
    assert [f.name for f in flags][-1] == "extra_knob_s" and "quiet_knob" not in [f.name for f in flags]
    seen = {}
    one = typer.Typer()

    @one.command(cls=Command)
    @with_flags(flags)
    def run(given=None):
        seen["given"] = vars(given)

    @one.command(cls=Command)
    def other():  # a second command, so that typer keeps `run` as a subcommand
        pass

    help_text = " ".join(CliRunner().invoke(one, ["run", "--help"]).output.replace("│", " ").split())
    assert "--extra-knob-s SECONDS A knob added after the command was written." in help_text
    assert CliRunner().invoke(one, ["run", "--extra-knob-s", "2.5"]).exit_code == 0
    assert seen["given"]["extra_knob_s"] == 2.5 and seen["given"]["detector"] is None
    # and the run's settings take it from the flag like any other: the settings_of names come from the model
    monkeypatch.setattr("attribot.cli.flags.Settings", MoreSettings)
    monkeypatch.setattr("attribot.config.Settings", MoreSettings)
    settings = settings_of(SimpleNamespace(**seen["given"]))
    assert settings.extra_knob_s == 2.5 and settings.quiet_knob == 3


def test_a_missing_image_is_said_as_such_with_its_path(tmp_path, empty_settings):
    missing = tmp_path / "missing.png"
    done = _invoke(["ask", "Where is the mug?", "--image", str(missing)])  # the default detector, oracle
    assert done.exit_code == 2
    said = " ".join(done.output.split())
    assert f"no such file: '{missing}'" in said and "detector" not in said


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--world", "bridge"], "--world bridge needs --bridge-url"),
        (
            ["--world", "bridge", "--bridge-url", "tcp://h:1", "--seed", "3"],
            "--seed does not apply to --world bridge",
        ),
        (["--world", "bridge", "--bridge-url", "nowhere"], "bridge setting url (--bridge-url) = 'nowhere'"),
        (["--world", "ai2thor", "--option", "floor=7"], "--option floor does not apply to --world ai2thor"),
        (["--world", "ai2thor", "--option", "fov_deg=400"], "fov_deg (--option fov_deg=) = 400"),
        (["--world", "moon"], "--world 'moon' is not a world here"),
        (["--seed", "-4"], "seed (--seed) = -4 is not valid"),
    ],
)
def test_world_options_are_built_from_the_world_configs(args, words, empty_settings):
    done = _invoke(["ask", "Where is the mug?", *args])
    assert done.exit_code == 2 and words in " ".join(done.output.split()), done.output


def test_dataset_show_writes_where_it_is_asked_and_says_where(tmp_path):
    data = tmp_path / "data"
    built = cli("dataset", "build", "--tasks", "weight_image", "--limit", "1", "--out", str(data))
    assert built.returncode == 0, built.stderr
    item = "weight_image-000"
    here = tmp_path / "cwd"
    here.mkdir()
    default = cli("dataset", "show", str(data), item, cwd=here)
    assert default.returncode == 0, default.stderr
    assert json.loads(default.stdout)["id"] == item and list(here.iterdir()) == []  # nothing in the cwd
    assert (data / "shown" / f"{item}.png").is_file() and str(
        data / "shown" / f"{item}.png"
    ) in default.stderr
    folder = cli("dataset", "show", str(data), item, "--out", str(tmp_path / "pictures"))
    assert folder.returncode == 0 and (tmp_path / "pictures" / f"{item}.png").is_file()
    jpeg = cli("dataset", "show", str(data), item, "--out", str(tmp_path / "x.jpg"))
    assert jpeg.returncode == 2 and "the image is a PNG" in jpeg.stderr


def test_dataset_show_writes_through_no_planted_link(tmp_path):
    # issue 49: a dataset's `shown` link led the image into an outside folder, and `shown/ID.png` over a file
    data = tmp_path / "data"
    built = cli("dataset", "build", "--tasks", "weight_image", "--limit", "1", "--out", str(data))
    assert built.returncode == 0, built.stderr
    item = "weight_image-000"
    outside = tmp_path / "outside"
    outside.mkdir()
    (data / "shown").symlink_to(outside)
    through_folder = cli("dataset", "show", str(data), item)
    assert through_folder.returncode == 2 and "is a link" in through_folder.stderr
    assert list(outside.iterdir()) == [] and "Traceback" not in through_folder.stderr
    (data / "shown").unlink()
    (data / "shown").mkdir()
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    (data / "shown" / f"{item}.png").symlink_to(victim)
    through_file = cli("dataset", "show", str(data), item)
    assert through_file.returncode == 2 and "is a link" in through_file.stderr
    assert victim.read_text() == "keep me" and (data / "shown" / f"{item}.png").is_symlink()

"""`attribot scene`: render and inspect the embedded MuJoCo scenes."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from attribot.cli.flags import SCENE_FLAGS, with_flags, without
from attribot.cli.output import Command, Group, fail
from attribot.cli.worlds import scene_config, scene_world

scene_app = typer.Typer(
    cls=Group,
    help="Render and inspect the embedded MuJoCo scenes (layouts: household, arrangement, triplet).",
    no_args_is_help=True,
)


@scene_app.command("render", cls=Command)
@with_flags(without(SCENE_FLAGS, "world_noise"))
def scene_render(
    out: Path = typer.Option(..., "--out", metavar="FILE", help="Image file to write (.png or .jpg)."),
    boxes: bool = typer.Option(False, "--boxes", help="Draw the ground-truth boxes and labels."),
    given: Any = None,
) -> None:
    """Write the robot camera's view of a scene to an image file."""
    import io

    from PIL import Image

    if out.suffix.lower() not in (".png", ".jpg", ".jpeg"):
        raise fail(
            f"cannot write {str(out)!r}: the file name must end in .png or .jpg", "use e.g. --out scene.png"
        )
    from attribot.files import check_writable, write_whole

    if not out.parent.is_dir():
        raise fail(f"the folder {str(out.parent)!r} does not exist", "create it first or write elsewhere")
    if out.is_dir():
        raise fail(f"--out {str(out)!r} is a folder", "give a file name, e.g. --out scene.png")
    check_writable(out.parent, f"--out {str(out)!r}", "write the image elsewhere, e.g. --out scene.png")
    with scene_world(scene_config(given)) as world:
        frame = world.observe()
        rgb = frame.rgb
        if boxes:
            from attribot.draw import draw_boxes

            info = world.sim.scene_info(frame)
            rgb = draw_boxes(rgb, [(o.box, f"{o.category} ({o.color})") for o in info.objects if o.box])
    buf = io.BytesIO()
    Image.fromarray(rgb).save(buf, format="PNG" if out.suffix.lower() == ".png" else "JPEG")
    write_whole(out, buf.getvalue())
    typer.echo(str(out))


@scene_app.command("info", cls=Command)
@with_flags(without(SCENE_FLAGS, "profile", "world_noise"))
def scene_info(given: Any = None) -> None:
    """Print a scene's ground truth as JSON: objects (category, colour, mass, position, box) and the robot."""
    with scene_world(scene_config(given)) as world:
        info = world.scene_info()
    typer.echo(info.model_dump_json(indent=2))

"""`attribot dataset`: build an evaluation suite's items, show one."""

from __future__ import annotations

import io
from pathlib import Path

import typer

from attribot.cli.flags import LIMIT, ROOT_SEED, SUITE, TASKS, suite_tasks
from attribot.cli.output import Command, Group, console, err_console, fail, writable_folder
from attribot.cli.worlds import findable_vocabulary

dataset_app = typer.Typer(
    cls=Group,
    help="Evaluation datasets: `attribot dataset build --suite paper --out DIR`, `attribot dataset show`.",
    no_args_is_help=True,
)


@dataset_app.command("build", cls=Command)
def dataset_build(
    out: Path = typer.Option(..., "--out", help="Folder for manifest.jsonl, dataset.json and images/."),
    suite: str = SUITE,
    tasks: str | None = TASKS,
    limit: int | None = LIMIT,
    findable_by: str | None = typer.Option(
        None,
        "--findable-by",
        metavar="SPEC",
        help="Draw the embodied tasks' scenes with only objects this closed-set detector can find, as "
        "`attribot eval --detector SPEC` (or --findable-by SPEC) does, e.g. coco.",
    ),
    seed: int = ROOT_SEED,
) -> None:
    """Generate the suite's items in the embedded world and write the manifest and the rendered images."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from attribot.eval.datasets import DATASET_VERSION, build_items, item_count, write_dataset

    chosen = suite_tasks(suite, tasks)
    vocabulary = None if findable_by is None else findable_vocabulary(findable_by)
    if limit is not None and limit < 1:
        raise fail(f"--limit {limit} builds nothing", "give a limit of 1 or more, e.g. --limit 10")
    writable_folder(out, "--out")
    total = sum(item_count(task, limit) for task in chosen)
    # generation and rendering take minutes for the whole suite: say how far they are
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
        console=err_console,
    ) as bar:
        made = bar.add_task("generating items", total=total)
        items = build_items(
            chosen, limit, on_item=lambda _item: bar.advance(made), vocabulary=vocabulary, seed=seed
        )
        drawn = bar.add_task("rendering images", total=len(items))
        write_dataset(
            items,
            out,
            on_image=lambda _item: bar.advance(drawn),
            drawn_for=findable_by if vocabulary is not None else None,
        )
    within = sorted({i.task for i in items if i.vocabulary is not None})
    if within:
        console.print(
            f"{', '.join(within)}: drawn in scenes whose objects {findable_by} can all find", highlight=False
        )
    console.print(f"{len(items)} items of dataset {DATASET_VERSION} -> {out}", highlight=False)


@dataset_app.command("show", cls=Command)
def dataset_show(
    folder: Path = typer.Argument(..., help="A dataset folder (or a run folder's dataset/)."),
    item_id: str = typer.Argument(..., help="The item's id, e.g. weight_embodied-003."),
    out: Path | None = typer.Option(
        None,
        "--out",
        metavar="PATH",
        help="Where to write the image with the true box: a .png file, or a folder (default: the dataset's "
        "shown/ folder).",
    ),
) -> None:
    """Print one item as JSON and write its image with the true box drawn (the path goes to stderr)."""
    from attribot.errors import UnknownName
    from attribot.eval.datasets import read_dataset

    if (folder / "dataset" / "manifest.jsonl").is_file():
        folder = folder / "dataset"
    items = {i.id: i for i in read_dataset(folder)}
    if item_id not in items:
        raise UnknownName(
            f"no item {item_id!r} in {folder}", f"items there: {', '.join(list(items)[:8])}, ..."
        )
    item = items[item_id]
    typer.echo(item.model_dump_json(indent=2))
    if (folder / "images" / f"{item_id}.png").exists():
        from PIL import Image, ImageDraw

        from attribot.files import check_target, inside, make_folder, write_whole
        from attribot.frame import load_image

        fix = "build the dataset again with attribot dataset build"
        image = inside(folder, f"images/{item_id}.png", "the item's image", fix)  # never a file elsewhere
        target = _shown_path(out, folder, item_id)
        if out is None:  # the dataset's own shown/: never a link planted to lead the image elsewhere
            make_folder(target.parent, "the dataset's shown folder", "remove it, or give --out PATH")
        writable_folder(target.parent, "--out")
        check_target(target, "the image", "give another --out, or remove what is there")
        img = Image.fromarray(load_image(image))
        ImageDraw.Draw(img).rectangle(item.true_box, outline=(0, 200, 0), width=3)
        png = io.BytesIO()
        img.save(png, format="PNG")
        write_whole(target, png.getvalue(), "the image", "give another --out, or remove what is there")
        err_console.print(f"image with the true box -> {target}", highlight=False)


def _shown_path(out: Path | None, dataset: Path, item_id: str) -> Path:
    """Where `dataset show` writes: the file `--out` names, into the folder it names, or the dataset's
    shown/ folder; never into the current folder unasked."""
    if out is None:
        return dataset / "shown" / f"{item_id}.png"
    if out.is_dir() or not out.suffix:
        return out / f"{item_id}.png"
    if out.suffix.lower() != ".png":
        raise fail(
            f"--out {str(out)!r}: the image is a PNG",
            f"give a .png file or a folder, e.g. --out {item_id}.png",
        )
    return out

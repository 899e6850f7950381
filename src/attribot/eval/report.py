"""The report of a run: one self-contained HTML file rendered from a template, and its figures beside it.

It rebuilds the paper's Table I (embodied weight and distance; also as LaTeX to copy) and its bar figures
(location, size, weight by image; SVG, and PNG at twice the size) from the records, with the paper's
published numbers beside ours, labelled as measured with other models in another world; per-task tables
with Wilson 95% intervals; a failure breakdown by category; what the error-catching mechanisms did and the
ablation; a section per hypothesis of the paper (H1-H4) saying whether our records confirm it; and a
gallery of items (the image with the true box and each method's box, the program and the trace),
filterable to failures. The numbers are also embedded as JSON (`<script id="summary">`).
"""

from __future__ import annotations

import base64
import io
import json
from collections import Counter, defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import jinja2
from PIL import Image, ImageDraw

from attribot.eval.compare import Runs, read_runs
from attribot.eval.figures import Bar, Group, bar_figure
from attribot.eval.hypotheses import hypotheses
from attribot.eval.methods import NOISE_LEVELS, PROGRAM_METHODS, Condition, Record
from attribot.eval.stats import wilson
from attribot.eval.suite import METHODS, TASKS, paper_numbers, tagged, task_names
from attribot.eval.tables import (
    FAILURE_KINDS,
    ablation_table,
    checks_table,
    series_label,
    table_one,
    table_one_latex,
)
from attribot.files import check_target, inside, write_whole
from attribot.frame import load_image
from attribot.mechanisms import MECHANISMS
from attribot.noise import NOISE_PRESETS

__all__ = ["wilson", "summarize", "write_report", "default_out", "paper_numbers"]

T = TypeVar("T")
_REALISTIC = NOISE_PRESETS["realistic"]
NOISY_WHY = (
    f"Under the realistic preset a detection may be missed ({_REALISTIC['miss']:.0%} per frame, "
    f"{_REALISTIC['miss_view']:.0%} from a whole viewpoint), swapped for another object's box or jittered, "
    f"every VQA answer may be wrong ({_REALISTIC['wrong']:.0%}), the rangefinder and force sensor are noisy, "
    f"grasps fail ({_REALISTIC['grasp_fail']:.0%}) or slip ({_REALISTIC['slip']:.0%}) and odometry drifts: "
    "each detection and action can propagate an error (the paper's main limitation). The error-catching "
    "mechanisms (looking again, checking after acting, measuring again, confidence, retries from the start) "
    "catch what they can; the table of checks below says which caught what, and the ablation what each is "
    "worth."
)
_BOX_COLOURS = (
    "#2196f3", "#f44336", "#9c27b0", "#ff9800", "#009688", "#795548",
    "#3f51b5", "#e91e63", "#673ab7", "#cddc39", "#00bcd4", "#607d8b",
)  # fmt: skip


def _order(names: list[T], name: T) -> int:
    return names.index(name) if name in names else len(names)


def summarize(records: list[Record]) -> list[dict[str, Any]]:
    """One row per (task, method, noise, detector): items, right, accuracy, Wilson interval, failures by
    category, and the reason when the method was not run. The row's condition is read once from the name its
    records keep in `noise`: its `preset` and whether it is an `ablation` (data, for the page's JSON too);
    `series` names it, with its detector when the records hold several (detectors in the order the records
    meet them)."""
    groups: dict[tuple[str, str, str, str], list[Record]] = defaultdict(list)
    for r in records:
        groups[(r.task, r.method, r.noise, r.detector or "oracle")].append(r)
    tasks, methods = task_names(None), METHODS.names()
    detectors = list(dict.fromkeys(d for *_, d in groups))
    several = len(detectors) > 1
    rows = []

    def place(key: tuple[str, str, str, str]) -> tuple[int, int, str, int]:
        return (_order(tasks, key[0]), _order(methods, key[1]), key[2], detectors.index(key[3]))

    for (task, method, noise, detector), rs in sorted(groups.items(), key=lambda kv: place(kv[0])):
        condition = Condition.parse(noise)
        ran = [r for r in rs if r.status != "not run"]
        right = sum(r.right for r in ran)
        lo, hi = wilson(right, len(ran))
        simulated = [r.sim_s for r in ran if r.sim_s is not None]
        rows.append(
            {
                "task": task,
                "method": method,
                "noise": noise,
                "preset": condition.preset,
                "ablation": condition.ablation,
                "detector": detector,
                "series": series_label(noise, detector, several),
                "n": len(ran),
                "right": right,
                "accuracy": right / len(ran) if ran else None,
                "low": lo,
                "high": hi,
                "failures": dict(Counter(r.error_category or "wrong answer" for r in ran if not r.right)),
                "refused": sum(r.refused for r in ran),
                "wrong_guess": sum(r.status == "wrong" and r.guess for r in ran),
                "confidently_wrong": sum(r.confidently_wrong for r in ran),
                "guesses": sum(r.guess for r in ran),
                "right_refusing_guesses": sum(r.right_refusing_guesses for r in ran),
                "not_run": len(rs) - len(ran),
                "wall_s": sum(r.wall_s for r in ran) / len(ran) if ran else None,
                "sim_s": sum(simulated) / len(simulated) if simulated else None,
                "not_run_reason": next((r.error for r in rs if r.status == "not run"), None),
                "paper": paper_numbers(task, method),
            }
        )
    return rows


def answer_lines(rows: list[dict[str, Any]]) -> list[str]:
    """One line per row that ran, for the console: right of n, and the wrong answers kept apart from the
    refusals ("weight_realroom pa-api clean: 44/50 right (0.88), 5 refused, 0 wrong as a guess, 1 confidently
    wrong"); where some answers were guesses, how many would be right with guesses refused (`--guesses
    refuse` turns each into no answer: the same run's other operating point)."""
    return [
        f"{r['task']} {r['method']} {r['series']}: {r['right']}/{r['n']} right ({r['accuracy']:.2f}), "
        f"{r['refused']} refused, {r['wrong_guess']} wrong as a guess, "
        f"{r['confidently_wrong']} confidently wrong"
        + (
            f"; with its {r['guesses']} guess{'es' if r['guesses'] != 1 else ''} refused: "
            f"{r['right_refusing_guesses']}/{r['n']} right"
            if r["guesses"]
            else ""
        )
        for r in rows
        if r["accuracy"] is not None
    ]


def fmt(row: dict[str, Any] | None) -> str:
    """An accuracy with its interval and n, or why there is none."""
    if row is None:
        return "-"
    if row["accuracy"] is None:
        return "not run"
    return f"{row['accuracy']:.2f} [{row['low']:.2f}, {row['high']:.2f}] (n={row['n']})"


# ---- per task: figure and table -------------------------------------------------------------------------


def _figure_groups(task: str, rows: list[dict[str, Any]]) -> list[Group]:
    """One group per method that ran: a bar per plain noise level (ablations have their own table) and
    the paper's best published number."""
    groups = []
    for method in METHODS.names():
        ran = [r for r in rows if r["method"] == method and r["accuracy"] is not None and not r["ablation"]]
        if not ran:
            continue  # not run: no empty slot
        ran.sort(key=lambda r: _order(list(NOISE_LEVELS), r["noise"]))  # stable: detectors stay in order
        bars = [Bar(r["series"], r["accuracy"], r["low"], r["high"], r["n"]) for r in ran]
        published = [v for _, v in paper_numbers(task, method)]
        if published:
            bars.append(Bar("paper", max(published)))
        groups.append(Group(method, tuple(bars)))
    return groups


def _task_row(task: str, r: dict[str, Any]) -> dict[str, Any]:
    failures = ", ".join(f"{k}: {v}" for k, v in sorted(r["failures"].items())) or "-"
    if r["not_run"]:
        failures = f"not run: {r['not_run_reason']}"
    seconds = "-" if r["wall_s"] is None else f"{r['wall_s']:.2f}"
    if r["sim_s"] is not None:
        seconds += f" / {r['sim_s']:.1f}"
    return {
        "method": r["method"],
        "noise": r["series"],
        "key": f"{task}|{r['method']}|{r['series']}",
        "accuracy": fmt(r),
        "failures": failures,
        "seconds": seconds,
        "paper": ", ".join(f"{lbl} {v:.2f}" for lbl, v in r["paper"]) or "-",
    }


def _task_sections(rows: list[dict[str, Any]], out: Path) -> list[dict[str, Any]]:
    """Each task's figure (written beside the report as SVG and PNG), table and notes."""
    sections = []
    for task in task_names(None):
        task_rows = [r for r in rows if r["task"] == task]
        if not task_rows:
            continue
        svg, png = bar_figure(f"{task}: accuracy with Wilson 95% intervals", _figure_groups(task, task_rows))
        write_whole(out.parent / f"{out.stem}-{task}.svg", svg.encode())
        write_whole(out.parent / f"{out.stem}-{task}.png", png)
        notes = [
            f"{r['method']} ({r['series']}) differs from the paper's by more than 0.25: "
            f"{METHODS.get(r['method']).why}" + (f" {NOISY_WHY}" if r["noise"] != "clean" else "")
            for r in task_rows
            if r["accuracy"] is not None
            and r["paper"]
            and abs(r["accuracy"] - max(v for _, v in r["paper"])) > 0.25
        ]
        sections.append(
            {
                "name": task,
                "why": TASKS.get(task).why,
                "svg": svg,
                "files": (f"{out.stem}-{task}.svg", f"{out.stem}-{task}.png"),
                "rows": [_task_row(task, r) for r in task_rows],
                "notes": notes,
            }
        )
    return sections


# ---- the gallery ---------------------------------------------------------------------------------------


Who = tuple[str, str]  # (method, detector)


def _who(r: Record) -> Who:
    return (r.method, r.detector or "oracle")


@dataclass(frozen=True)
class _Legend:
    """Who drew each box in the gallery: a method, and its detector when the report sets several side by
    side; each with its colour and a key without spaces for the page's filter."""

    several: bool
    entries: tuple[Who, ...]  # in the methods' order, detectors within

    @staticmethod
    def of(records: list[Record]) -> _Legend:
        ran = {_who(r) for r in records if r.status != "not run"}
        detectors = list(dict.fromkeys(d for _, d in map(_who, records)))
        order = [(m, d) for m in METHODS.names() for d in detectors if (m, d) in ran]
        return _Legend(len(detectors) > 1, tuple(order))

    def label(self, who: Who) -> str:
        return f"{who[0]} ({who[1]})" if self.several else who[0]

    def key(self, who: Who) -> str:
        return "|".join(who) if self.several else who[0]

    def colour(self, who: Who) -> str:
        return _BOX_COLOURS[_order(list(self.entries), who) % len(_BOX_COLOURS)]

    def rows(self) -> list[tuple[str, str, str]]:
        """(key, label, colour) for the page's legend and filter."""
        return [(self.key(w), self.label(w), self.colour(w)) for w in self.entries]


def _image(path: Path | None, item_records: list[Record], legend: _Legend) -> str:
    """The item's image at full size with the true box (thick, green) and each method's box (its colour,
    named), as a JPEG data URI; "" when the run holds no image of it. A file that is no image, or one too
    large to decode, is an `InputError` (`load_image`)."""
    if path is None:
        return ""
    img = Image.fromarray(load_image(path))
    d = ImageDraw.Draw(img)
    if item_records[0].true_box:
        d.rectangle(item_records[0].true_box, outline=(0, 200, 0), width=5)
    boxed = [(legend.label(_who(r)), legend.colour(_who(r)), r.box) for r in item_records if r.box]
    for k, (name, colour, box) in enumerate(boxed):
        d.rectangle(box, outline=colour, width=2)
        # the names stacked above the box (inside it at the image's top), white on the method's colour
        y = box[1] - 19 * (len(boxed) - k)
        y = y if y >= 0 else box[1] + 2 + 19 * k
        left, top, right, bottom = d.textbbox((box[0], y), name, font_size=15)
        d.rectangle((left - 2, top - 2, right + 2, bottom + 2), fill=colour)
        d.text((box[0], y), name, fill="white", font_size=15)
    buf = io.BytesIO()
    img.save(buf, "JPEG", quality=80)
    return "data:image/jpeg;base64," + base64.b64encode(buf.getvalue()).decode()


_TRACE_LINES = 200
"""The most calls of one record's trace a gallery card shows."""


def _trace_line(call: Any) -> str:
    if not isinstance(call, dict):
        return str(call)[:100]
    args = call.get("args")
    args = ", ".join(str(a)[:40] for a in (args[:10] if isinstance(args, list) else []))
    return f"{str(call.get('call'))[:60]}({args}) -> {str(call.get('result'))[:60]}"


def _image_path(run_dirs: tuple[Path, ...], item_id: str) -> Path | None:
    """The item's image in the first run folder that holds it (runs reported together share items), never
    a file outside that folder."""
    name = f"dataset/images/{item_id}.png"
    fix = "give run folders written by attribot eval, whose files are their own"
    paths = (inside(d, name, "the item's image", fix) for d in run_dirs if (d / name).exists())
    return next(paths, None)


def _result(r: Record, legend: _Legend) -> dict[str, Any]:
    return {
        "method": legend.label(_who(r)),
        "colour": legend.colour(_who(r)),
        "status": r.status,
        "answer": r.answer[:200],
        "error": (f"{r.error_category}: " if r.error_category else "") + (r.error or "")[:300],
        "program": r.program,
        "prompt": r.prompt,
        "trace": "\n".join(_trace_line(t) for t in r.trace[:_TRACE_LINES])
        + (f"\n... ({len(r.trace)} calls)" if len(r.trace) > _TRACE_LINES else ""),
    }


def _gallery(
    records: list[Record], run_dirs: tuple[Path, ...], noise: str, legend: _Legend
) -> list[dict[str, Any]]:
    by_item: dict[str, list[Record]] = defaultdict(list)
    for record in records:
        if record.noise == noise:
            by_item[record.id].append(record)
    order = list(legend.entries)
    cards = []
    for item_id, rs in sorted(by_item.items()):
        rs.sort(key=lambda rec: _order(order, _who(rec)))
        ran = [r for r in rs if r.status != "not run"]
        cards.append(
            {
                "id": item_id,
                "query": rs[0].query,
                "image": _image(_image_path(run_dirs, item_id), ran or rs, legend),
                "failed": " ".join(legend.key(_who(r)) for r in ran if not r.right),
                "results": [_result(r, legend) for r in ran],
                "not_run": sorted({legend.label(_who(r)) for r in rs if r.status == "not run"}),
            }
        )
    return cards


# ---- the whole report ------------------------------------------------------------------------------------


def _environment() -> jinja2.Environment:
    return jinja2.Environment(
        loader=jinja2.PackageLoader("attribot.eval", "templates"),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )


def default_out(run_dirs: Sequence[Path]) -> Path:
    """Where a report goes unless told: `RUN/report.html` for one run, `FIRST/compared.html` for several
    (so that no run's own report is overwritten)."""
    return run_dirs[0] / ("report.html" if len(run_dirs) == 1 else "compared.html")


def write_report(
    run_dir: Path | Sequence[Path], out: Path | None = None, gallery_noise: str = "clean"
) -> Path:
    """Write the report of the run in `run_dir` (or of several runs side by side, see
    `attribot.eval.compare`) to `out` (default: `default_out`), its figures beside it (`<stem>-<task>.svg`
    and `.png`) and Table I as LaTeX (`<stem>-table1.tex`); returns the HTML path."""
    dirs = [run_dir] if isinstance(run_dir, Path) else list(run_dir)
    runs = read_runs(dirs)
    out = out or default_out(runs.dirs)
    out.parent.mkdir(parents=True, exist_ok=True)
    for target in (out, out.parent / f"{out.stem}-table1.tex"):  # before anything is written beside them
        check_target(target, "the report's file", "give --out a path where an HTML file can be written")
    rows = summarize(runs.records)
    latex = table_one_latex(rows, tagged("embodied"))
    write_whole(out.parent / f"{out.stem}-table1.tex", latex.encode())
    page = (
        _environment()
        .get_template("report.html.jinja")
        .render(**_page(runs, rows, out, gallery_noise), latex=latex, latex_file=f"{out.stem}-table1.tex")
    )
    write_whole(out, page.encode())
    return out


def _page(runs: Runs, rows: list[dict[str, Any]], out: Path, gallery_noise: str) -> dict[str, Any]:
    """The template's variables (but Table I's LaTeX)."""
    records = runs.records
    legend = _Legend.of(records)
    return {
        "records": len(records),
        "run_dir": ", ".join(str(d) for d in runs.dirs),
        "runs": [str(d) for d in runs.dirs],
        "settings": runs.settings,
        "compared": runs.compared,
        "table_one": table_one(rows, tagged("embodied")),
        "senses_table": table_one(rows, tagged("senses")),
        "tasks": _task_sections(rows, out),
        "failure_kinds": FAILURE_KINDS,
        "failures": [
            (r, [r["failures"].get(k, 0) for k in FAILURE_KINDS]) for r in rows if r["accuracy"] is not None
        ],
        "answers": [r for r in rows if r["accuracy"] is not None],
        "checks": checks_table(records, PROGRAM_METHODS),
        "mechanisms": MECHANISMS,
        "ablation": ablation_table(rows, fmt),
        "hypotheses": hypotheses(rows, records),
        "why": [(name, m.why) for name, m in METHODS.items()],
        "not_run": sorted({(r["method"], r["not_run_reason"]) for r in rows if r["accuracy"] is None}),
        "gallery_noise": gallery_noise,
        "gallery": _gallery(records, runs.dirs, gallery_noise, legend),
        "legend": legend.rows(),
        # inside <script>: no "<" at all, so that no "</script>" or "<!--" in a record's text can end it
        "summary": json.dumps(rows).replace("<", "\\u003c"),
    }

"""The report of a run: one self-contained HTML file (figures inlined) and PNG plots beside it.

It rebuilds the paper's Table I (embodied weight and distance) and its bar figures (location, size, weight
by image) from the records, with the paper's published numbers beside ours, labelled as measured with
other models in another world; per-task tables with Wilson 95% intervals; a failure breakdown by category;
and a gallery of items (the image with the true box and each method's box, the program and the trace),
filterable to failures. The numbers are also embedded as JSON (`<script id="summary">`).
"""

from __future__ import annotations

import base64
import html
import io
import json
import math
from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

from PIL import Image, ImageDraw

from attribot.api.safeguards import MECHANISMS
from attribot.eval.datasets import TASKS
from attribot.eval.methods import METHODS, NOISE_LEVELS, PROGRAM_METHODS, Record
from attribot.eval.run import read_records
from attribot.files import write_whole
from attribot.noise import NOISE_PRESETS

__all__ = ["wilson", "summarize", "write_report", "PAPER"]

PAPER: dict[tuple[str, str], list[tuple[str, float]]] = {
    ("location", "ovd"): [("OVD (GLIP)", 0.35)],
    ("location", "attr-api"): [("OVD+GPT-3.5", 0.60), ("OVD+GPT-4", 0.82)],
    ("size", "ovd"): [("OVD (GLIP)", 0.445), ("OVD, superlative", 0.501)],
    ("size", "attr-api"): [("OVD+GPT-3.5", 0.82), ("OVD+GPT-3.5, superlative", 0.80), ("OVD+GPT-4", 0.84)],
    ("weight_image", "ovd"): [("OVD (GLIP)", 0.42), ("OVD, superlative", 0.36)],
    ("weight_image", "vqa"): [("VQA (BLIP-2)", 0.54), ("VQA, superlative", 0.36)],
    ("weight_image", "vqa+llm"): [("VQA+GPT-3.5", 0.84), ("VQA+GPT-4", 0.93)],
    ("weight_embodied", "ovd"): [("OVD", 0.14)],
    ("weight_embodied", "vqa"): [("VQA", 0.64)],
    ("weight_embodied", "attr-api"): [("attribute API", 0.90)],
    ("weight_embodied", "vlm"): [("GPT-4o", 0.88)],
    ("weight_embodied", "pa-api"): [("perception-action API", 0.96)],
    ("distance_embodied", "ovd"): [("OVD", 0.64)],
    ("distance_embodied", "vqa"): [("VQA", 0.56)],
    ("distance_embodied", "attr-api"): [("attribute API", 0.22)],
    ("distance_embodied", "vlm"): [("GPT-4o", 0.70)],
    ("distance_embodied", "pa-api"): [("perception-action API", 0.94)],
}
"""The paper's published accuracies (reference only: GLIP, BLIP-2 and GPT models on O3 images, web images
and AI2-THOR; ours are measured with this run's backends in the embedded world)."""

WHY = {
    "ovd": "The offline oracle detector matches object names, not attributes: given a whole query it "
    "returns its best-scoring named object, so it is right only when that object happens to be the answer.",
    "vqa": "The offline oracle VQA answers templated questions from the scene's metadata and says 'unknown' "
    "to weight and distance, so its row is near zero by design; a real VQA model guesses.",
    "vqa+llm": "The offline language model reads the catalog's masses: with the items named it compares them "
    "reliably, which a real LLM does from common sense.",
    "attr-api": "Programs over the camera alone: weight from the catalog by name, distance from visual "
    "proxies (the paper's attribute API hard-coded distance from the image centre, hence its 0.22).",
    "pa-api": "Programs that measure: the rangefinder after visual servoing, the wrist force sensor after "
    "driving, grasping and lifting by perception.",
    "vlm": "An end-to-end vision-chat model; not run without a configured backend (--vqa openai:MODEL).",
}
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


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of k successes in n trials (0, 1 when n is 0).

    >>> [round(v, 3) for v in wilson(48, 50)]
    [0.865, 0.989]
    """
    if n == 0:
        return 0.0, 1.0
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def summarize(records: list[Record]) -> list[dict[str, Any]]:
    """One row per (task, method, noise): items, right, accuracy, Wilson interval, failures by category,
    and the reason when the method was not run."""
    groups: dict[tuple[str, str, str], list[Record]] = defaultdict(list)
    for r in records:
        groups[(r.task, r.method, r.noise)].append(r)
    rows = []
    for (task, method, noise), rs in sorted(
        groups.items(), key=lambda kv: (TASKS.index(kv[0][0]), METHODS.index(kv[0][1]), kv[0][2])
    ):
        ran = [r for r in rs if r.status != "not run"]
        right = sum(r.right for r in ran)
        lo, hi = wilson(right, len(ran))
        failures = Counter(r.error_category or "wrong answer" for r in ran if not r.right)
        simulated = [r.sim_s for r in ran if r.sim_s is not None]
        rows.append(
            {
                "task": task,
                "method": method,
                "noise": noise,
                "n": len(ran),
                "right": right,
                "accuracy": right / len(ran) if ran else None,
                "low": lo,
                "high": hi,
                "failures": dict(failures),
                "not_run": len(rs) - len(ran),
                "wall_s": sum(r.wall_s for r in ran) / len(ran) if ran else None,
                "sim_s": sum(simulated) / len(simulated) if simulated else None,
                "not_run_reason": next((r.error for r in rs if r.status == "not run"), None),
                "paper": PAPER.get((task, method), []),
            }
        )
    return rows


def _fmt(row: dict[str, Any]) -> str:
    if row["accuracy"] is None:
        return "not run"
    return f"{row['accuracy']:.2f} [{row['low']:.2f}, {row['high']:.2f}] (n={row['n']})"


def _bars(task: str, rows: list[dict[str, Any]]) -> bytes:
    """A grouped bar chart (PNG) of one task: ours per noise level and the paper's, per method."""
    methods = [m for m in METHODS if any(r["method"] == m for r in rows)]
    series = [*(n for n in NOISE_LEVELS if any(r["noise"] == n for r in rows)), "paper"]
    palette = [(46, 125, 50), (249, 168, 37), (30, 136, 229), (142, 36, 170), (216, 67, 21), (0, 137, 123)]
    colours = {n: palette[i % len(palette)] for i, n in enumerate(series)}
    colours["paper"] = (120, 120, 120)
    w, h, left, bottom, top = max(640, 120 + 150 * len(methods)), 360, 60, 60, 40
    img = Image.new("RGB", (w, h), "white")
    d = ImageDraw.Draw(img)
    d.text(
        (left, 10),
        f"{task}: accuracy (ours by noise level; paper: other models, another world)",
        fill="black",
    )
    plot_h = h - bottom - top
    for tick in (0.0, 0.25, 0.5, 0.75, 1.0):
        y = h - bottom - tick * plot_h
        d.line([(left, y), (w - 20, y)], fill=(220, 220, 220))
        d.text((10, y - 6), f"{tick:.2f}", fill="black")
    bar = 30
    for i, m in enumerate(methods):
        x0 = left + 20 + i * 150
        for j, s in enumerate(series):
            if s == "paper":
                values = [v for _, v in PAPER.get((task, m), [])]
                value = max(values) if values else None
            else:
                row = next((r for r in rows if r["method"] == m and r["noise"] == s), None)
                value = row["accuracy"] if row else None
            if value is None:
                continue
            x = x0 + j * (bar + 4)
            d.rectangle([x, h - bottom - value * plot_h, x + bar, h - bottom], fill=colours[s])
            d.text((x, h - bottom - value * plot_h - 14), f"{value:.2f}", fill="black")
        d.text((x0, h - bottom + 8), m, fill="black")
    for j, s in enumerate(series):
        d.rectangle([w - 300 + j * 95, h - 24, w - 288 + j * 95, h - 12], fill=colours[s])
        d.text((w - 284 + j * 95, h - 26), s, fill="black")
    buf = io.BytesIO()
    img.save(buf, "PNG")
    return buf.getvalue()


def _thumbnail(path: Path, item_records: list[Record]) -> str:
    """The item's image, half size, with the true box (green) and each method's box, as a data URI."""
    if not path.is_file():
        return ""
    img = Image.open(path).convert("RGB")
    d = ImageDraw.Draw(img)
    palette = [(33, 150, 243), (244, 67, 54), (156, 39, 176), (255, 152, 0), (0, 150, 136), (121, 85, 72)]
    first = item_records[0]
    if first.true_box:
        d.rectangle(first.true_box, outline=(0, 200, 0), width=4)
    for k, r in enumerate(item_records):
        if r.box:
            d.rectangle(r.box, outline=palette[METHODS.index(r.method) % len(palette)], width=2)
            d.text(
                (r.box[0] + 2, r.box[1] + 2 + 10 * k),
                r.method,
                fill=palette[METHODS.index(r.method) % len(palette)],
            )
    img = img.resize((img.width // 2, img.height // 2))
    buf = io.BytesIO()
    img.save(buf, "JPEG", quality=70)
    return "data:image/jpeg;base64," + base64.b64encode(buf.getvalue()).decode()


_CSS = """
body{font-family:system-ui,sans-serif;margin:24px;max-width:1200px;color:#222}
table{border-collapse:collapse;margin:8px 0 20px}td,th{border:1px solid #ccc;padding:4px 8px;font-size:13px}
th{background:#f3f3f3}.paper{color:#666}
.card{border:1px solid #ddd;margin:10px 0;padding:8px;display:flex;gap:12px}
.card.hidden{display:none}.right{color:#2e7d32}.wrong,.failed{color:#c62828}pre{font-size:11px;max-height:240px;
overflow:auto;background:#fafafa;padding:6px}.note{color:#555;font-size:13px}
"""

_JS = """
function applyFilter(){
  var only = document.getElementById('failures').checked;
  var method = document.getElementById('method').value;
  var cards = document.querySelectorAll('.card');
  var shown = 0;
  for (var i = 0; i < cards.length; i++) {
    var c = cards[i];
    var failed = (c.dataset.failed || '').split(' ');
    var failing = method === 'any' ? c.dataset.failing === '1' : failed.indexOf(method) >= 0;
    var hide = only && !failing;
    c.classList.toggle('hidden', hide);
    if (!hide) shown++;
  }
  document.getElementById('shown').textContent = shown;
}
document.getElementById('failures').addEventListener('change', applyFilter);
document.getElementById('method').addEventListener('change', applyFilter);
applyFilter();
"""


def _trace_line(call: dict[str, Any]) -> str:
    args = ", ".join(str(a)[:40] for a in call.get("args", []))
    return f"{call.get('call')}({args}) -> {str(call.get('result'))[:60]}"


def _checks_tables(records: list[Record], rows: list[dict[str, Any]]) -> list[str]:
    """What each error-catching mechanism did per task, method and noise (items where it caught an error,
    and of those how many ended right), and the ablation: accuracy with each mechanism off in turn."""
    e = html.escape
    out = [
        "<h2>What the error-catching mechanisms did</h2><p class='note'>Per cell: items where the "
        "mechanism caught something / of those, answered right; unsettled: items it left unsettled. Missed: "
        "items that failed with nothing caught.</p>"
        "<table><tr><th>task</th><th>method</th><th>noise</th>"
        + "".join(f"<th>{e(m)}</th>" for m in MECHANISMS)
        + "<th>missed</th></tr>"
    ]
    groups: dict[tuple[str, str, str], list[Record]] = defaultdict(list)
    for r in records:
        if r.method in PROGRAM_METHODS:
            groups[(r.task, r.method, r.noise)].append(r)
    for (task, method, noise), rs in sorted(groups.items()):
        cells = []
        for m in MECHANISMS:
            caught = [
                r for r in rs if any(c["mechanism"] == m and c["outcome"] == "caught" for c in r.checks)
            ]
            unsettled = sum(
                any(c["mechanism"] == m and c["outcome"] == "unsettled" for c in r.checks) for r in rs
            )
            right = sum(r.right for r in caught)
            cells.append(
                f"<td>{len(caught)} / {right}" + (f"; {unsettled} unsettled" if unsettled else "") + "</td>"
            )
        missed = sum(not r.right and not any(c["outcome"] == "caught" for c in r.checks) for r in rs)
        cells.append(f"<td>{missed} of {sum(not r.right for r in rs)} failures</td>")
        out.append(f"<tr><td>{e(task)}</td><td>{e(method)}</td><td>{e(noise)}</td>{''.join(cells)}</tr>")
    out.append("</table>")
    ablated = sorted({r["noise"] for r in rows if "-no-" in r["noise"]})
    if ablated:
        base = sorted({n.partition("-no-")[0] for n in ablated})
        columns = [*base, *ablated]
        out.append(
            "<h2>Ablation: each mechanism off in turn</h2><table><tr><th>task</th><th>method</th>"
            + "".join(f"<th>{e(c)}</th>" for c in columns)
            + "</tr>"
        )
        for task, method in sorted({(r["task"], r["method"]) for r in rows if r["noise"] in ablated}):
            cells = []
            for c in columns:
                row = next(
                    (r for r in rows if (r["task"], r["method"], r["noise"]) == (task, method, c)), None
                )
                cells.append(f"<td class='acc'>{e(_fmt(row)) if row else '-'}</td>")
            out.append(f"<tr><td>{e(task)}</td><td>{e(method)}</td>{''.join(cells)}</tr>")
        out.append("</table>")
    return out


def write_report(run_dir: Path, out: Path | None = None, gallery_noise: str = "clean") -> Path:
    """Write the report of the run in `run_dir` to `out` (default `run_dir/report.html`) and the PNG plots
    beside it; returns the HTML path."""
    records = read_records(run_dir)
    out = out or run_dir / "report.html"
    out.parent.mkdir(parents=True, exist_ok=True)
    rows = summarize(records)
    e = html.escape
    parts = [
        "<!doctype html><html><head><meta charset='utf-8'><title>attribot evaluation</title>",
        f"<style>{_CSS}</style></head><body>",
        "<h1>attribot evaluation</h1>",
        f"<p class='note'>{len(records)} records from {e(str(run_dir))}. Ours: measured in the embedded "
        "MuJoCo world with this run's backends. Paper: published numbers, measured with other models "
        "(GLIP, BLIP-2, GPT-3.5/4/4o) on other images and in another world (O3, web images, AI2-THOR): "
        "a reference, not a like-for-like comparison.</p>",
    ]
    settings = run_dir / "run.json"
    if settings.is_file():
        parts.append(f"<pre>{e(settings.read_text(encoding='utf-8'))}</pre>")
    # Table I: embodied weight and distance
    parts.append("<h2>Table I: embodied weight and distance</h2><table><tr><th>method</th>")
    embodied = ("weight_embodied", "distance_embodied")
    present = {r["noise"] for r in rows}
    levels = [n for n in NOISE_LEVELS if n in present] or ["clean"]
    for task in embodied:
        for noise in levels:
            parts.append(f"<th>{e(task)} ({noise})</th>")
        parts.append(f"<th class='paper'>{e(task)} (paper)</th>")
    parts.append("</tr>")
    for method in METHODS:
        cells = []
        any_row = False
        for task in embodied:
            for noise in levels:
                row = next(
                    (r for r in rows if (r["task"], r["method"], r["noise"]) == (task, method, noise)), None
                )
                any_row |= row is not None
                cells.append(
                    f"<td class='acc' data-key='{task}|{method}|{noise}'>{e(_fmt(row)) if row else '-'}</td>"
                )
            paper = PAPER.get((task, method), [])
            cells.append(
                f"<td class='paper'>{e(', '.join(f'{lbl} {v:.2f}' for lbl, v in paper)) or '-'}</td>"
            )
        if any_row:
            parts.append(f"<tr><td>{e(method)}</td>{''.join(cells)}</tr>")
    parts.append("</table>")
    # per task: figure and table
    for task in TASKS:
        task_rows = [r for r in rows if r["task"] == task]
        if not task_rows:
            continue
        png = _bars(task, task_rows)
        write_whole(out.parent / f"{out.stem}-{task}.png", png)
        parts.append(f"<h2>{e(task)}</h2>")
        parts.append(
            f"<img alt='{e(task)} accuracy' src='data:image/png;base64,{base64.b64encode(png).decode()}'>"
        )
        parts.append(
            "<table><tr><th>method</th><th>noise</th><th>accuracy [95% Wilson]</th><th>failures</th>"
            "<th>mean wall / sim s</th><th class='paper'>paper (other models, another world)</th></tr>"
        )
        for r in task_rows:
            failures = ", ".join(f"{k}: {v}" for k, v in sorted(r["failures"].items())) or "-"
            if r["not_run"]:
                failures = f"not run: {r['not_run_reason']}"
            published = ", ".join(f"{lbl} {v:.2f}" for lbl, v in r["paper"]) or "-"
            key = f"{task}|{r['method']}|{r['noise']}"
            seconds = "-" if r["wall_s"] is None else f"{r['wall_s']:.2f}"
            if r["sim_s"] is not None:
                seconds += f" / {r['sim_s']:.1f}"
            parts.append(
                f"<tr><td>{e(r['method'])}</td><td>{e(r['noise'])}</td><td class='acc' data-key='{key}'>"
                f"{e(_fmt(r))}</td><td>{e(failures)}</td><td>{seconds}</td>"
                f"<td class='paper'>{e(published)}</td></tr>"
            )
        parts.append("</table>")
        flagged = [
            r
            for r in task_rows
            if r["accuracy"] is not None
            and r["paper"]
            and abs(r["accuracy"] - max(v for _, v in r["paper"])) > 0.25
        ]
        for r in flagged:
            parts.append(
                f"<p class='note'>{e(r['method'])} ({e(r['noise'])}) differs from the paper's by more than "
                f"0.25: {e(WHY.get(r['method'], ''))}"
                + (f" {e(NOISY_WHY)}" if r["noise"] != "clean" else "")
                + "</p>"
            )
    # failures by category
    parts.append(
        "<h2>Failures by category</h2><table><tr><th>task</th><th>method</th><th>noise</th><th>planner</th>"
        "<th>runner</th><th>perception</th><th>action</th><th>wrong answer</th></tr>"
    )
    for r in rows:
        f = r["failures"]
        cols = "".join(
            f"<td>{f.get(k, 0)}</td>" for k in ("planner", "runner", "perception", "action", "wrong answer")
        )
        parts.append(
            f"<tr><td>{e(r['task'])}</td><td>{e(r['method'])}</td><td>{e(r['noise'])}</td>{cols}</tr>"
        )
    parts.append("</table>")
    parts += _checks_tables(records, rows)
    parts.append("<h2>Why the offline rows look as they do</h2>")
    parts += [f"<p class='note'><b>{e(m)}</b>: {e(text)}</p>" for m, text in WHY.items()]
    # gallery
    by_item: dict[str, list[Record]] = defaultdict(list)
    for record in records:
        if record.noise == gallery_noise:
            by_item[record.id].append(record)
    parts.append(
        f"<h2>Gallery ({e(gallery_noise)})</h2><p><label><input type='checkbox' id='failures'> failures only"
        "</label> <select id='method'><option value='any'>any method</option>"
        + "".join(f"<option value='{m}'>{m}</option>" for m in METHODS)
        + "</select> <span id='shown'></span> shown</p>"
    )
    for item_id, rs in sorted(by_item.items()):
        rs.sort(key=lambda rec: METHODS.index(rec.method))
        failed = " ".join(rec.method for rec in rs if not rec.right and rec.status != "not run")
        thumb = _thumbnail(run_dir / "dataset" / "images" / f"{item_id}.png", rs)
        details = []
        for rec in rs:
            body = [f"<b class='{e(rec.status)}'>{e(rec.method)}: {e(rec.status)}</b> {e(rec.answer[:200])}"]
            if rec.error:
                body.append(f"<div>{e(rec.error_category or '')}: {e(rec.error[:300])}</div>")
            if rec.program:
                trace = "\n".join(_trace_line(t) for t in rec.trace)
                body.append(
                    f"<details><summary>program and trace</summary><pre>{e(rec.program)}</pre>"
                    f"<pre>{e(trace)}</pre></details>"
                )
            details.append("<div>" + "".join(body) + "</div>")
        image = f"<img alt='{e(item_id)}' src='{thumb}'>" if thumb else ""
        parts.append(
            f"<div class='card' data-failing='{1 if failed else 0}' data-failed='{e(failed)}'>{image}<div>"
            f"<b>{e(item_id)}</b>: {e(rs[0].query)}<br>{''.join(details)}</div></div>"
        )
    parts.append(
        "<script type='application/json' id='summary'>" + json.dumps(rows).replace("</", "<\\/") + "</script>"
    )
    parts.append(f"<script>{_JS}</script></body></html>")
    write_whole(out, "\n".join(parts).encode())
    return out

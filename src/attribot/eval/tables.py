"""The report's tables as plain rows for its template: Table I (and its LaTeX), the checks the
error-catching mechanisms made, and the ablation."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable
from typing import Any

from attribot.eval.methods import NOISE_LEVELS, Record
from attribot.eval.suite import METHODS, paper_numbers
from attribot.mechanisms import MECHANISMS

__all__ = [
    "FAILURE_KINDS",
    "series_label",
    "levels",
    "table_one",
    "table_one_latex",
    "checks_table",
    "ablation_table",
]

FAILURE_KINDS = ("planner", "runner", "perception", "action", "uncertain", "wrong answer")
_LATEX_NAMES = {
    "ovd": "OVD",
    "vqa": "VQA",
    "vqa+llm": "VQA + LLM",
    "vlm": "VLM (end to end)",
    "attr-api": "Attribute API",
    "pa-api": "Perception-action API",
}


def series_label(noise: str, detector: str | None, several: bool) -> str:
    """What a report calls one condition of a method: its noise level, and its detector when the report
    sets several detectors side by side ("clean, coco")."""
    return f"{noise}, {detector}" if several else noise


def levels(rows: list[dict[str, Any]]) -> list[str]:
    """The series of `rows` on plain noise levels (ablations aside): the presets' order, and within one
    level the detectors in the order of the rows."""
    plain = [r for r in rows if r["noise"] in NOISE_LEVELS]
    plain.sort(key=lambda r: NOISE_LEVELS.index(r["noise"]))
    return list(dict.fromkeys(r["series"] for r in plain))


def _row(rows: list[dict[str, Any]], task: str, method: str, series: str) -> dict[str, Any] | None:
    return next((r for r in rows if (r["task"], r["method"], r["series"]) == (task, method, series)), None)


def table_one(rows: list[dict[str, Any]], tasks: list[str]) -> dict[str, Any]:
    """Table I, compact: a row per method that ran on an embodied task, for each task a column per noise
    level (accuracy, its interval and n) and the paper's number."""
    series = levels(rows) or ["clean"]
    body = []
    for method in METHODS.names():
        cells: list[dict[str, Any]] = []
        for task in tasks:
            for noise in series:
                row = _row(rows, task, method, noise)
                ran = row is not None and row["accuracy"] is not None
                cells.append(
                    {
                        "key": f"{task}|{method}|{noise}",
                        "value": f"{row['accuracy']:.2f}" if ran and row else "-",
                        "interval": f"[{row['low']:.2f}, {row['high']:.2f}] (n={row['n']})"
                        if ran and row
                        else "",
                        "paper": False,
                    }
                )
            paper = [v for _, v in paper_numbers(task, method)]
            cells.append(
                {"key": "", "value": f"{max(paper):.2f}" if paper else "-", "interval": "", "paper": True}
            )
        if any(c["value"] != "-" for c in cells if not c.get("paper")):
            body.append({"method": method, "cells": cells})
    return {"tasks": tasks, "levels": series, "rows": body}


def table_one_latex(rows: list[dict[str, Any]], tasks: list[str]) -> str:
    """Table I as a LaTeX tabular (booktabs), ours with the 95% interval, the paper's beside it."""
    table = table_one(rows, tasks)
    per_task = len(table["levels"]) + 1
    heads = " & ".join(f"\\multicolumn{{{per_task}}}{{c}}{{{t.replace('_', ' ')}}}" for t in tasks)
    sub = " & ".join([*(f"ours ({lvl})" for lvl in table["levels"]), "paper"] * len(tasks))
    lines = [
        "\\begin{tabular}{l" + "c" * per_task * len(tasks) + "}",
        "\\toprule",
        f"Method & {heads} \\\\",
        f" & {sub} \\\\",
        "\\midrule",
    ]
    for row in table["rows"]:
        cells = [
            c["value"] + (f" {{\\scriptsize {c['interval'].split(' (')[0]}}}" if c["interval"] else "")
            for c in row["cells"]
        ]
        lines.append(f"{_LATEX_NAMES.get(row['method'], row['method'])} & " + " & ".join(cells) + " \\\\")
    lines += ["\\bottomrule", "\\end{tabular}"]
    return "\n".join(lines) + "\n"


def checks_table(records: list[Record], program_methods: tuple[str, ...]) -> list[dict[str, Any]]:
    """Per task, method, noise (and detector, when the records hold several): for each mechanism the items
    where it caught something and of those the ones answered right, the items it left unsettled, and the
    failures where nothing was caught."""
    several = len({r.detector for r in records}) > 1
    groups: dict[tuple[str, str, str], list[Record]] = defaultdict(list)
    for r in records:
        if r.method in program_methods:
            groups[(r.task, r.method, series_label(r.noise, r.detector, several))].append(r)
    out = []
    for (task, method, noise), rs in sorted(groups.items()):
        cells = []
        for m in MECHANISMS:
            caught = [
                r for r in rs if any(c["mechanism"] == m and c["outcome"] == "caught" for c in r.checks)
            ]
            unsettled = sum(
                any(c["mechanism"] == m and c["outcome"] == "unsettled" for c in r.checks) for r in rs
            )
            cells.append(
                f"{len(caught)} / {sum(r.right for r in caught)}"
                + (f"; {unsettled} unsettled" if unsettled else "")
            )
        missed = sum(not r.right and not any(c["outcome"] == "caught" for c in r.checks) for r in rs)
        failures = sum(not r.right for r in rs)
        out.append(
            {
                "task": task,
                "method": method,
                "noise": noise,
                "cells": cells,
                "missed": f"{missed} of {failures} failures",
            }
        )
    return out


def ablation_table(rows: list[dict[str, Any]], fmt: Callable[[dict[str, Any] | None], str]) -> dict[str, Any]:
    """Accuracy with each mechanism off in turn, beside the preset with all of them on (a row per task,
    method and detector)."""
    ablated = sorted({r["noise"] for r in rows if r["ablation"]})
    base = sorted({r["preset"] for r in rows if r["ablation"]})
    columns = [*base, *ablated]

    def cell(task: str, method: str, detector: str, noise: str) -> dict[str, Any] | None:
        key = (task, method, detector, noise)
        return next((r for r in rows if (r["task"], r["method"], r["detector"], r["noise"]) == key), None)

    keys = sorted({(r["task"], r["method"], r["detector"]) for r in rows if r["noise"] in ablated})
    several = len({r["detector"] for r in rows}) > 1
    body = [
        {
            "task": task,
            "method": f"{method} ({detector})" if several else method,
            "cells": [fmt(cell(task, method, detector, c)) for c in columns],
        }
        for task, method, detector in keys
    ]
    return {"columns": columns, "rows": body}

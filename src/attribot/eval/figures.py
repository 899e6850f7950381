"""The report's bar figures, drawn once as shapes and written both as SVG and as PNG at twice the size.

A figure groups bars by method: one bar per condition that was run (no empty slot where a method was not),
the paper's published number beside ours in grey, a Wilson 95% interval on each of our bars, n under each
bar, the method's name centred under its group, and a legend. Pillow draws the PNG (no plotting library
needed); the SVG is plain text that a browser and LaTeX tools read.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from functools import cache
from html import escape

from PIL import Image, ImageDraw, ImageFont

__all__ = ["Bar", "Group", "bar_figure"]

PALETTE = ("#2e7d32", "#f9a825", "#1e88e5", "#8e24aa", "#d84315", "#00897b", "#6d4c41")
PAPER_COLOUR = "#9e9e9e"
FONT = 16  # px in the SVG; doubled in the PNG


@dataclass(frozen=True)
class Bar:
    """One bar: its series (a noise condition, or "paper"), its value, and for ours the interval and n."""

    series: str
    value: float
    low: float | None = None
    high: float | None = None
    n: int | None = None


@dataclass(frozen=True)
class Group:
    label: str  # the method
    bars: tuple[Bar, ...]


@dataclass(frozen=True)
class _Rect:
    x: float
    y: float
    w: float
    h: float
    fill: str


@dataclass(frozen=True)
class _Line:
    x0: float
    y0: float
    x1: float
    y1: float
    stroke: str = "#000000"
    width: float = 1.0


@dataclass(frozen=True)
class _Text:
    x: float
    y: float  # the baseline
    text: str
    size: float = FONT
    anchor: str = "middle"  # start | middle | end
    fill: str = "#222222"


Shape = _Rect | _Line | _Text

_BAR, _GAP, _GROUP_GAP, _LEFT, _TOP, _PLOT_H = 46.0, 6.0, 48.0, 72.0, 60.0, 300.0


def _colours(groups: list[Group]) -> dict[str, str]:
    series = list(dict.fromkeys(b.series for g in groups for b in g.bars if b.series != "paper"))
    colours = {s: PALETTE[i % len(PALETTE)] for i, s in enumerate(series)}
    if any(b.series == "paper" for g in groups for b in g.bars):
        colours["paper"] = PAPER_COLOUR
    return colours


def _axes(width: float, title: str) -> list[Shape]:
    base = _TOP + _PLOT_H
    shapes: list[Shape] = [_Text(_LEFT, 24, title, FONT + 2, "start")]
    for tick in (0.0, 0.25, 0.5, 0.75, 1.0):
        y = base - tick * _PLOT_H
        shapes.append(_Line(_LEFT, y, width - 16, y, "#dddddd"))
        shapes.append(_Text(_LEFT - 8, y + 5, f"{tick:.2f}", FONT - 2, "end"))
    shapes.append(_Line(_LEFT, _TOP, _LEFT, base, "#444444"))
    shapes.append(_Line(_LEFT, base, width - 16, base, "#444444"))
    shapes.append(_Text(18, _TOP - 14, "accuracy", FONT - 2, "start"))
    return shapes


def _bar(x: float, bar: Bar, colour: str) -> list[Shape]:
    base = _TOP + _PLOT_H
    top = base - bar.value * _PLOT_H
    shapes: list[Shape] = [_Rect(x, top, _BAR, max(bar.value * _PLOT_H, 0.5), colour)]
    if bar.low is not None and bar.high is not None:
        mid, y0, y1 = x + _BAR / 2, base - bar.high * _PLOT_H, base - bar.low * _PLOT_H
        shapes += [_Line(mid, y0, mid, y1, "#000000", 1.5)]
        shapes += [_Line(mid - 6, y, mid + 6, y, "#000000", 1.5) for y in (y0, y1)]
    label_y = min(top, base - (bar.high or 0) * _PLOT_H) - 8
    shapes.append(_Text(x + _BAR / 2, label_y, f"{bar.value:.2f}", FONT - 3))
    shapes.append(_Text(x + _BAR / 2, base + 18, "paper" if bar.n is None else f"n={bar.n}", FONT - 4))
    return shapes


def _legend_label(series: str) -> str:
    return "paper (other models, another world)" if series == "paper" else f"ours, {series}"


def _legend_width(label: str) -> float:
    return 36 + 0.6 * (FONT - 2) * len(label)  # a swatch, and about 0.6 em a character


def _legend(colours: dict[str, str], y: float) -> list[Shape]:
    shapes: list[Shape] = []
    x = _LEFT
    for series, colour in colours.items():
        label = _legend_label(series)
        shapes += [_Rect(x, y - 12, 15, 15, colour), _Text(x + 21, y, label, FONT - 2, "start")]
        x += _legend_width(label)
    return shapes


def _shapes(title: str, groups: list[Group]) -> tuple[list[Shape], float, float]:
    colours = _colours(groups)
    widths = [len(g.bars) * (_BAR + _GAP) - _GAP for g in groups]
    legend_w = _LEFT + sum(_legend_width(_legend_label(s)) for s in colours) + 16
    width = max(
        _LEFT + sum(widths) + _GROUP_GAP * (len(groups) + 1) + 16,
        legend_w,
        0.6 * (FONT + 2) * len(title) + 90,
    )
    width, height = float(math.ceil(width)), _TOP + _PLOT_H + 92  # whole pixels: the PNG is exactly 2x
    shapes = _axes(width, title)
    x = _LEFT + _GROUP_GAP
    for group, w in zip(groups, widths, strict=True):
        for i, bar in enumerate(group.bars):
            shapes += _bar(x + i * (_BAR + _GAP), bar, colours[bar.series])
        shapes.append(_Text(x + w / 2, _TOP + _PLOT_H + 42, group.label, FONT))
        x += w + _GROUP_GAP
    shapes += _legend(colours, height - 12)
    return shapes, width, height


def _svg(shapes: list[Shape], width: float, height: float, title: str) -> str:
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" height="{height:.0f}" '
        f'viewBox="0 0 {width:.0f} {height:.0f}" font-family="DejaVu Sans, Helvetica, Arial, sans-serif" '
        f'role="img" aria-label="{escape(title)}">',
        f'<rect width="{width:.0f}" height="{height:.0f}" fill="#ffffff"/>',
    ]
    for s in shapes:
        if isinstance(s, _Rect):
            out.append(
                f'<rect x="{s.x:.1f}" y="{s.y:.1f}" width="{s.w:.1f}" height="{s.h:.1f}" fill="{s.fill}"/>'
            )
        elif isinstance(s, _Line):
            out.append(
                f'<line x1="{s.x0:.1f}" y1="{s.y0:.1f}" x2="{s.x1:.1f}" y2="{s.y1:.1f}" stroke="{s.stroke}" '
                f'stroke-width="{s.width}"/>'
            )
        else:
            out.append(
                f'<text x="{s.x:.1f}" y="{s.y:.1f}" font-size="{s.size:.0f}" text-anchor="{s.anchor}" '
                f'fill="{s.fill}">{escape(s.text)}</text>'
            )
    out.append("</svg>")
    return "\n".join(out) + "\n"


@cache
def _font(size: int) -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    return ImageFont.load_default(size=size)


def _png(shapes: list[Shape], width: float, height: float, scale: float = 2.0) -> bytes:
    img = Image.new("RGB", (round(width * scale), round(height * scale)), "white")
    d = ImageDraw.Draw(img)
    for s in shapes:
        if isinstance(s, _Rect):
            d.rectangle([s.x * scale, s.y * scale, (s.x + s.w) * scale, (s.y + s.h) * scale], fill=s.fill)
        elif isinstance(s, _Line):
            d.line([s.x0 * scale, s.y0 * scale, s.x1 * scale, s.y1 * scale], fill=s.stroke,
                   width=max(1, round(s.width * scale)))  # fmt: skip
        else:
            anchor = {"start": "ls", "middle": "ms", "end": "rs"}[s.anchor]
            d.text(
                (s.x * scale, s.y * scale),
                s.text,
                fill=s.fill,
                font=_font(round(s.size * scale)),
                anchor=anchor,
            )
    buf = io.BytesIO()
    img.save(buf, "PNG")
    return buf.getvalue()


def bar_figure(title: str, groups: list[Group]) -> tuple[str, bytes]:
    """The figure as SVG text and as PNG bytes at twice the SVG's size."""
    shapes, width, height = _shapes(title, [g for g in groups if g.bars])
    return _svg(shapes, width, height, title), _png(shapes, width, height)

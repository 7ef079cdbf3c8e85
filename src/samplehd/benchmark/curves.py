"""Robustness curves: success rate against perturbation strength, one panel per axis, each point with
its Wilson band, drawn with Pillow (no plotting library)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from PIL import Image, ImageDraw, ImageFont

__all__ = ["draw_robustness_curves", "write_robustness_png"]

PANEL = (360, 250)  # one axis's panel [px]
COLUMNS = 3
_MARGIN = {"left": 44, "right": 14, "top": 26, "bottom": 34}
_PAD = 10  # [px] between the frame and the first and last strength
_BAND, _LINE, _GRID, _TEXT = (198, 214, 240), (40, 80, 170), (215, 215, 215), (20, 20, 20)


def _panel(draw: ImageDraw.ImageDraw, origin: tuple[int, int], axis: str, points: Sequence[Mapping[str, Any]],
           strengths: Sequence[int], font: ImageFont.ImageFont | ImageFont.FreeTypeFont) -> None:
    x0, y0 = origin[0] + _MARGIN["left"], origin[1] + _MARGIN["top"]
    x1, y1 = origin[0] + PANEL[0] - _MARGIN["right"], origin[1] + PANEL[1] - _MARGIN["bottom"]
    lo_s, hi_s = min(strengths), max(strengths)

    def px(strength: float) -> float:  # points kept off the frame by a few pixels
        span = (strength - lo_s) / (hi_s - lo_s) if hi_s > lo_s else 0.5
        return x0 + _PAD + (x1 - x0 - 2 * _PAD) * span

    def py(rate: float) -> float:
        return y1 - (y1 - y0) * rate

    measured = [p for p in points if p["rate"] is not None]
    if len(measured) > 1:
        band = ([(px(p["strength"]), py(p["high"])) for p in measured]
                + [(px(p["strength"]), py(p["low"])) for p in reversed(measured)])
        draw.polygon(band, fill=_BAND)
    draw.text((origin[0] + _MARGIN["left"], origin[1] + 6), axis, fill=_TEXT, font=font)
    for k in range(5):
        rate = k / 4
        draw.line([(x0, py(rate)), (x1, py(rate))], fill=_GRID)
        draw.text((origin[0] + 6, py(rate) - 6), f"{rate:.2f}", fill=_TEXT, font=font)
    for s in strengths:
        draw.line([(px(s), y1), (px(s), y1 + 4)], fill=_TEXT)
        draw.text((px(s) - 3, y1 + 6), str(s), fill=_TEXT, font=font)
    draw.text(((x0 + x1) / 2 - 22, y1 + 19), "strength", fill=_TEXT, font=font)
    if len(measured) > 1:
        draw.line([(px(p["strength"]), py(p["rate"])) for p in measured], fill=_LINE, width=2)
    for p in measured:
        x, y = px(p["strength"]), py(p["rate"])
        draw.line([(x, py(p["low"])), (x, py(p["high"]))], fill=_LINE)
        draw.ellipse([x - 3, y - 3, x + 3, y + 3], fill=_LINE)
    draw.rectangle([x0, y0, x1, y1], outline=_TEXT)


def draw_robustness_curves(curves: Mapping[str, Sequence[Mapping[str, Any]]], title: str = "") -> Image.Image:
    """One panel per axis: success rate (0–1) against strength, the 95 % Wilson band shaded.

    Args:
        curves: axis → points ``{strength, rate, low, high, ...}`` (the ``curves`` of
            :func:`samplehd.benchmark.statistics.summarize`).
        title: a line above the panels (e.g. the policy and split).

    Returns:
        An RGB image of ``min(len(curves), 3)`` panels per row.
    """
    font = ImageFont.load_default()
    axes = list(curves)
    strengths = sorted({int(p["strength"]) for pts in curves.values() for p in pts}) or [0]
    cols = max(1, min(len(axes), COLUMNS))
    rows = max(1, -(-len(axes) // cols))
    head = 24 if title else 0
    img = Image.new("RGB", (PANEL[0] * cols, head + PANEL[1] * rows), "white")
    draw = ImageDraw.Draw(img)
    if title:
        draw.text((8, 6), title, fill=_TEXT, font=font)
    for k, axis in enumerate(axes):
        _panel(draw, (PANEL[0] * (k % cols), head + PANEL[1] * (k // cols)), axis, curves[axis], strengths, font)
    return img


def write_robustness_png(path: str | Path, curves: Mapping[str, Sequence[Mapping[str, Any]]],
                         title: str = "") -> Path:
    """Draw :func:`draw_robustness_curves` and save it as a PNG at ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    draw_robustness_curves(curves, title).save(path, format="PNG")
    return path

"""Tile images into one contact sheet, for looking at many scenes or frames at once."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from PIL import Image, ImageDraw

__all__ = ["contact_sheet"]


def contact_sheet(
    images: Sequence[np.ndarray],
    columns: int,
    labels: Sequence[str] | None = None,
    tile_width: int | None = None,
    gap: int = 4,
) -> np.ndarray:
    """Tile H×W×3 uint8 images row by row into one image, optionally captioned.

    Args:
        images: the tiles (resized to the first tile's aspect at `tile_width`).
        columns: tiles per row.
        labels: one caption per tile, drawn in its top-left corner.
        tile_width: width of each tile [px] (default: the first image's width).
        gap: pixels between tiles.
    """
    if not images:
        raise ValueError("contact_sheet needs at least one image")
    h0, w0 = images[0].shape[:2]
    tw = tile_width or w0
    th = max(1, round(h0 * tw / w0))
    rows = (len(images) + columns - 1) // columns
    sheet = Image.new("RGB", (columns * tw + (columns - 1) * gap, rows * th + (rows - 1) * gap), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    for k, img in enumerate(images):
        tile = Image.fromarray(np.asarray(img, dtype=np.uint8)).resize((tw, th))
        x, y = (k % columns) * (tw + gap), (k // columns) * (th + gap)
        sheet.paste(tile, (x, y))
        if labels:
            draw.rectangle((x, y, x + 7 * len(labels[k]) + 6, y + 14), fill=(0, 0, 0))
            draw.text((x + 3, y + 2), labels[k], fill=(255, 255, 255))
    return np.asarray(sheet)

"""Procedural label textures for the photo preset: printed food boxes and soda-can labels.

All images are numpy arrays made from a seed (nothing is downloaded or shipped as image files). A
food-box texture holds three prints side by side in u: [0, 1) front/back, [1, 2) the narrow sides,
[2, 3) top and bottom (see ``geometry._label_uv``). A can texture wraps once around the can; its
alpha-like mask channel says where bare aluminium shows (rims, top, bottom).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

__all__ = ["can_label", "food_box_print", "srgb_to_linear"]


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """sRGB-encoded values in [0, 1] to linear light."""
    c = np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _disc(img: np.ndarray, cx: float, cy: float, r: float, rgb: np.ndarray) -> None:
    h, w, _ = img.shape
    y, x = np.mgrid[0:h, 0:w]
    img[(x - cx) ** 2 + (y - cy) ** 2 <= r * r] = rgb


def _bars(img: np.ndarray, x0: int, y0: int, x1: int, rows: int, height: int, gap: int, rgb: np.ndarray,
          rng: np.random.Generator) -> None:
    """Lines of 'text': bars of random lengths."""
    for k in range(rows):
        y = y0 + k * (height + gap)
        length = int((x1 - x0) * rng.uniform(0.45, 1.0))
        img[y:y + height, x0:x0 + length] = rgb


@lru_cache(maxsize=32)
def food_box_print(rgb: tuple[float, float, float], seed: int = 0, width: int = 256) -> np.ndarray:
    """A (width, 3·width, 3) float sRGB image: a cereal-box-like print in the box's colour.

    Front: the colour as background, a white panel with a 'brand' band, a bowl-and-food picture and
    lines of text; sides: text columns and a nutrition table; top: plain colour with a flap line.
    """
    rng = np.random.default_rng(seed)
    base = np.asarray(rgb, dtype=np.float64)
    accent = np.clip(1.0 - 0.85 * base + 0.15, 0.0, 1.0)  # a contrasting print colour
    w = width
    img = np.empty((w, 3 * w, 3))
    img[:] = base
    front = img[:, :w]
    # Image rows run top → bottom; v = 0 is the box's bottom, so row = w - 1 - v·w (flipped below).
    front[int(0.06 * w):int(0.30 * w), int(0.08 * w):int(0.92 * w)] = accent  # brand band
    _bars(front, int(0.14 * w), int(0.12 * w), int(0.86 * w), 2, int(0.05 * w), int(0.03 * w),
          np.array([0.97, 0.97, 0.95]), rng)
    _disc(front, 0.5 * w, 0.60 * w, 0.22 * w, np.array([0.96, 0.95, 0.92]))  # bowl
    for _ in range(9):  # food in the bowl
        _disc(front, 0.5 * w + rng.uniform(-0.13, 0.13) * w, 0.56 * w + rng.uniform(-0.07, 0.05) * w,
              rng.uniform(0.03, 0.05) * w, np.clip(np.array([0.85, 0.55, 0.2]) * rng.uniform(0.8, 1.1), 0, 1))
    _bars(front, int(0.2 * w), int(0.86 * w), int(0.8 * w), 2, int(0.025 * w), int(0.02 * w), accent, rng)
    side = img[:, w:2 * w]
    side[int(0.1 * w):int(0.55 * w), int(0.12 * w):int(0.88 * w)] = np.array([0.96, 0.96, 0.94])
    _bars(side, int(0.16 * w), int(0.14 * w), int(0.84 * w), 9, int(0.018 * w), int(0.026 * w),
          np.array([0.15, 0.15, 0.15]), rng)
    _bars(side, int(0.16 * w), int(0.65 * w), int(0.84 * w), 5, int(0.03 * w), int(0.03 * w), accent, rng)
    top = img[:, 2 * w:]
    top[int(0.48 * w):int(0.52 * w), :] = base * 0.8  # the flap's edge
    return np.flipud(img).copy()  # row 0 = v 0 (bottom), as texture lookups expect


@lru_cache(maxsize=32)
def can_label(rgb: tuple[float, float, float], seed: int = 0, width: int = 512) -> tuple[np.ndarray, np.ndarray]:
    """A can label: ((width/2, width, 3) float sRGB colour, (width/2, width) metal mask in [0, 1]).

    The label covers the straight wall; the bottom dome and the tapered neck and lid are bare metal
    (mask 1), with a thin printed band and a logo stripe in a contrasting colour.
    """
    rng = np.random.default_rng(seed)
    h = width // 2
    base = np.asarray(rgb, dtype=np.float64)
    accent = np.clip(1.0 - 0.9 * base + 0.1, 0.0, 1.0)
    img = np.empty((h, width, 3))
    img[:] = base
    v = (np.arange(h) + 0.5) / h  # row 0 = bottom of the can
    u = (np.arange(width) + 0.5) / width
    # A wave-shaped stripe around the can, and a 'logo' panel repeated twice around.
    wave = 0.55 + 0.06 * np.sin(2 * np.pi * 2 * u + rng.uniform(0, 2 * np.pi))
    stripe = np.abs(v[:, None] - wave[None, :]) < 0.05
    img[stripe] = accent
    for centre in (0.25, 0.75):
        logo = (np.abs(u[None, :] - centre) < 0.09) & (np.abs(v[:, None] - 0.38) < 0.09)
        img[logo] = np.array([0.97, 0.97, 0.95])
        inner = (np.abs(u[None, :] - centre) < 0.06) & (np.abs(v[:, None] - 0.38) < 0.02)
        img[inner] = accent * 0.7
    mask = np.zeros((h, width))
    mask[v < 0.06] = 1.0  # bottom dome and the rolled base
    mask[v > 0.88] = 1.0  # neck, lid and rim
    return img, mask


@lru_cache(maxsize=4)
def window_view(seed: int = 0, across: int = 256, up: int = 160) -> np.ndarray:
    """What the kitchen window shows, as linear radiance per unit brightness: (across, up, 3).

    A daylight sky, brighter towards the horizon, over a band of trees and a lawn. Axis 0 runs across
    the window, axis 1 from its top (0) to its bottom, as the window rectangle's texture coordinates do.
    """
    rng = np.random.default_rng([seed, 0x51D0])
    h = 1.0 - (np.arange(up) + 0.5) / up  # height in the window: 1 top, 0 bottom
    x = (np.arange(across) + 0.5) / across
    top, horizon = np.array([0.42, 0.60, 0.95]), np.array([0.92, 0.95, 1.0])
    t = np.clip((h - 0.3) / 0.7, 0.0, 1.0)[None, :, None]
    img = np.broadcast_to(horizon * (1 - t) + top * t, (across, up, 3)).copy()
    # A tree line: a wavy silhouette, a little noise in its green.
    ridge = (0.2 + 0.05 * np.sin(2 * np.pi * (3 * x + rng.uniform()))
             + 0.03 * np.sin(2 * np.pi * (11 * x + rng.uniform())))
    trees = h[None, :] < ridge[:, None]
    green = np.array([0.10, 0.20, 0.08]) * (0.8 + 0.4 * rng.random((across, up, 1)))
    img[trees] = green[trees]
    img[:, h < 0.05] = np.array([0.20, 0.32, 0.12])  # lawn
    return img

"""Procedural textures for the kitchen world: wood grain, tiles and plaster, made from numpy arrays.

Textures are generated from a fixed seed so every build of the world is identical; they are cached
(treat the returned arrays as read-only).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

__all__ = ["plaster_texture", "recolour", "tile_texture", "wood_texture"]


def _smooth_noise(
    rng: np.random.Generator, height: int, width: int, cells: int, cells_x: int | None = None
) -> np.ndarray:
    """Smoothly interpolated value noise in [0, 1] with `cells` (rows) × `cells_x` lattice cells."""
    cx = cells if cells_x is None else cells_x
    lattice = rng.random((cells + 1, cx + 1))
    ys = np.linspace(0, cells, height, endpoint=False)
    xs = np.linspace(0, cx, width, endpoint=False)
    y0, x0 = ys.astype(int), xs.astype(int)
    fy, fx = (ys - y0)[:, None], (xs - x0)[None, :]
    fy, fx = fy * fy * (3 - 2 * fy), fx * fx * (3 - 2 * fx)
    a = lattice[y0][:, x0]
    b = lattice[y0][:, x0 + 1]
    c = lattice[y0 + 1][:, x0]
    d = lattice[y0 + 1][:, x0 + 1]
    return (a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy


@lru_cache(maxsize=8)
def wood_texture(
    size: int = 512,
    light: tuple[int, int, int] = (196, 150, 104),
    dark: tuple[int, int, int] = (128, 84, 50),
    seed: int = 7,
) -> np.ndarray:
    """Return a (size, size, 3) uint8 wood-grain texture; grain runs along the image's x axis."""
    rng = np.random.default_rng(seed)
    # Grain runs along x: the warp changes slowly along x and faster across it.
    warp = _smooth_noise(rng, size, size, 8, 2) * 1.6 + _smooth_noise(rng, size, size, 32, 4) * 0.35
    v = np.linspace(0.0, 1.0, size, endpoint=False)[:, None]
    rings = 0.5 + 0.5 * np.sin(2 * np.pi * (v * 22.0 + warp))
    rings = rings**4
    fibres = _smooth_noise(rng, size, size, 160, 6)
    t = np.clip(0.55 * rings + 0.3 * fibres, 0.0, 1.0)[..., None]
    img = np.asarray(light, float) * (1 - t) + np.asarray(dark, float) * t
    return np.clip(img, 0, 255).astype(np.uint8)


@lru_cache(maxsize=8)
def tile_texture(
    size: int = 256,
    tiles: int = 4,
    tile_rgb: tuple[int, int, int] = (226, 230, 226),
    grout_rgb: tuple[int, int, int] = (150, 150, 145),
    seed: int = 11,
) -> np.ndarray:
    """Return a (size, size, 3) uint8 texture of square tiles with grout lines and slight variation."""
    rng = np.random.default_rng(seed)
    img = np.empty((size, size, 3), float)
    img[:] = tile_rgb
    step = size // tiles
    shade = rng.uniform(-8, 8, (tiles, tiles))
    for i in range(tiles):
        for j in range(tiles):
            img[i * step : (i + 1) * step, j * step : (j + 1) * step] += shade[i, j]
    grout = max(2, size // 128)
    for k in range(tiles):
        img[k * step : k * step + grout, :] = grout_rgb
        img[:, k * step : k * step + grout] = grout_rgb
    img += (_smooth_noise(rng, size, size, 16)[..., None] - 0.5) * 6
    return np.clip(img, 0, 255).astype(np.uint8)


@lru_cache(maxsize=8)
def plaster_texture(
    size: int = 256, rgb: tuple[int, int, int] = (232, 226, 212), seed: int = 13
) -> np.ndarray:
    """Return a (size, size, 3) uint8 texture of lightly mottled painted plaster."""
    rng = np.random.default_rng(seed)
    n = _smooth_noise(rng, size, size, 8) * 0.6 + _smooth_noise(rng, size, size, 32) * 0.4
    img = np.asarray(rgb, float)[None, None, :] + (n[..., None] - 0.5) * 14
    return np.clip(img, 0, 255).astype(np.uint8)


def recolour(rgb: np.ndarray, hue: float = 0.0, saturation: float = 1.0, value: float = 1.0) -> np.ndarray:
    """A uint8 RGB image with its colours moved in HSV: hue turned, saturation and brightness scaled.

    Args:
        rgb: (h, w, 3) uint8 image.
        hue: turn of every pixel's hue round the colour wheel [deg].
        saturation: factor on every pixel's HSV saturation [1] (clipped to 1).
        value: factor on every pixel's HSV value, its brightness [1] (clipped to 1).

    Returns:
        A new (h, w, 3) uint8 image (the same values for hue 0 and factors 1).
    """
    x = rgb.astype(np.float64) / 255.0
    hi, lo = x.max(axis=-1), x.min(axis=-1)
    chroma = hi - lo
    safe = np.where(chroma > 0, chroma, 1.0)
    r, g, b = x[..., 0], x[..., 1], x[..., 2]
    h = np.where(hi == r, ((g - b) / safe) % 6.0, np.where(hi == g, (b - r) / safe + 2.0, (r - g) / safe + 4.0))
    h = np.where(chroma > 0, h, 0.0)
    s = np.where(hi > 0, chroma / np.where(hi > 0, hi, 1.0), 0.0)
    h = (h + hue / 60.0) % 6.0
    s = np.clip(s * saturation, 0.0, 1.0)
    v = np.clip(hi * value, 0.0, 1.0)
    c = v * s
    k = c * (1.0 - np.abs(h % 2.0 - 1.0))
    sector = np.floor(h).astype(int) % 6
    zero = np.zeros_like(c)
    table = np.stack([np.stack(t, axis=-1) for t in ((c, k, zero), (k, c, zero), (zero, c, k), (zero, k, c),
                                                      (k, zero, c), (c, zero, k))])
    out = np.take_along_axis(table, sector[None, ..., None], axis=0)[0] + (v - c)[..., None]
    return np.round(np.clip(out, 0.0, 1.0) * 255.0).astype(np.uint8)

"""Procedural textures (numpy arrays) for materials, e.g. wood grain for wooden objects."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["METAL_SEED", "RUBBER_SEED", "TEXTURES", "WOOD_SEED", "brushed_metal", "rubber_grain", "wood_grain"]

WOOD_SEED = 20240611  # fixed: every wooden object shows the same grain pattern, run after run
METAL_SEED = 20240612
RUBBER_SEED = 20240613


def wood_grain(width: int = 256, height: int = 256, rng: np.random.Generator | None = None) -> np.ndarray:
    """A tileable grey-scale wood-grain image; the material colour tints it.

    Grain lines run along the image's u axis (horizontal), growth rings vary along v.

    Args:
        width: image width [px].
        height: image height [px].
        rng: random generator for the grain irregularities (default: fixed seed ``WOOD_SEED``).

    Returns:
        (height, width, 3) uint8 RGB image, brightness between about 55 % and 100 %.
    """
    if rng is None:
        rng = np.random.default_rng(WOOD_SEED)
    u = np.linspace(0.0, 1.0, width, endpoint=False)[None, :]
    v = np.linspace(0.0, 1.0, height, endpoint=False)[:, None]
    # Integer frequencies keep the pattern tileable in u and v.
    warp = np.zeros((height, width))
    for k in range(1, 5):
        phase_u, phase_v = rng.uniform(0, 2 * np.pi, 2)
        warp += (
            rng.uniform(0.002, 0.006) / k * np.sin(2 * np.pi * k * u + phase_u) * np.cos(2 * np.pi * k * v + phase_v)
        )
    rings = 22
    # Uneven ring spacing, still periodic in v (integer frequencies).
    t = (v + warp) * rings + 0.8 * np.sin(2 * np.pi * 3 * v + rng.uniform(0, 2 * np.pi))
    ring = 0.5 + 0.5 * np.cos(2 * np.pi * t)
    ring = ring**4  # thin dark late-wood lines on light early wood
    fine = np.zeros((height, width))
    for k in (23, 37, 61):
        fine += np.sin(2 * np.pi * (k * v + rng.uniform(0, 1)) + 0.5 * np.sin(2 * np.pi * 2 * u)) / 3
    lum = 0.95 - 0.16 * ring + 0.04 * fine
    lum = np.clip(lum, 0.55, 1.0)
    tint = np.array([1.0, 0.93, 0.82])  # warm, so that white paint still reads as wood
    img = lum[..., None] * tint[None, None, :]
    return np.round(img * 255.0).astype(np.uint8)


def brushed_metal(width: int = 256, height: int = 256, rng: np.random.Generator | None = None) -> np.ndarray:
    """A tileable grey-scale brushed-metal image: fine streaks along u of uneven brightness, and broader
    darker bands, so that a metal object's diffuse look is darker and streaked (the material colour tints
    it; highlights come from the material's specular settings).

    Returns:
        (height, width, 3) uint8 RGB image, brightness between about 55 % and 95 %.
    """
    if rng is None:
        rng = np.random.default_rng(METAL_SEED)
    v = np.linspace(0.0, 1.0, height, endpoint=False)
    u = np.linspace(0.0, 1.0, width, endpoint=False)
    streak = np.zeros(height)
    for k in (3, 7, 13, 29, 53):  # integer frequencies: tileable
        streak += rng.uniform(0.5, 1.0) / np.sqrt(k) * np.sin(2 * np.pi * k * v + rng.uniform(0, 2 * np.pi))
    streak = streak / np.abs(streak).max()
    noise = rng.normal(0.0, 1.0, height)
    noise = (noise - noise.mean()) / noise.std()
    along = 0.03 * np.sin(2 * np.pi * 2 * u[None, :] + rng.uniform(0, 2 * np.pi))
    lum = 0.78 + 0.12 * streak[:, None] + 0.05 * noise[:, None] + along
    lum = np.clip(lum, 0.55, 0.95)
    return np.round(np.repeat(lum[..., None], 3, axis=2) * 255.0).astype(np.uint8)


def rubber_grain(width: int = 128, height: int = 128, rng: np.random.Generator | None = None) -> np.ndarray:
    """A tileable grey-scale matte grain for rubber: a fine, even speckle a little darker than the
    colour (the material colour tints it).

    Returns:
        (height, width, 3) uint8 RGB image, brightness between about 70 % and 90 %.
    """
    if rng is None:
        rng = np.random.default_rng(RUBBER_SEED)
    n = rng.normal(0.0, 1.0, (height, width))
    n = (n + np.roll(n, 1, 0) + np.roll(n, 1, 1) + np.roll(n, (1, 1), (0, 1))) / 4  # soften a little
    lum = np.clip(0.8 + 0.05 * n / n.std(), 0.7, 0.9)
    return np.round(np.repeat(lum[..., None], 3, axis=2) * 255.0).astype(np.uint8)


# The textures a material's look may name, and the function that makes each (RGB uint8 image).
TEXTURES: dict[str, Callable[[], np.ndarray]] = {
    "wood_grain": wood_grain, "brushed_metal": brushed_metal, "rubber_grain": rubber_grain}

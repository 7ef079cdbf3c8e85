"""Images the viewer sends to the browser: PNG/JPEG encoding, colourised depth and segmentation,
thumbnails, and raw per-pixel arrays (instance ids, depth) for the cursor read-out.

Depth is shown with a perceptual colour map over the valid range of the frame; segmentation ids
get fixed, well-separated colours so that one object keeps its colour across frames.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from PIL import Image

from samplehd.errors import DatasetError

__all__ = [
    "colourise_depth",
    "colourise_segmentation",
    "encode_image",
    "load_depth_mm",
    "load_ids",
    "load_rgb",
    "raw_array_bytes",
    "thumbnail",
]

# Fixed colours for background, table and robot; objects cycle through a qualitative palette.
_FIXED = np.array([[20, 20, 24], [120, 104, 88], [150, 150, 160]], dtype=np.uint8)
_OBJECT_PALETTE = np.array(
    [
        [230, 25, 75], [60, 180, 75], [255, 225, 25], [0, 130, 200], [245, 130, 48],
        [145, 30, 180], [70, 240, 240], [240, 50, 230], [210, 245, 60], [250, 190, 212],
        [0, 128, 128], [220, 190, 255], [170, 110, 40], [255, 250, 200], [128, 0, 0],
        [170, 255, 195], [128, 128, 0], [255, 215, 180], [0, 0, 128], [255, 255, 255],
    ],
    dtype=np.uint8,
)

# Anchors of the "turbo" colour map (Google, Apache-2.0), linearly interpolated.
_TURBO = np.array(
    [
        [48, 18, 59], [70, 107, 227], [40, 187, 236], [49, 242, 153], [162, 252, 60],
        [237, 208, 58], [251, 128, 34], [208, 47, 5], [122, 4, 3],
    ],
    dtype=np.float32,
)


def _open(path: Path) -> Image.Image:
    try:
        image = Image.open(path)
        image.load()
    except FileNotFoundError as exc:
        raise DatasetError(f"{path}: not written yet") from exc
    except (OSError, SyntaxError, ValueError) as exc:
        raise DatasetError(f"{path}: unreadable image ({exc})") from exc
    return image


def load_rgb(path: Path) -> np.ndarray:
    """(H, W, 3) uint8 image of an RGB(A) or grey file."""
    return np.asarray(_open(path).convert("RGB"))


def load_ids(path: Path) -> np.ndarray:
    """(H, W) integer instance ids of a segmentation PNG (8 or 16 bit)."""
    image = _open(path)
    if image.mode in ("RGB", "RGBA"):
        return np.asarray(image.convert("RGB"))[..., 0].astype(np.int32)
    return np.asarray(image).astype(np.int32)


def load_depth_mm(path: Path) -> np.ndarray:
    """(H, W) depth in millimetres of a 16-bit depth PNG (0 = no depth)."""
    return np.asarray(_open(path)).astype(np.int32)


def colourise_depth(depth: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 colour image of a depth map; near is warm, far is cold, 0/NaN/inf black.

    Args:
        depth: (H, W) depth in any unit; non-positive and non-finite values count as missing.
    """
    d = np.asarray(depth, dtype=np.float64)
    valid = np.isfinite(d) & (d > 0)
    out = np.zeros((*d.shape, 3), dtype=np.uint8)
    if not valid.any():
        return out
    lo, hi = np.percentile(d[valid], [1.0, 99.0])
    span = max(hi - lo, 1e-9)
    t = 1.0 - np.clip((d[valid] - lo) / span, 0.0, 1.0)
    x = t * (len(_TURBO) - 1)
    i = np.minimum(x.astype(np.int64), len(_TURBO) - 2)
    f = (x - i)[:, None]
    out[valid] = np.round(_TURBO[i] * (1 - f) + _TURBO[i + 1] * f).astype(np.uint8)
    return out


def colourise_segmentation(ids: np.ndarray, object_offset: int = 3) -> np.ndarray:
    """(H, W, 3) uint8 colour image of an instance-id map (0 background, 1 table, 2 robot, 3+i object i)."""
    ids = np.asarray(ids, dtype=np.int64)
    lut_size = max(int(ids.max(initial=0)) + 1, object_offset)
    lut = np.empty((lut_size, 3), dtype=np.uint8)
    lut[: min(object_offset, len(_FIXED))] = _FIXED[: min(object_offset, len(_FIXED))]
    for k in range(object_offset, lut_size):
        lut[k] = _OBJECT_PALETTE[(k - object_offset) % len(_OBJECT_PALETTE)]
    return lut[np.clip(ids, 0, lut_size - 1)]


def object_colour(index: int) -> tuple[int, int, int]:
    """Segmentation-view colour of scene object ``index`` (same as :func:`colourise_segmentation`)."""
    r, g, b = _OBJECT_PALETTE[index % len(_OBJECT_PALETTE)]
    return int(r), int(g), int(b)


def encode_image(pixels: np.ndarray, fmt: str = "png", quality: int = 88) -> bytes:
    """Encode an (H, W, 3) uint8 or (H, W) uint8/uint16 array as PNG or JPEG bytes."""
    arr = np.asarray(pixels)
    if arr.dtype != np.uint8 and arr.ndim == 3:
        arr = np.clip(arr, 0, 255).astype(np.uint8)
    image = Image.fromarray(arr)
    buf = io.BytesIO()
    if fmt == "jpeg":
        image.convert("RGB").save(buf, format="JPEG", quality=quality)
    else:
        image.save(buf, format="PNG", compress_level=1)
    return buf.getvalue()


def thumbnail(pixels: np.ndarray, width: int = 320) -> bytes:
    """JPEG thumbnail of an (H, W, 3) image, ``width`` pixels wide."""
    image = Image.fromarray(np.asarray(pixels, dtype=np.uint8))
    height = max(1, round(image.height * width / max(image.width, 1)))
    image = image.resize((width, height), Image.Resampling.BILINEAR)
    buf = io.BytesIO()
    image.convert("RGB").save(buf, format="JPEG", quality=80)
    return buf.getvalue()


def raw_array_bytes(values: np.ndarray) -> tuple[bytes, str]:
    """Little-endian bytes of a 2-D integer array in the smallest of uint8/uint16/int32, and its dtype name."""
    arr = np.asarray(values)
    lo, hi = int(arr.min(initial=0)), int(arr.max(initial=0))
    if lo >= 0 and hi < 256:
        return arr.astype("<u1").tobytes(), "uint8"
    if lo >= 0 and hi < 65536:
        return arr.astype("<u2").tobytes(), "uint16"
    return arr.astype("<i4").tobytes(), "int32"

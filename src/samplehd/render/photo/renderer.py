"""Path-traced RGB with GL-exact depth and segmentation.

RGB: Mitsuba 3 path tracing (a few samples per pixel, box pixel filter) → firefly clamp → Open Image
Denoise with albedo and normal guides → exposure → filmic tone curve → sRGB. Depth and segmentation
come from the GL rasteriser of the same model and camera, so they are exactly those of the other
presets; the path-traced image is pixel-aligned with them (same pose, vertical field of view and
principal point; ``tests/render/test_photo.py`` checks it against Mitsuba's own depth).
"""

from __future__ import annotations

from collections.abc import Iterable
from types import TracebackType
from typing import Any

import mujoco
import numpy as np

from samplehd.errors import RenderError
from samplehd.render.photo.look import LookParams, default_look
from samplehd.render.photo.scene import PhotoScene
from samplehd.render.renderer import MODALITIES, SceneRenderer, _camera_id

__all__ = ["DEFAULT_SPP", "PhotoRenderer", "tonemap"]

DEFAULT_SPP = 1
_CLAMP = 8.0  # [linear radiance] caps rare high-energy paths (fireflies) before denoising
_WHITE = 1.1  # linear radiance shown as white (before exposure)


def tonemap(rgb: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """Linear HDR → sRGB uint8 with a filmic shoulder (ACES fit), so highlights roll off instead of clipping."""
    x = np.maximum(rgb, 0.0) * (2.0 ** exposure) * (0.8 / _WHITE)
    a, b, c, d, e = 2.51, 0.03, 2.43, 0.59, 0.14
    y = np.clip((x * (a * x + b)) / (x * (c * x + d) + e), 0.0, 1.0)
    srgb = np.where(y <= 0.0031308, 12.92 * y, 1.055 * np.power(y, 1 / 2.4) - 0.055)
    return np.round(srgb * 255.0).astype(np.uint8)


def denoise(color: np.ndarray, albedo: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Open Image Denoise (RT filter, HDR) of a linear image with its albedo and normal guides."""
    import pyoidn

    return pyoidn.denoise(np.ascontiguousarray(color, dtype=np.float32), np.ascontiguousarray(albedo, dtype=np.float32),
                          np.ascontiguousarray(normal, dtype=np.float32), hdr=True, quality="balanced")


class PhotoRenderer:
    """Renders RGB by path tracing and depth/segmentation by GL, with :class:`SceneRenderer`'s interface.

    Example:
        >>> with PhotoRenderer(model, 640, 360) as r:  # doctest: +SKIP
        ...     images = r.render(data, "operator", ("rgb", "segmentation"))
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        width: int,
        height: int,
        *,
        look: LookParams | None = None,
        spp: int = DEFAULT_SPP,
        seed: int = 0,
        denoise: bool = True,
        buffer_size: tuple[int, int] | None = None,
    ) -> None:
        if not isinstance(spp, int) or not 1 <= spp <= 4096:
            raise RenderError(f"photo spp={spp!r} is invalid; valid: an integer 1..4096")
        self.model = model
        self.look = look or default_look()
        self.spp = spp
        self.seed = int(seed)
        self.denoise = bool(denoise)
        self._gl = SceneRenderer(model, width, height, "fast", buffer_size)
        self.buffer_size = self._gl.buffer_size
        self.width, self.height = width, height
        self._scene: PhotoScene | None = None
        self.frames = 0

    def resize(self, width: int, height: int) -> None:
        """Render ``width``×``height`` px images from now on."""
        self._gl.resize(width, height)
        self.width, self.height = width, height

    def __enter__(self) -> PhotoRenderer:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def close(self) -> None:
        """Free the GL resources and the Mitsuba scene (safe to call twice)."""
        self._gl.close()
        self._scene = None

    def radiance(self, data: mujoco.MjData, camera: str | int) -> np.ndarray:
        """(H, W, 9) float32 linear RGB, albedo and normal of one path-traced frame (before denoising)."""
        cid = _camera_id(self.model, camera)
        if self._scene is None:
            self._scene = PhotoScene(self.model, data, self.width, self.height, self.look)
        self._scene.pose(data, cid, self.width, self.height)
        # A fixed seed per render: the same state gives the same image, and still frames do not flicker.
        return self._scene.render(self.spp, self.seed)

    def rgb(self, data: mujoco.MjData, camera: str | int) -> np.ndarray:
        """(H, W, 3) uint8 path-traced, denoised, tone-mapped image."""
        raw = self.radiance(data, camera)
        color = np.minimum(np.nan_to_num(raw[..., :3], nan=0.0, posinf=_CLAMP), _CLAMP)
        if self.denoise:
            color = denoise(color, np.clip(raw[..., 3:6], 0, 1), np.clip(raw[..., 6:9], -1, 1))
        self.frames += 1
        return tonemap(color, self.look.exposure)

    def render(
        self, data: mujoco.MjData, camera: str | int, modalities: Iterable[str] = ("rgb",)
    ) -> dict[str, np.ndarray]:
        """Render the requested modalities, as :meth:`SceneRenderer.render` (RGB path traced)."""
        wanted = tuple(dict.fromkeys(modalities))
        bad = [m for m in wanted if m not in MODALITIES]
        if bad or not wanted:
            raise RenderError(f"unknown modalities {bad or '(none)'}; valid: {', '.join(MODALITIES)}")
        out: dict[str, np.ndarray] = {}
        rest = [m for m in wanted if m != "rgb"]
        if rest:
            out.update(self._gl.render(data, camera, rest))
        if "rgb" in wanted:
            out["rgb"] = self.rgb(data, camera)
        return {m: out[m] for m in wanted}


def photo_info(renderer: PhotoRenderer) -> dict[str, Any]:
    """What to record about a photo render in an annotation."""
    from samplehd.render.photo.runtime import photo_backend

    return {"renderer": "mitsuba3", "variant": photo_backend(), "spp": renderer.spp, "denoised": renderer.denoise,
            "look": renderer.look.to_dict()}

"""Path-traced RGB frames; ``SceneRenderer`` with the ``photo`` preset adds GL-exact depth and segmentation.

RGB: Mitsuba 3 path tracing (a few samples per pixel, box pixel filter) → firefly clamp → Open Image
Denoise with albedo and normal guides → exposure → filmic tone curve → sRGB. Depth and segmentation
come from the GL rasteriser of the same model and camera, so they are exactly those of the other
presets; the path-traced image is pixel-aligned with them (same pose, vertical field of view and
principal point; ``tests/render/test_photo.py`` checks it against Mitsuba's own depth).
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from samplehd.errors import RenderError
from samplehd.render.photo.look import LookParams, blackbody_rgb, default_look, random_look
from samplehd.render.photo.runtime import load_drjit, load_oidn, photo_backend
from samplehd.render.photo.scene import PhotoScene

__all__ = ["DEFAULT_SPP", "LOOKS", "PhotoOptions", "PhotoTracer", "denoise", "photo_info", "photo_options", "tonemap"]

LOOKS = ("fixed", "random")  # the photo look: the same for every scene, or drawn from each scene's seed

DEFAULT_SPP = 1
_CLAMP = 8.0  # [linear radiance] caps rare high-energy paths (fireflies) before denoising
_WHITE = 1.1  # linear radiance shown as white (before exposure)
_FINISH: dict[str, Any] = {}  # torch where frames are finished on the GPU (decided once per process)


def _filmic(x: Any) -> Any:
    """The ACES fit of the filmic shoulder; arithmetic only, so NumPy arrays and torch tensors alike."""
    a, b, c, d, e = 2.51, 0.03, 2.43, 0.59, 0.14
    return (x * (a * x + b)) / (x * (c * x + d) + e)


def white_balance(look: LookParams) -> np.ndarray:
    """Per-channel gains of a camera balanced for the ceiling lights' colour temperature (as a camera's
    white balance would be): a white object under them comes out white, and a purple one purple, not the
    magenta of warm light on it; the daylight window keeps its relative tint."""
    return 1.0 / blackbody_rgb(look.colour_temperature)


def tonemap(rgb: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """Linear HDR → sRGB uint8 with a filmic shoulder (ACES fit), so highlights roll off instead of clipping."""
    x = np.maximum(rgb, 0.0) * (2.0 ** exposure) * (0.8 / _WHITE)
    y = np.clip(_filmic(x), 0.0, 1.0)
    srgb = np.where(y <= 0.0031308, 12.92 * y, 1.055 * np.power(y, 1 / 2.4) - 0.055)
    return np.round(srgb * 255.0).astype(np.uint8)


def denoise(color: np.ndarray, albedo: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Open Image Denoise (RT filter, HDR) of a linear image with its albedo and normal guides."""
    return load_oidn().denoise(np.ascontiguousarray(color, dtype=np.float32),
                               np.ascontiguousarray(albedo, dtype=np.float32),
                               np.ascontiguousarray(normal, dtype=np.float32), hdr=True, quality="balanced")


def _gpu_torch() -> Any:
    """torch, where a frame can stay on the GPU from path tracing to 8-bit image (the CUDA variant, with
    torch and Open Image Denoise's CUDA device to hand it between them); None elsewhere. Decided once."""
    if "torch" not in _FINISH:
        _FINISH["torch"] = None
        if photo_backend() == "cuda_ad_rgb" and importlib.util.find_spec("torch") is not None:
            import torch

            if torch.cuda.is_available() and load_oidn().Device.is_cuda_available():
                _FINISH["torch"] = torch
    return _FINISH["torch"]


def _finish_on_gpu(raw: Any, options: PhotoOptions, torch: Any) -> np.ndarray:
    """:meth:`PhotoTracer.rgb`'s clamp → denoise → tone curve as torch operations on Mitsuba's tensor
    ``raw`` (on the GPU for the CUDA variant): only the 8-bit image comes back to the host."""
    dr = load_drjit()
    dr.eval(raw)
    dr.sync_thread()  # the trace finished before torch reads its buffer
    t = raw.torch()
    color = torch.nan_to_num(t[..., :3], nan=0.0, posinf=_CLAMP).clamp(max=_CLAMP).contiguous()
    if options.denoise:
        color = load_oidn().denoise(color, t[..., 3:6].clamp(0, 1).contiguous(),
                                    t[..., 6:9].clamp(-1, 1).contiguous(), hdr=True, quality="balanced")
    gains = torch.as_tensor(white_balance(options.look), dtype=color.dtype, device=color.device)
    x = (color * gains).clamp(min=0.0) * (2.0 ** options.look.exposure) * (0.8 / _WHITE)
    y = _filmic(x).clamp(0.0, 1.0)
    srgb = torch.where(y <= 0.0031308, 12.92 * y, 1.055 * y.pow(1 / 2.4) - 0.055)
    return torch.round(srgb * 255.0).to(torch.uint8).cpu().numpy()


@dataclass(frozen=True)
class PhotoOptions:
    """Options of the photo preset.

    Attributes:
        look: lighting, textures and exposure (default: :func:`default_look`).
        spp: path samples per pixel (1 is enough with denoising; more for stills).
        denoise: run Open Image Denoise (off shows the raw path-traced noise).
        seed: sampler seed; every frame uses it, so a still scene does not flicker.
    """

    look: LookParams = field(default_factory=default_look)
    spp: int = DEFAULT_SPP
    denoise: bool = True
    seed: int = 0

    def __post_init__(self) -> None:
        if isinstance(self.spp, bool) or not isinstance(self.spp, int) or not 1 <= self.spp <= 4096:
            raise RenderError(f"photo spp={self.spp!r} is invalid; valid: an integer 1..4096")


class PhotoTracer:
    """Path-traced RGB frames of one model: builds the Mitsuba scene on the first frame, then poses it."""

    def __init__(self, model: mujoco.MjModel, options: PhotoOptions | None = None,
                 segmentation: np.ndarray | None = None, background: int = 0) -> None:
        """``segmentation``/``background``: per-geom ids for the geometry pass (see :class:`PhotoScene`)."""
        self.model = model
        self.options = options or PhotoOptions()
        self._segmentation = (segmentation, background)
        self._scene: PhotoScene | None = None
        self.frames = 0

    @property
    def scene(self) -> PhotoScene | None:
        """The Mitsuba scene, posed for the last frame (None before the first)."""
        return self._scene

    def radiance(self, data: mujoco.MjData, camera_id: int, width: int, height: int) -> np.ndarray:
        """(H, W, 9) float32 linear RGB, albedo and normal of one path-traced frame (before denoising)."""
        scene = self._pose(data, camera_id, width, height)
        return scene.render(self.options.spp, self.options.seed)

    def _pose(self, data: mujoco.MjData, camera_id: int, width: int, height: int) -> PhotoScene:
        if self._scene is None or self._scene.size != (width, height):
            self._scene = PhotoScene(self.model, data, width, height, self.options.look, *self._segmentation)
        self._scene.pose(data, camera_id, width, height)
        return self._scene

    def rgb(self, data: mujoco.MjData, camera_id: int, width: int, height: int) -> np.ndarray:
        """(H, W, 3) uint8 path-traced, denoised, tone-mapped image (finished on the GPU where it was traced
        there)."""
        torch = _gpu_torch()
        if torch is not None:
            scene = self._pose(data, camera_id, width, height)
            self.frames += 1
            return _finish_on_gpu(scene.render_tensor(self.options.spp, self.options.seed), self.options, torch)
        raw = self.radiance(data, camera_id, width, height)
        color = np.minimum(np.nan_to_num(raw[..., :3], nan=0.0, posinf=_CLAMP), _CLAMP)
        if self.options.denoise:
            color = denoise(color, np.clip(raw[..., 3:6], 0, 1), np.clip(raw[..., 6:9], -1, 1))
        self.frames += 1
        return tonemap(color * white_balance(self.options.look).astype(np.float32), self.options.look.exposure)


def photo_options(look: str = "fixed", seed: int = 0, spp: int = DEFAULT_SPP,
                  where: str = "photo look") -> PhotoOptions:
    """Photo options for a scene: ``look`` ``fixed`` (the default look) or ``random`` (drawn from ``seed``,
    the scene's seed: lights, colour temperature, textures and exposure).

    Raises:
        RenderError: an unknown look or a bad spp (one line, naming ``where``; a ``where`` that is a
            parameter's name, ``photo_look``, is the error's ``field``).
    """
    if look not in LOOKS:
        raise RenderError(f"{where}={look!r} is invalid; valid: {', '.join(LOOKS)}",
                          field=where if where.isidentifier() else None)
    return PhotoOptions(look=random_look(seed) if look == "random" else default_look(), spp=spp, seed=0)


def photo_info(options: PhotoOptions) -> dict[str, Any]:
    """What to record about photo renders in an annotation."""
    return {"renderer": "mitsuba3", "variant": photo_backend(), "spp": options.spp, "denoised": options.denoise,
            "seed": options.seed, "look": options.look.to_dict()}

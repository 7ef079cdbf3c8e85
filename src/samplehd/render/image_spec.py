"""One image request (:class:`ImageSpec`): which cameras, which modalities, at what size and render preset.

Every stage that asks the render floor for images hands it one of these instead of the five values
(render from states, rerender, replay, paths, the viewer and the commands); the render preset names
are the keys of :data:`samplehd.render.renderer.PRESETS`, the one list of them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from samplehd.errors import RenderError
from samplehd.render.photo.renderer import PhotoOptions
from samplehd.render.renderer import MODALITIES, PRESETS, SceneRenderer, check_size, get_preset, image_shape

__all__ = ["PRESET_NAMES", "ImageSpec"]

PRESET_NAMES: tuple[str, ...] = tuple(PRESETS)


@dataclass(frozen=True)
class ImageSpec:
    """Which images to render, from every camera named, in every modality named.

    Attributes:
        width: image width [px] (8..8192).
        height: image height [px] (8..8192).
        preset: render preset, one of :data:`PRESET_NAMES` (``fast``, ``hd``, the path-traced ``photo``).
        cameras: camera names, in order (checked against a model when it renders).
        modalities: any of ``rgb``, ``depth``, ``segmentation``, in order.

    Raises:
        RenderError: a bad size, an unknown preset or modality (the renderer's own one-line messages).
    """

    width: int = 320
    height: int = 180
    preset: str = "fast"
    cameras: tuple[str, ...] = ("scene",)
    modalities: tuple[str, ...] = ("rgb",)

    def __post_init__(self) -> None:
        check_size(self.width, self.height)
        get_preset(self.preset)
        for name in ("cameras", "modalities"):
            value = getattr(self, name)
            if isinstance(value, str) or not isinstance(value, Sequence):
                raise RenderError(f"{name} {value!r}: must be a list of names")
            object.__setattr__(self, name, tuple(value))
        bad = [m for m in self.modalities if m not in MODALITIES]
        if bad:
            raise RenderError(f"unknown modalities {bad}; valid: {', '.join(MODALITIES)}")

    def shape(self, modality: str) -> tuple[int, ...]:
        """The shape of one image of ``modality``: (H, W, 3) for rgb, (H, W) for depth and segmentation."""
        return image_shape(modality, self.width, self.height)

    def renderer(self, model: mujoco.MjModel, photo: PhotoOptions | None = None,
                 buffer_size: tuple[int, int] | None = None) -> SceneRenderer:
        """A :class:`~samplehd.render.renderer.SceneRenderer` of ``model`` at this size and preset."""
        return SceneRenderer(model, self.width, self.height, self.preset, buffer_size=buffer_size, photo=photo)

    def render(self, model: mujoco.MjModel, data: mujoco.MjData) -> dict[str, dict[str, np.ndarray]]:
        """One-shot: make a renderer, render ``images[camera][modality]`` of the state ``data``, free it."""
        with self.renderer(model) as r:
            return {camera: r.render(data, camera, self.modalities) for camera in self.cameras}

"""Which images a dataset's episodes get (:class:`RenderConfig`), rendered from the episodes' stored
physics states with :func:`samplehd.render.states.render_states` during ``samplehd generate``,
``samplehd rerender`` and ``samplehd paths``, so all give identical pixels.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from samplehd.errors import ConfigError
from samplehd.render.renderer import MODALITIES, camera_names
from samplehd.render.states import render_states
from samplehd.scene.world import compile_world

__all__ = ["RENDER_MODES", "RenderConfig", "check_cameras"]

RENDER_MODES = ("none", "fast", "hd")


@dataclass(frozen=True)
class RenderConfig:
    """Which images an episode gets.

    Attributes:
        mode: ``none`` (states only), or the render preset ``fast`` / ``hd``.
        width: image width [px].
        height: image height [px].
        cameras: camera names (``scene`` is the scene's sampled camera; ``operator``, ``wrist``).
        modalities: any of rgb, depth, segmentation.
    """

    mode: str = "fast"
    width: int = 320
    height: int = 180
    cameras: tuple[str, ...] = ("scene",)
    modalities: tuple[str, ...] = MODALITIES

    def __post_init__(self) -> None:
        if self.mode not in RENDER_MODES:
            raise ConfigError(f"render.mode={self.mode!r}: valid: {', '.join(RENDER_MODES)}")
        for name in ("width", "height"):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or not 8 <= v <= 8192:
                raise ConfigError(f"render.{name}={v!r}: must be an integer in 8..8192 px")
        if not self.cameras or not all(isinstance(c, str) and c for c in self.cameras):
            raise ConfigError(f"render.cameras={list(self.cameras)!r}: must be a non-empty list of camera names")
        bad = [m for m in self.modalities if m not in MODALITIES]
        if bad or not self.modalities:
            raise ConfigError(f"render.modalities={list(self.modalities)!r}: valid: {', '.join(MODALITIES)}")

    @property
    def enabled(self) -> bool:
        return self.mode != "none"

    def images(self, model: mujoco.MjModel, frames: Mapping[str, np.ndarray]) -> dict[str, dict[str, np.ndarray]]:
        """Render an episode's frames from its stored states: ``images[camera][modality]`` (first axis
        T), or ``{}`` for mode ``none``.

        Raises:
            DatasetError: the states do not fit the model.
            RenderError: unknown camera or no GL context.
        """
        if not self.enabled:
            return {}
        return render_states(model, frames, self.cameras, self.modalities, self.width, self.height, self.mode)

    def to_dict(self) -> dict[str, Any]:
        return {"mode": self.mode, "width": self.width, "height": self.height, "cameras": list(self.cameras),
                "modalities": list(self.modalities)}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], where: str = "render") -> RenderConfig:
        valid = {"mode", "width", "height", "cameras", "modalities"}
        unknown = sorted(set(d) - valid)
        if unknown:
            raise ConfigError(f"{where}: unknown option(s) {unknown}; valid: {', '.join(sorted(valid))}")
        kw = dict(d)
        for k in ("cameras", "modalities"):
            if k in kw:
                kw[k] = tuple(kw[k])
        return cls(**kw)


def check_cameras(config: RenderConfig) -> None:
    """Fail early (before any simulation) on a camera name no scene world has.

    Raises:
        ConfigError: naming the unknown cameras and the valid ones.
    """
    if not config.enabled:
        return

    valid = sorted({*camera_names(compile_world()[0]), "scene"})
    bad = [c for c in config.cameras if c not in valid]
    if bad:
        raise ConfigError(f"render.cameras: unknown camera(s) {bad}; valid: {', '.join(valid)}")

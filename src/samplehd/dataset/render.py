"""Render an episode's images from its stored physics states, without re-simulating.

For every frame the stored ``qpos``, ``qvel`` and ``act`` are written into the compiled scene's
``MjData`` and ``mj_forward`` computes the poses the renderer draws. The same function renders images
during ``samplehd generate`` and ``samplehd rerender``, so both give identical pixels.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from samplehd.errors import ConfigError
from samplehd.schema import bounded, check_fields, from_mapping

__all__ = ["RENDER_MODES", "RenderConfig", "check_cameras", "render_states"]

RENDER_MODES = ("none", "fast", "hd")
_MODALITIES = ("rgb", "depth", "segmentation")


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

    mode: str = bounded("fast", choices=RENDER_MODES)
    width: int = bounded(320, lo=8, hi=8192, unit="px")
    height: int = bounded(180, lo=8, hi=8192, unit="px")
    # Camera names are checked against the world by check_cameras (it compiles the world).
    cameras: tuple[str, ...] = bounded(("scene",), nonempty=True, unique=True)
    modalities: tuple[str, ...] = bounded(_MODALITIES, choices=_MODALITIES, nonempty=True, unique=True)

    def __post_init__(self) -> None:
        check_fields(self, "render")

    @property
    def enabled(self) -> bool:
        return self.mode != "none"

    def to_dict(self) -> dict[str, Any]:
        return {"mode": self.mode, "width": self.width, "height": self.height, "cameras": list(self.cameras),
                "modalities": list(self.modalities)}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], where: str = "render") -> RenderConfig:
        return from_mapping(cls, d, where)


def render_states(model: Any, frames: Mapping[str, np.ndarray], config: RenderConfig,
                  data: Any = None) -> dict[str, dict[str, np.ndarray]]:
    """Render every frame of an episode from its stored states.

    Args:
        model: the compiled scene (``compile_scene(spec)``).
        frames: the episode's frame arrays (``qpos``, ``qvel``, ``act`` are used).
        config: cameras, modalities, resolution and preset (mode must not be ``none``).
        data: an ``MjData`` to reuse (default: a new one).

    Returns:
        ``images[camera][modality]`` with first axis T: rgb uint8 (T,H,W,3), depth float32 (T,H,W) [m],
        segmentation int32 (T,H,W).

    Raises:
        RenderError: unknown camera or no GL context.
    """
    import mujoco

    from samplehd.render.renderer import SceneRenderer

    if not config.enabled:
        return {}
    data = data if data is not None else mujoco.MjData(model)
    qpos, qvel, act = frames["qpos"], frames["qvel"], frames["act"]
    t = len(qpos)
    out: dict[str, dict[str, np.ndarray]] = {}
    with SceneRenderer(model, config.width, config.height, config.mode) as r:
        for cam in config.cameras:
            stacks: dict[str, list[np.ndarray]] = {m: [] for m in config.modalities}
            for k in range(t):
                data.qpos[:] = qpos[k]
                data.qvel[:] = qvel[k]
                if model.na:
                    data.act[:] = act[k]
                mujoco.mj_forward(model, data)
                img = r.render(data, cam, config.modalities)
                for m in config.modalities:
                    stacks[m].append(img[m])
            out[cam] = {m: (np.stack(v) if v else np.zeros((0, config.height, config.width), np.float32))
                        for m, v in stacks.items()}
    return out


def check_cameras(config: RenderConfig) -> None:
    """Fail early (before any simulation) on a camera name no scene world has.

    Raises:
        ConfigError: naming the unknown cameras and the valid ones.
    """
    if not config.enabled:
        return
    valid = _world_cameras()
    bad = [c for c in config.cameras if c not in valid]
    if bad:
        raise ConfigError(f"render.cameras: unknown camera(s) {bad}; valid: {', '.join(valid)}")


@functools.cache
def _world_cameras() -> tuple[str, ...]:
    """Cameras of every scene world (compiled once per process) plus the scene's own ``scene``."""
    from samplehd.render.renderer import camera_names
    from samplehd.scene.world import compile_world

    return tuple(sorted({*camera_names(compile_world()[0]), "scene"}))


def camera_list(text: Sequence[str] | None, default: tuple[str, ...]) -> tuple[str, ...]:
    """Camera names from the command line (space or comma separated)."""
    if not text:
        return default
    return tuple(c for item in text for c in item.split(",") if c)

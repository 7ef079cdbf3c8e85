"""Render an episode's images from its stored physics states, without re-simulating.

For every frame the stored ``qpos``, ``qvel`` and ``act`` are written into the compiled scene's
``MjData`` and ``mj_forward`` computes the poses the renderer draws. The same function renders images
during ``samplehd generate`` and ``samplehd rerender``, so both give identical pixels.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from samplehd.errors import ConfigError

__all__ = ["RENDER_MODES", "RenderConfig", "check_cameras", "render_states"]

RENDER_MODES = ("none", "fast", "hd", "photo")
_MODALITIES = ("rgb", "depth", "segmentation")


@dataclass(frozen=True)
class RenderConfig:
    """Which images an episode gets.

    Attributes:
        mode: ``none`` (states only), or the render preset ``fast`` / ``hd`` / ``photo`` (path traced).
        width: image width [px].
        height: image height [px].
        cameras: camera names (``scene`` is the scene's sampled camera; ``operator``, ``wrist``).
        modalities: any of rgb, depth, segmentation.
        every: images at every N-th frame only (1: every frame; 0: none but the subtask ends).
        subtask_ends: also (or only) at the first and last frame of each subtask.
        look: photo preset: ``fixed``, or ``random`` (lights, textures, exposure from the scene's seed).
    """

    mode: str = "fast"
    width: int = 320
    height: int = 180
    cameras: tuple[str, ...] = ("scene",)
    modalities: tuple[str, ...] = _MODALITIES
    every: int = 1
    subtask_ends: bool = False
    look: str = "fixed"

    def __post_init__(self) -> None:
        if self.mode not in RENDER_MODES:
            raise ConfigError(f"render.mode={self.mode!r}: valid: {', '.join(RENDER_MODES)}")
        for name in ("width", "height"):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or not 8 <= v <= 8192:
                raise ConfigError(f"render.{name}={v!r}: must be an integer in 8..8192 px")
        if not self.cameras or not all(isinstance(c, str) and c for c in self.cameras):
            raise ConfigError(f"render.cameras={list(self.cameras)!r}: must be a non-empty list of camera names")
        bad = [m for m in self.modalities if m not in _MODALITIES]
        if bad or not self.modalities:
            raise ConfigError(f"render.modalities={list(self.modalities)!r}: valid: {', '.join(_MODALITIES)}")
        if not isinstance(self.subtask_ends, bool):
            raise ConfigError(f"render.subtask_ends={self.subtask_ends!r}: must be true or false")
        from samplehd.render.keyframes import keyframe_indices

        keyframe_indices(0, self.every, None, self.subtask_ends)  # validates every
        if self.look not in ("fixed", "random"):
            raise ConfigError(f"render.look={self.look!r}: valid: fixed, random")

    def keyframes(self, num_frames: int, subtask_index: np.ndarray | None) -> np.ndarray:
        """Frames of an episode that get images."""
        from samplehd.render.keyframes import keyframe_indices

        return keyframe_indices(num_frames, self.every, subtask_index, self.subtask_ends)

    @property
    def enabled(self) -> bool:
        return self.mode != "none"

    def to_dict(self) -> dict[str, Any]:
        d = {"mode": self.mode, "width": self.width, "height": self.height, "cameras": list(self.cameras),
             "modalities": list(self.modalities)}
        # Only where set, so that records of every-frame images stay as they were.
        if self.every != 1:
            d["every"] = self.every
        if self.subtask_ends:
            d["subtask_ends"] = True
        if self.look != "fixed":
            d["look"] = self.look
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], where: str = "render") -> RenderConfig:
        valid = {"mode", "width", "height", "cameras", "modalities", "every", "subtask_ends", "look"}
        unknown = sorted(set(d) - valid)
        if unknown:
            raise ConfigError(f"{where}: unknown option(s) {unknown}; valid: {', '.join(sorted(valid))}")
        kw = dict(d)
        for k in ("cameras", "modalities"):
            if k in kw:
                kw[k] = tuple(kw[k])
        return cls(**kw)


def render_states(model: Any, frames: Mapping[str, np.ndarray], config: RenderConfig,
                  data: Any = None, seed: int = 0) -> dict[str, Any]:
    """Render every frame (or the keyframes) of an episode from its stored states.

    Args:
        model: the compiled scene (``compile_scene(spec)``).
        frames: the episode's frame arrays (``qpos``, ``qvel``, ``act`` are used; ``subtask_index``
            for subtask-end keyframes).
        config: cameras, modalities, resolution and preset (mode must not be ``none``).
        data: an ``MjData`` to reuse (default: a new one).
        seed: the scene's seed (the photo preset's randomised look is drawn from it).

    Returns:
        ``images[camera][modality]`` with first axis T: rgb uint8 (T,H,W,3), depth float32 (T,H,W) [m],
        segmentation int32 (T,H,W); with keyframes, a :class:`~samplehd.dataset.container.SparseFrames`.

    Raises:
        RenderError: unknown camera or no GL context.
    """
    import mujoco

    from samplehd.render.renderer import SceneRenderer

    if not config.enabled:
        return {}
    from samplehd.dataset.container import SparseFrames
    from samplehd.render.renderer import get_preset

    data = data if data is not None else mujoco.MjData(model)
    qpos, qvel, act = frames["qpos"], frames["qvel"], frames["act"]
    t = len(qpos)
    picks = config.keyframes(t, frames.get("subtask_index"))
    photo = None
    if get_preset(config.mode).path_traced:
        from samplehd.render.photo import photo_options

        photo = photo_options(config.look, seed, where="render.look")
    out: dict[str, dict[str, Any]] = {}
    with SceneRenderer(model, config.width, config.height, config.mode, photo=photo) as r:
        for cam in config.cameras:
            stacks: dict[str, list[np.ndarray]] = {m: [] for m in config.modalities}
            for k in picks:
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
            if len(picks) < t:
                out[cam] = {m: SparseFrames(picks, v, t) for m, v in out[cam].items()}
    return out


def check_cameras(config: RenderConfig) -> None:
    """Fail early (before any simulation) on a camera name no scene world has.

    Raises:
        ConfigError: naming the unknown cameras and the valid ones.
    """
    if not config.enabled:
        return
    from samplehd.render.renderer import camera_names
    from samplehd.scene.world import compile_world

    valid = sorted({*camera_names(compile_world()[0]), "scene"})
    bad = [c for c in config.cameras if c not in valid]
    if bad:
        raise ConfigError(f"render.cameras: unknown camera(s) {bad}; valid: {', '.join(valid)}")


def camera_list(text: Sequence[str] | None, default: tuple[str, ...]) -> tuple[str, ...]:
    """Camera names from the command line (space or comma separated)."""
    if not text:
        return default
    return tuple(c for item in text for c in item.split(",") if c)

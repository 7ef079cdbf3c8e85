"""Which images a dataset's episodes get (:class:`RenderConfig`), rendered from the episodes' stored
physics states with :func:`samplehd.render.states.render_states` during ``samplehd generate``,
``samplehd rerender`` and ``samplehd paths``, so all give identical pixels (``samplehd generate`` draws
them from the same states while the path is recorded: :meth:`RenderConfig.images_live`).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from samplehd.errors import ConfigError
from samplehd.render.deflated import deflating
from samplehd.render.image_spec import PRESET_NAMES, ImageSpec
from samplehd.render.keyframes import SparseFrames, keyframe_indices
from samplehd.render.photo import LOOKS, photo_options
from samplehd.render.renderer import IMAGE_DTYPES, MODALITIES, camera_names, get_preset, stored_segmentation_dtype
from samplehd.render.states import LiveStates, render_live, render_states
from samplehd.scene.world import compile_world
from samplehd.schema import Config, bounded

__all__ = ["RENDER_MODES", "RenderConfig", "check_render_applies", "check_cameras"]

# ``none`` (states only) or a render preset.
RENDER_MODES = ("none", *PRESET_NAMES)


@dataclass(frozen=True)
class RenderConfig(Config, section="render"):
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

    mode: str = bounded("fast", choices=RENDER_MODES)
    width: int = bounded(320, lo=8, hi=8192, unit="px")
    height: int = bounded(180, lo=8, hi=8192, unit="px")
    # Camera names are checked against the world by check_cameras (it compiles the world).
    cameras: tuple[str, ...] = bounded(("scene",), nonempty=True, unique=True)
    modalities: tuple[str, ...] = bounded(MODALITIES, choices=MODALITIES, nonempty=True, unique=True)
    every: int = 1
    subtask_ends: bool = False
    look: str = bounded("fixed", choices=LOOKS)

    def __post_init__(self) -> None:
        super().__post_init__()
        keyframe_indices(0, self.every, None, self.subtask_ends)  # validates every

    def keyframes(self, num_frames: int, subtask_index: np.ndarray | None) -> np.ndarray:
        """Frames of an episode that get images."""
        return keyframe_indices(num_frames, self.every, subtask_index, self.subtask_ends)

    @property
    def enabled(self) -> bool:
        return self.mode != "none"

    @property
    def image(self) -> ImageSpec:
        """The image request of this config (mode ``none`` has none).

        Raises:
            ValueError: mode ``none``.
        """
        if not self.enabled:
            raise ValueError("render mode 'none' requests no images")
        return ImageSpec(self.width, self.height, self.mode, self.cameras, self.modalities)

    def images(self, model: mujoco.MjModel, frames: Mapping[str, np.ndarray],
               seed: int = 0, deflated: bool = False) -> dict[str, dict[str, Any]]:
        """Render an episode's frames from its stored states: ``images[camera][modality]`` (first axis
        T), or ``{}`` for mode ``none``. With keyframes (``every``, ``subtask_ends``) each stream is a
        :class:`~samplehd.render.keyframes.SparseFrames`. ``seed``: the scene's seed (the photo
        preset's randomised look is drawn from it). ``deflated``: each stream is a
        :class:`~samplehd.render.deflated.DeflatedFrames`, every frame deflated as soon as it is rendered (on a
        helper thread, while the next frames render: ``render_states(overlap=True)``),
        in the dtype the episode file stores (segmentation uint8, or uint16 for a scene with ids past 255),
        for writing (about a tenth of the memory of the raw frames, and no fresh memory per frame).

        Raises:
            DatasetError: the states do not fit the model.
            RenderError: unknown camera or no GL context.
        """
        if not self.enabled:
            return {}
        t = len(frames["qpos"])
        picks = self.keyframes(t, frames.get("subtask_index"))
        photo = photo_options(self.look, seed, where="render.look") if get_preset(self.mode).path_traced else None
        args = (model, frames, self.image)
        if deflated:
            seg = stored_segmentation_dtype(model)
            streams, keep = self._deflating(seg)
            images: dict[str, dict[str, Any]] = dict(streams)
            render_states(*args, indices=picks.tolist(), photo=photo, on_frame=keep, segmentation_dtype=seg,
                          overlap=True)
        else:
            images = render_states(*args, indices=picks.tolist(), photo=photo)
        if len(picks) == t:
            return images
        return {c: {m: SparseFrames(picks, v, t) for m, v in mods.items()} for c, mods in images.items()}

    def _deflating(self, segmentation_dtype: Any) -> tuple[dict[str, dict[str, Any]], Any]:
        """Empty deflated streams of this config's images, and the ``on_frame`` that fills them."""
        dtypes = {**IMAGE_DTYPES, "segmentation": segmentation_dtype}
        image = self.image
        return deflating(image.cameras, {m: image.shape(m) for m in image.modalities}, dtypes)

    @property
    def every_frame(self) -> bool:
        """Whether every frame of an episode gets images (no keyframes)."""
        return self.every == 1

    def images_live(self, model: mujoco.MjModel, live: LiveStates, seed: int = 0) -> dict[str, dict[str, Any]] | None:
        """:meth:`images` (``deflated``) of an episode while its rollout is recorded, drawn from its states as
        they come (:func:`samplehd.render.states.render_live`): the same frames, rendered beside the physics
        instead of after it. Only for configs that render :attr:`every_frame` (which frames the keyframes are
        depends on the whole episode).

        Returns:
            The images of the attempt that became the episode, or None when the rollout ended without one.

        Raises:
            DatasetError: the states do not fit the model.
            RenderError: unknown camera or no GL context.
        """
        if not (self.enabled and self.every_frame):
            raise ValueError(f"images_live renders every frame; render.every={self.every}, mode {self.mode!r}")
        photo = photo_options(self.look, seed, where="render.look") if get_preset(self.mode).path_traced else None
        seg = stored_segmentation_dtype(model)
        kept: list[dict[str, dict[str, Any]]] = []

        def on_attempt() -> Any:
            streams, keep = self._deflating(seg)
            kept[:] = [dict(streams)]
            return keep

        done = render_live(model, live, on_attempt, self.image, photo=photo, segmentation_dtype=seg)
        return None if done is None else kept[0]

    def to_dict(self) -> dict[str, object]:
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
    return tuple(sorted({*camera_names(compile_world()[0]), "scene"}))


# The render fields that only matter when episode frames are drawn. width and height are not among them:
# they also size each scene's own images (RGB, depth, segmentation), drawn whatever the mode.
_IMAGE_FIELDS = ("cameras", "modalities", "every", "subtask_ends", "look")


def check_render_applies(render: RenderConfig, given: Mapping[str, str]) -> None:
    """Refuse render fields a user set that do nothing with the render mode chosen.

    Args:
        render: the resolved settings.
        given: field name -> where the user set it (``--cameras``, ``run.json render.cameras``).

    Raises:
        ConfigError: an image field with mode ``none``, or ``look`` with a preset that is not path traced.
    """
    if not render.enabled:
        for name in _IMAGE_FIELDS:
            if name in given:
                raise ConfigError(f"{given[name]}: render.{name} does nothing with render mode 'none' (states "
                                  f"only); remove it or choose a render mode ({', '.join(PRESET_NAMES)})")
    elif "look" in given and not get_preset(render.mode).path_traced:
        raise ConfigError(f"{given['look']}: render.look is for the photo preset only, not {render.mode!r}; remove "
                          f"it or render with photo")

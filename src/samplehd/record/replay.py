"""Replay of recorded episodes: per-subtask contact sheets rendered from the stored states (videos
and single frames come from :mod:`samplehd.render.states` and :mod:`samplehd.render.video`)."""

from __future__ import annotations

import mujoco
import numpy as np

from samplehd.record.episode import Episode
from samplehd.render.contact_sheet import contact_sheet
from samplehd.render.image_spec import ImageSpec
from samplehd.render.states import render_states
from samplehd.scene.world import OPERATOR_CAMERA

__all__ = ["subtask_contact_sheet"]


def subtask_contact_sheet(model: mujoco.MjModel, episode: Episode, image: ImageSpec | None = None,
                          cols: int = 4) -> np.ndarray:
    """One image per subtask (its last frame), labelled ``index: name``, tiled ``cols`` per row.

    ``image``: the first of its cameras, in rgb, at its size and preset (default: ``operator``, 320x180, fast).
    """
    image = image or ImageSpec(320, 180, "fast", (OPERATOR_CAMERA.name,))
    camera = image.cameras[0]
    image = ImageSpec(image.width, image.height, image.preset, (camera,), ("rgb",))
    sub = episode.frames["subtask_index"]
    picks, labels = [], []
    if episode.num_frames == 0:
        return np.full(image.shape("rgb"), 255, np.uint8)
    for s, name in enumerate(episode.subtasks):
        ks = np.flatnonzero(sub == s)
        if len(ks):
            picks.append(int(ks[-1]))
            labels.append(f"{s}: {name}")
    images = render_states(model, episode.frames, image, picks)
    return contact_sheet(list(images[camera]["rgb"]), cols, labels, gap=0)

"""Which frames of an episode get images when not every frame is rendered (keyframes).

Path-traced images cost about a second per frame on a CPU, so a dataset can be made photoreal at
keyframes only: every N-th frame, and/or the first and last frame of each subtask.
"""

from __future__ import annotations

import numpy as np

from samplehd.errors import ConfigError, DatasetError
from samplehd.render.deflated import DeflatedFrames

__all__ = ["SparseFrames", "keyframe_indices"]


def keyframe_indices(num_frames: int, every: int = 1, subtask_index: np.ndarray | None = None,
                     subtask_ends: bool = False) -> np.ndarray:
    """Sorted frame indices to render.

    Args:
        num_frames: frames of the episode (T).
        every: every N-th frame from frame 0 (1 = all frames; 0 = none, only subtask ends).
        subtask_index: per-frame subtask index (needed for ``subtask_ends``).
        subtask_ends: also the first and last frame of each subtask.

    Raises:
        ConfigError: ``every`` is not a non-negative integer, or no frame would be chosen.
    """
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 0:
        raise ConfigError(f"render.every={every!r} is invalid; valid: an integer >= 0 (1: every frame)")
    if every == 0 and not subtask_ends:
        raise ConfigError("render.every=0 renders no frame; valid: every >= 1, or every 0 with subtask_ends")
    picks: set[int] = set(range(0, num_frames, int(every))) if every else set()
    if subtask_ends and num_frames:
        idx = np.asarray(subtask_index if subtask_index is not None else np.zeros(num_frames, int))
        change = np.flatnonzero(np.diff(idx) != 0)
        picks.update([0, num_frames - 1, *change.tolist(), *(change + 1).tolist()])
    return np.array(sorted(picks), dtype=np.int64)


class SparseFrames:
    """Images of an episode at some of its frames (keyframes): ``images[k]`` is frame ``frames[k]``.

    Stands for a length-T image stream; ``samplehd.dataset.container.write_episode`` stores only the K images.
    """

    def __init__(self, frames: np.ndarray, images: np.ndarray | DeflatedFrames, num_frames: int) -> None:
        self.frames = np.asarray(frames, dtype=np.int64)
        self.images = images if isinstance(images, DeflatedFrames) else np.asarray(images)
        self.num_frames = int(num_frames)
        if len(self.frames) != len(self.images):
            raise DatasetError(f"{len(self.images)} keyframe images for {len(self.frames)} frame indices")

    def __len__(self) -> int:
        return self.num_frames

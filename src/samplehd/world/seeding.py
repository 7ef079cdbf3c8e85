"""Seeding rules: how every scene and every episode gets its own seed from a dataset's base seed.

Each seed is drawn from a :class:`numpy.random.SeedSequence` keyed by the base seed and the item's
indices, so items are independent streams: a scene's content does not depend on how many scenes came
before it, which worker made it, or whether the run was resumed.
"""

from __future__ import annotations

import numpy as np

__all__ = ["episode_seed", "scene_seed"]


def scene_seed(base_seed: int, index: int) -> int:
    """The seed of scene `index` of a dataset with `base_seed` (independent streams per scene)."""
    return int(np.random.SeedSequence([int(base_seed), int(index)]).generate_state(1, np.uint32)[0])


def episode_seed(base_seed: int, scene_index: int, slot: int) -> int:
    """The seed of instruction slot ``slot`` of scene ``scene_index`` (independent of everything else)."""
    ss = np.random.SeedSequence([int(base_seed), 1, int(scene_index), int(slot)])
    return int(ss.generate_state(1, np.uint32)[0])

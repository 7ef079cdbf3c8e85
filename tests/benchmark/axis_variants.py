"""A helper of the axis tests: the first variant of a twin that an axis can make."""

from __future__ import annotations

from samplehd.benchmark.axes import perturb
from samplehd.errors import SceneError


def first_variant(twin: dict, axis: str, strength: int, attempts: int = 6) -> dict:
    """The variant of the first attempt that can be made (an attempt may find no free spot, or no
    instruction that keeps each object's role)."""
    for attempt in range(attempts):
        try:
            return perturb(twin, axis, strength, seed=0, attempt=attempt)
        except SceneError:
            pass
    raise AssertionError(f"no {axis} variant of {twin['instruction']!r} at strength {strength}")

"""Performance measurements behind ``samplehd bench`` and ``benchmarks/``.

Each area module defines ``run(repeats: int) -> list[Figure]``. Figures are medians of repeated
runs; ratios are measured in the same run. Nothing here is asserted in tests.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass

__all__ = ["Figure", "median_rate"]


@dataclass(frozen=True)
class Figure:
    """One measured figure.

    Attributes:
        area: what was measured (robot, render, language, ...).
        name: the figure's name, e.g. ``rgb fps 640x360 fast``.
        value: the median over repeats.
        unit: unit of the value (``1/s``, ``ratio``, ``s``).
        note: how it was measured.
    """

    area: str
    name: str
    value: float
    unit: str
    note: str = ""

    def to_dict(self) -> dict[str, object]:
        return asdict(self)


def median_rate(fn: Callable[[], object], count: int, repeats: int) -> float:
    """Median over `repeats` of `count` calls per second of wall time of ``fn``."""
    rates = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(count):
            fn()
        rates.append(count / (time.perf_counter() - t0))
    return statistics.median(rates)

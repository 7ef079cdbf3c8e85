"""Performance measurements behind ``samplehd bench``, the one home of the benchmarks.

Each area module defines ``run(repeats: int) -> list[Figure]`` (the figures ``samplehd bench``
tabulates) and may define ``add_arguments(parser)`` and ``report(args) -> int`` for its detailed
report (``samplehd bench AREA ...``). Figures are medians of repeated runs; ratios are measured in the
same run. Nothing here is asserted in tests.
"""

from __future__ import annotations

import json
import os
import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

__all__ = ["Figure", "median_rate", "pin_to_one_core", "print_figures"]


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


def print_figures(figures: list[Figure], json_path: Path | None = None) -> None:
    """Print one line per figure; also write them as JSON to ``json_path`` when given."""
    for f in figures:
        print(f"{f.name:64s} {f.value:12.3f} {f.unit:5s} ({f.note})")
    if json_path is not None:
        Path(json_path).write_text(json.dumps([f.to_dict() for f in figures], indent=1))


def pin_to_one_core(last: bool = False) -> None:
    """Run this process on one core (the first, or the last), so single-thread figures are stable."""
    if hasattr(os, "sched_setaffinity"):
        cores = os.sched_getaffinity(0)
        os.sched_setaffinity(0, {max(cores) if last else min(cores)})

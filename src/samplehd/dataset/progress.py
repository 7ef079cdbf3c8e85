"""Progress of dataset jobs: the receiver interface and its rich progress bars (overall and per
stage, with rate and ETA)."""

from __future__ import annotations

import time
from types import TracebackType
from typing import Any

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.progress import Progress as RichBars

__all__ = ["Progress", "RichProgress"]


class Progress:
    """Receives progress events; the default does nothing (the CLI draws rich progress bars)."""

    def stage(self, name: str, total: int, done: int = 0) -> None:
        """A stage starts with ``total`` units, ``done`` of them already finished (resume)."""

    def advance(self, name: str, n: int = 1, frames: int = 0) -> None:
        """``n`` units of stage ``name`` finished, producing ``frames`` frames."""

    def note(self, text: str) -> None:
        """A one-line message."""


class RichProgress(Progress):
    """Draws one bar per stage plus an overall bar (units done / total, rate, elapsed, ETA).

    Args:
        disable: draw nothing (messages still go to stderr when not a terminal? no: quiet).
    """

    def __init__(self, disable: bool = False) -> None:
        self.console = Console(stderr=True, quiet=disable)
        self.bars = RichBars(
            TextColumn("{task.description:>12}"), BarColumn(), MofNCompleteColumn(),
            TextColumn("{task.fields[rate]:>7.2f}/s"), TextColumn("{task.fields[extra]}"),
            TimeElapsedColumn(), TextColumn("eta"), TimeRemainingColumn(),
            console=self.console, disable=disable, refresh_per_second=4,
        )
        self.tasks: dict[str, Any] = {}
        self.totals: dict[str, int] = {}
        self.done: dict[str, int] = {}
        self.started: dict[str, float] = {}
        self.frames = 0
        self.t0 = time.perf_counter()
        self.overall = self.bars.add_task("overall", total=None, rate=0.0, extra="")

    def __enter__(self) -> RichProgress:
        self.bars.__enter__()
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.bars.__exit__(exc_type, exc, tb)

    def _overall(self) -> None:
        total = sum(self.totals.values())
        done = sum(self.done.values())
        dt = max(time.perf_counter() - self.t0, 1e-6)
        self.bars.update(self.overall, total=total, completed=done, rate=done / dt,
                         extra=f"{self.frames} frames, {self.frames / dt:.0f} frames/s")

    def stage(self, name: str, total: int, done: int = 0) -> None:
        if name not in self.tasks:
            self.tasks[name] = self.bars.add_task(name, total=total, completed=done, rate=0.0, extra="")
            self.started[name] = time.perf_counter()
            self.done[name] = done
            self._base = getattr(self, "_base", {})
            self._base[name] = done
        self.totals[name] = total
        self.done[name] = min(self.done[name], total) if done <= self.done[name] else done
        self.bars.update(self.tasks[name], total=total, completed=self.done[name])
        self._overall()

    def advance(self, name: str, n: int = 1, frames: int = 0) -> None:
        if name not in self.tasks:
            self.stage(name, n)
        self.done[name] += n
        self.frames += frames
        dt = max(time.perf_counter() - self.started[name], 1e-6)
        rate = (self.done[name] - self._base.get(name, 0)) / dt
        extra = f"{self.frames} frames" if name == "paths" else ""
        self.bars.update(self.tasks[name], completed=self.done[name], rate=rate, extra=extra)
        self._overall()

    def note(self, text: str) -> None:
        self.console.log(text)

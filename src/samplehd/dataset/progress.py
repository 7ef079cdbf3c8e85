"""Rich progress bars for dataset generation: overall and per stage, with rate and ETA."""

from __future__ import annotations

import time
from pathlib import Path
from types import TracebackType
from typing import Any

from samplehd.dataset.generate import GenerateSummary, Progress

__all__ = ["RichProgress", "print_summary"]


class RichProgress(Progress):
    """Draws one bar per stage plus an overall bar (units done / total, rate, elapsed, ETA).

    Args:
        disable: draw nothing (messages still go to stderr when not a terminal? no: quiet).
    """

    def __init__(self, disable: bool = False) -> None:
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )
        from rich.progress import Progress as RichBars

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


def print_summary(out: Path, summary: GenerateSummary, config: Any) -> None:
    """The final summary of a run, on stdout."""
    from rich.console import Console
    from rich.table import Table

    console = Console()
    t = Table(title=f"dataset {out}", show_header=False)
    t.add_row("scenes", str(summary.scenes))
    t.add_row("instruction candidates", f"{summary.candidates} ({summary.attempted} attempted)")
    rate = summary.episodes / max(summary.attempted, 1)
    t.add_row("episodes", f"{summary.episodes} ({rate:.0%} of attempted paths succeeded)")
    if config.target_episodes:
        t.add_row("target", f"{config.target_episodes} ({'reached' if summary.target_reached else 'NOT reached'})")
    t.add_row("families", ", ".join(f"{k} {v}" for k, v in summary.families.items()))
    t.add_row("frames", f"{summary.frames} ({summary.frames / max(summary.episodes, 1):.0f} per episode)")
    t.add_row("path rejections", ", ".join(f"{k} {v}" for k, v in summary.rejections.items()) or "none")
    t.add_row("scene rejections", ", ".join(f"{k} {v}" for k, v in summary.scene_rejections.items()) or "none")
    t.add_row("wall time", f"{summary.seconds:.1f} s ({summary.units_run} path units run, "
                           f"{summary.frames / max(summary.seconds, 1e-9):.0f} frames/s overall)")
    console.print(t)
    if not summary.target_reached:
        console.print(f"[yellow]only {summary.episodes} of the target {config.target_episodes} episodes: "
                      f"raise instructions.per_scene or num_scenes[/yellow]")

"""The performance table of docs/PERFORMANCE.md, measured in one run: ``samplehd bench --report [FILE]``.

Every row is measured in the same process, one after another, and carries the command that gives
its figures on its own. The machine is often shared, so rates are given per wall second and per
CPU second of this process (``time.process_time``: every thread of it, the rasteriser's threads of
Mesa's llvmpipe included); the header says when, on what machine, under which load average and at
which commit the table was measured. The table replaces the text between two markers in FILE.
"""

from __future__ import annotations

import datetime
import os
import statistics
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypedDict

import mujoco
import numpy as np

from samplehd.bench import pin_to_one_core
from samplehd.bench.language import bench_object_counts
from samplehd.bench.paths import _bench_scene
from samplehd.bench.provenance import machine_description, measured_commit
from samplehd.dataset.container import read_frames
from samplehd.dataset.journal import JournalRecord
from samplehd.dataset.layout import EPISODE_DIR
from samplehd.dataset.render import RenderConfig
from samplehd.dataset.work import EpisodeUnit, run_episode_unit
from samplehd.errors import ConfigError
from samplehd.motion.assist import compile_scene_with_assist
from samplehd.record.paths import PathConfig
from samplehd.render.backend import configure_gl_backend
from samplehd.render.renderer import MODALITIES, SceneRenderer
from samplehd.render.states import pose_state
from samplehd.scene.world import OPERATOR_CAMERA, compile_world
from samplehd.tasks.task import Task
from samplehd.workers import keep_freed_memory
from samplehd.world.layout import DIRECTIONS

__all__ = ["BEGIN", "END", "Row", "measure", "table_markdown", "write_report"]

BEGIN = "<!-- performance table: made by `samplehd bench --report docs/PERFORMANCE.md`; edits here are overwritten -->"
END = "<!-- end of performance table -->"


@dataclass(frozen=True)
class Row:
    """One line of the table: what, per wall second, per CPU second, and the command to measure it alone."""

    figure: str
    wall: str
    cpu: str
    command: str


def _cpu() -> float:
    return time.process_time()


def _median_pair(fn: Callable[[], int], repeats: int) -> tuple[float, float]:
    """Median count/s over wall time and over this process's CPU time of ``fn`` (which returns a count)."""
    wall, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), _cpu()
        n = fn()
        t1, c1 = time.perf_counter(), _cpu()
        wall.append(n / max(t1 - t0, 1e-9))
        cpu.append(n / max(c1 - c0, 1e-9))
    return statistics.median(wall), statistics.median(cpu)


def _fmt(x: float) -> str:
    if x >= 10_000:
        return f"{x / 1000:,.1f} k"
    if x >= 100:
        return f"{x:,.0f}"
    if x >= 10:
        return f"{x:.1f}"
    return f"{x:.2f}"


def _language_rows(repeats: int) -> list[Row]:

    cores = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
    pin_to_one_core()
    try:
        counts = bench_object_counts(scenes=40, repeats=repeats)
    finally:
        if cores is not None:
            os.sched_setaffinity(0, cores)
    rows = counts["rows"]
    wall = " / ".join(_fmt(r["instructions_per_wall_s"]) for r in rows)
    cpu = " / ".join(_fmt(r["instructions_per_s"]) for r in rows)
    objects = " / ".join(str(r["objects"]) for r in rows)
    return [Row(f"instructions/s on one core, scenes of {objects} objects, every constraint on "
                f"(log-log slope of time per scene {counts['slope_ms_per_scene']:.2f})",
                wall, cpu, "`samplehd bench --report FILE --only language`")]


def _path_rows(repeats: int) -> list[Row]:
    """Pure render of the paths benchmark scene, and the dataset's real episode unit (plan, execute,
    check, render from the states, write the HDF5 file) with and without those images.

    The renderer's reference rate is that of drawing the very states the episode unit draws (each state's
    poses computed outside the timing, one ``render`` call per frame timed): the arm's poses along a path
    cost more to draw than the scene's first state, whose rate is shown beside it. The share of the
    renderer's rate is the median over ``repeats + 2`` pairs of the unit and the renderer run one right after
    the other (the machine's speed drifts between repeats more than within a pair), with their range.
    """
    scene = _bench_scene()
    task = Task("place", (1,), part="left")
    rows: list[Row] = []
    keep_freed_memory()  # as the episode units of `samplehd generate` run, in or out of this process
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / EPISODE_DIR).mkdir()

        def unit(render: RenderConfig, seed: int) -> JournalRecord:
            u = EpisodeUnit(tmp, f"e{seed}.h5", 0, seed, seed, "place", task, "put the soda can on the left",
                            "train", scene, {k: list(v) for k, v in DIRECTIONS.items()}, PathConfig(), render)
            out = run_episode_unit(u)
            if not out.ok:
                raise RuntimeError(f"benchmark episode failed: {out}")
            return out.to_dict()

        states = RenderConfig(mode="none")
        frames = int(unit(states, 0)["num_frames"])
        done = [unit(states, r) for r in range(repeats)]
        s_wall = statistics.median(d["num_frames"] / d["seconds"] for d in done)
        s_cpu = statistics.median(d["num_frames"] / d["cpu_seconds"] for d in done)
        rows.append(Row(f"ground-truth path frames/s, states only (plan, execute, check, write; {frames} frames)",
                        _fmt(s_wall), _fmt(s_cpu), "`samplehd bench --report FILE --only paths`"))
        model, data = compile_scene_with_assist(scene)
        for w, h in ((320, 180), (640, 360)):
            images = RenderConfig("fast", w, h, (OPERATOR_CAMERA.name,), MODALITIES)
            # Side by side, repeat by repeat (the load of a shared machine drifts): the renderer alone on the
            # scene's first state, the episode unit with images, and the renderer alone on that episode's states.
            first, done, pure = [], [], []
            with SceneRenderer(model, w, h, "fast") as r:
                # Into one set of frame buffers, as the episode renders (no fresh memory per frame).
                out = r.render(data, OPERATOR_CAMERA.name, MODALITIES)  # warm-up: the first frame uploads textures

                def draw(r: SceneRenderer = r, out: dict[str, np.ndarray] = out) -> tuple[int, float, float]:
                    t0, c0 = time.perf_counter(), _cpu()
                    for _ in range(frames):
                        r.render(data, OPERATOR_CAMERA.name, MODALITIES, out=out)
                    return frames, time.perf_counter() - t0, _cpu() - c0

                for k in range(repeats + 2):
                    first.append(_rates(*draw()))
                    done.append(unit(images, k))
                    stored = read_frames(Path(tmp) / EPISODE_DIR / f"e{k}.h5", ("qpos", "qvel", "act", "time"))
                    pure.append(_rates(*_draw_states(r, stored, out)))
            p_wall, p_cpu = (statistics.median(x[i] for x in pure) for i in (0, 1))
            i_wall = statistics.median(d["num_frames"] / d["seconds"] for d in done)
            i_cpu = statistics.median(d["num_frames"] / d["cpu_seconds"] for d in done)
            shares = {key: sorted(d["num_frames"] / d[sec] / x[i] for d, x in zip(done, pure, strict=True))
                      for key, sec, i in (("wall", "seconds", 0), ("CPU", "cpu_seconds", 1))}

            def share(key: str, shares: dict[str, list[float]] = shares) -> str:
                v = shares[key]
                return f"{statistics.median(v):.0%} {key} ({v[0]:.0%}–{v[-1]:.0%})"

            f_ms = 1000 / statistics.median(x[1] for x in first)

            def ms(key: str, done: list[JournalRecord] = done) -> float:
                return 1000 * statistics.median(d[key] / d["num_frames"] for d in done)

            what = f"`fast` RGB+depth+segmentation {w}×{h}, operator camera"
            rows.append(Row(f"render frames/s, {what} (renderer alone, drawing the states of the episode below "
                            "into one set of frame buffers; "
                            f"{1000 / p_cpu:.1f} CPU ms per frame, {f_ms:.1f} on the scene's first state)",
                            _fmt(p_wall), _fmt(p_cpu), "`samplehd bench --report FILE --only paths`"))
            rows.append(Row(f"ground-truth path frames/s with {what} (as above, images rendered from the states "
                            f"and written); share of the renderer's rate on the same states, median of {len(done)} "
                            f"pairs run in turn (range): {share('wall')}, {share('CPU')}; "
                            "CPU ms per frame: plan and execute "
                            f"{ms('path_cpu_seconds'):.1f}, render from the states {ms('render_cpu_seconds'):.1f}, "
                            f"write {ms('write_cpu_seconds'):.1f}",
                            _fmt(i_wall), _fmt(i_cpu), "`samplehd bench --report FILE --only paths`"))
    return rows


def _rates(count: int, wall: float, cpu: float) -> tuple[float, float]:
    """count/s over wall time and over this process's CPU time."""
    return count / max(wall, 1e-9), count / max(cpu, 1e-9)


def _draw_states(r: SceneRenderer, frames: dict[str, np.ndarray],
                 out: dict[str, np.ndarray]) -> tuple[int, float, float]:
    """Draw every recorded state once into ``out``: (frames, wall seconds, CPU seconds) of the ``render`` calls
    alone (each state's poses are computed before its call, outside the timing; nothing is kept)."""
    d = mujoco.MjData(r.model)
    wall = cpu = 0.0
    for k in range(len(frames["qpos"])):
        pose_state(r.model, d, frames["qpos"][k], frames["qvel"][k], frames["act"][k], frames["time"][k])
        t0, c0 = time.perf_counter(), _cpu()
        r.render(d, OPERATOR_CAMERA.name, MODALITIES, out=out)
        wall, cpu = wall + time.perf_counter() - t0, cpu + _cpu() - c0
    return len(frames["qpos"]), wall, cpu


def _robot_rows(repeats: int) -> list[Row]:
    model, data = compile_world()
    rng = np.random.default_rng(0)

    def steps() -> int:
        n = 5000
        for k in range(n):
            if k % 50 == 0:
                data.ctrl[:] = rng.uniform(-0.5, 0.5, model.nu)
            mujoco.mj_step(model, data)
        return n

    wall, cpu = _median_pair(steps, repeats)
    return [Row("physics steps/s, kitchen world with the arm moving (raw `mj_step`)", _fmt(wall), _fmt(cpu),
                "`samplehd bench --report FILE --only robot`")]


AREAS: dict[str, Callable[[int], list[Row]]] = {"robot": _robot_rows, "paths": _path_rows, "language": _language_rows}


class BenchFacts(TypedDict):
    """The header facts of a benchmark table: when (UTC) and on what it ran, the load averages (1 / 5 /
    15 min) at the start and end (None where the system has none), the commit, the wall and CPU time of
    the run [s], and the repeats per figure."""

    date: str
    machine: str
    load_start: tuple[float, float, float] | None
    load_end: tuple[float, float, float] | None
    commit: str
    seconds: float
    cpu_seconds: float
    repeats: int


def measure(repeats: int = 3, areas: Sequence[str] = tuple(AREAS)) -> tuple[list[Row], BenchFacts]:
    """Measure every row; returns the rows and the header facts (date, machine, loads, commit)."""
    configure_gl_backend()
    start = os.getloadavg() if hasattr(os, "getloadavg") else None
    when = datetime.datetime.now(datetime.UTC)
    t0, c0 = time.perf_counter(), _cpu()
    rows = [row for area in areas for row in AREAS[area](repeats)]
    facts: BenchFacts = {
        "date": when.strftime("%Y-%m-%d %H:%M UTC"),
        "machine": machine_description(),
        "load_start": start,
        "load_end": os.getloadavg() if hasattr(os, "getloadavg") else None,
        "commit": measured_commit(),
        "seconds": time.perf_counter() - t0,
        "cpu_seconds": _cpu() - c0,
        "repeats": repeats,
    }
    return rows, facts


def table_markdown(rows: Sequence[Row], facts: BenchFacts) -> str:
    """The table with its header, between the markers."""
    def load(v: Any) -> str:
        return " / ".join(f"{x:.1f}" for x in v) if v else "unknown"

    lines = [
        BEGIN,
        f"Measured {facts['date']} at commit {facts['commit']}, in one run of `samplehd bench --report` "
        f"({facts['seconds']:.0f} s wall, {facts['cpu_seconds']:.0f} CPU s, medians of {facts['repeats']} repeats), "
        f"on {facts['machine']}. Load average (1 / 5 / 15 min) {load(facts['load_start'])} at the start, "
        f"{load(facts['load_end'])} at the end: where it exceeds the core count, wall rates are "
        "pessimistic and the per-CPU-second rates (this process's threads, the renderer's included) are the "
        "ones to compare.",
        "",
        "| figure | per wall second | per CPU second | command |",
        "|---|---|---|---|",
        *(f"| {r.figure} | {r.wall} | {r.cpu} | {r.command} |" for r in rows),
        END,
    ]
    return "\n".join(lines) + "\n"


def check_target(path: Path) -> str | None:
    """Validate the report's target before measuring: the file's text (None: a new file).

    Raises:
        ConfigError: the folder is missing, or an existing file lacks the two markers.
    """
    if not path.parent.is_dir():
        raise ConfigError(f"report={path}: folder {path.parent} does not exist", field="report")
    if not path.exists():
        return None
    text = path.read_text(encoding="utf-8")
    if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(BEGIN) > text.index(END):
        raise ConfigError(f"report={path}: the file must hold the line {BEGIN!r} once, later the line {END!r} "
                          "once; the table goes between them", field="report")
    return text


def write_report(path: Path, table: str, text: str | None) -> None:
    """Put the table between the markers of ``text`` (the file's text) or write it as a new file."""
    if text is None:
        out = table
    else:
        head, rest = text.split(BEGIN, 1)
        tail = rest.split(END, 1)[1]
        out = head + table.rstrip("\n") + tail
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(out, encoding="utf-8")
    tmp.replace(path)

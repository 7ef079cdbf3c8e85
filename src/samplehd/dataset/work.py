"""Work units of dataset generation: pure functions of their (picklable) inputs.

A unit carries its typed configs, writes its own output file atomically and returns a small result
(a frozen dataclass; an episode's is its journal record, :meth:`EpisodeResult.to_dict`) to the
coordinating process. Units never share state, so any worker (a local process, a Ray task) can run
any unit in any order and the files come out the same.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import json
import time
import traceback
from collections import OrderedDict
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import mujoco
import numpy as np

from samplehd.dataset.container import (
    KEYFRAME_KEYS,
    camera_settings,
    merge_camera_settings,
    read_episode,
    read_meta,
    render_record,
    write_episode,
    write_error,
)
from samplehd.dataset.journal import JournalRecord
from samplehd.dataset.layout import EPISODE_DIR, RESUME_HINT
from samplehd.dataset.render import RenderConfig
from samplehd.errors import DatasetError, PlanningError, RenderError
from samplehd.motion.assist import compile_scene_with_assist
from samplehd.record.disturbances import DisturbanceConfig, draw_disturbance
from samplehd.record.episode import Episode
from samplehd.record.paths import PathConfig, PathRejected, plan_and_execute
from samplehd.render.states import LiveStates
from samplehd.scene.generate import render_scene_files
from samplehd.scene.spec import SceneSpec, compile_scene
from samplehd.scene.world import fresh_state
from samplehd.tasks.task import Task
from samplehd.world.layout import Directions

__all__ = ["EpisodeResult", "EpisodeUnit", "RenderResult", "RenderUnit", "SceneResult", "run_episode_unit",
           "run_render_unit", "run_scene_unit"]


@dataclass(frozen=True)
class SceneResult:
    """What one scene unit did.

    Attributes:
        index: the scene.
        rejections: rejected placements by reason.
        seconds: wall time [s].
        cpu_seconds: CPU time of the unit's process [s].
    """

    index: int
    rejections: dict[str, int] = field(default_factory=dict)
    seconds: float = 0.0
    cpu_seconds: float = 0.0


def run_scene_unit(job: Any) -> SceneResult:
    """Sample, render and annotate one scene (``samplehd.scene.generate.SceneJob``)."""
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        ann, rejections = render_scene_files(job)
    except (OSError, RenderError) as exc:
        cause = exc if isinstance(exc, OSError) else exc.__cause__
        if isinstance(cause, OSError):
            raise write_error(Path(job.out) / "scenes", cause, RESUME_HINT) from None
        raise
    return SceneResult(job.index, rejections, time.perf_counter() - t0, time.process_time() - c0)


@dataclass(frozen=True)
class EpisodeUnit:
    """Everything one ground-truth path needs.

    Attributes:
        out: dataset directory.
        file: episode file name inside ``episodes/``.
        scene_index: the scene.
        slot: the instruction's position among the scene's candidates.
        seed: the episode's seed.
        family: task family.
        task: the task (the episode file stores it as the executor's dict, :meth:`Task.to_program_dict`).
        instruction: instruction text (stored in the file).
        split: train or test.
        scene: the scene.
        directions: the scene's direction vectors (``scenes.json``'s ``directions``).
        paths: ground-truth path settings.
        render: which images the episode gets.
        disturbances: the disturbance draw (None: none; see :mod:`samplehd.record.disturbances`).
    """

    out: str
    file: str
    scene_index: int
    slot: int
    seed: int
    family: str
    task: Task
    instruction: str
    split: str
    scene: SceneSpec
    directions: Directions | None
    paths: PathConfig
    render: RenderConfig
    disturbances: DisturbanceConfig | None = None


@dataclass(frozen=True)
class EpisodeResult:
    """What one episode unit did; :meth:`to_dict` is its record in ``journal.jsonl``.

    Attributes:
        scene_index: the scene.
        slot: the instruction's position among the scene's candidates.
        status: ``ok`` (the episode file is written) or ``rejected``.
        seconds: wall time of the unit [s].
        cpu_seconds: CPU time of the unit's process [s].
        reason: why it was rejected (a countable key, e.g. ``checker_failed``, ``error_ValueError``).
        message: the rejection's first line.
        attempts: attempts made (a rejection by an error in the planner does not count them).
        num_frames: frames of the written episode.
        size: bytes of the written file.
        sha256: digest of the written file.
        path_seconds: wall time of planning and execution [s] (they overlap the images when those are
            drawn beside the path).
        render_seconds: wall time of the images [s].
        path_cpu_seconds: CPU time of planning and execution [s].
        render_cpu_seconds: CPU time of the images [s].
        write_cpu_seconds: CPU time of writing the file [s].
        success: False for a disturbed episode whose recovery failed (kept, with its labels); None otherwise.
        disturbance: the kind of the episode's disturbance (None: undisturbed).
        outcome: of a disturbed episode: ``recovered``, ``absorbed`` (nothing failed) or ``failed``.
    """

    scene_index: int
    slot: int
    status: str
    seconds: float
    cpu_seconds: float
    reason: str | None = None
    message: str | None = None
    attempts: int | None = None
    num_frames: int | None = None
    size: int | None = None
    sha256: str | None = None
    path_seconds: float | None = None
    render_seconds: float | None = None
    path_cpu_seconds: float | None = None
    render_cpu_seconds: float | None = None
    write_cpu_seconds: float | None = None
    success: bool | None = None
    disturbance: str | None = None
    outcome: str | None = None

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def to_dict(self) -> JournalRecord:
        """The journal record: the fields that apply to this outcome (the others are left out)."""
        return {f.name: v for f in dataclasses.fields(self) if (v := getattr(self, f.name)) is not None}


# The last few worlds this process compiled for episode units, pristine (each unit gets a copy): a scene's
# units run one after another where the dataset's order allows (``scene_major``), and copying a compiled
# model costs about 1 CPU ms where building and compiling it cost 25-80.
_WORLDS: OrderedDict[tuple[SceneSpec, float, str, bool], mujoco.MjModel] = OrderedDict()
_WORLDS_KEPT = 4


def unit_world(scene: SceneSpec, timestep: float, robot_look: str,
               assist: bool) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The compiled world of an episode unit, as ``compile_scene_with_assist`` (``assist``) or ``compile_scene``
    returns it: a model of its own (a copy of one kept from an earlier unit of the same scene, the same bytes)
    and fresh data, arm at home, gripper open, after ``mj_forward``.

    Args:
        scene: the unit's scene.
        timestep: physics step [s].
        robot_look: the arm's look (``mesh`` where images are drawn, ``primitive`` where none are).
        assist: with the grasp welds.
    """
    key = (scene, timestep, robot_look, assist)
    model = _WORLDS.get(key)
    if model is None:
        model, _ = (compile_scene_with_assist if assist else compile_scene)(scene, timestep, robot_look)
        _WORLDS[key] = model
        if len(_WORLDS) > _WORLDS_KEPT:
            _WORLDS.popitem(last=False)
    else:
        _WORLDS.move_to_end(key)
    model = copy.copy(model)
    return model, fresh_state(model)


def run_episode_unit(unit: EpisodeUnit) -> EpisodeResult:
    """Plan and execute one instruction, render its images from the stored states, write the file.

    With images at every frame, the path runs on a helper thread and this one draws each state as soon as it
    is recorded (:meth:`RenderConfig.images_live`: the same frames as drawing the finished episode), so the
    physics runs beside the renderer instead of before it; an attempt the checker rejects costs the frames
    drawn of it so far (the physics outruns the renderer about twentyfold, so few).

    Returns:
        Its outcome: rejected (``reason``, ``message``, ``attempts``) or ok (the file's ``num_frames``,
        ``size``, ``sha256``, and the times of its parts).

    Raises:
        DatasetError: the episode file cannot be written (disk full, permissions).
    """

    t0, c0 = time.perf_counter(), time.process_time()
    config, render, scene = unit.paths, unit.render, unit.scene
    # The grasp welds add no degrees of freedom: the same model serves the path and the images. With no
    # images the arm is drawn with primitives: its visual meshes have no mass and no contacts (the same
    # physics, bit for bit) but cost 40-50 CPU ms to compile per unit and about 15 % of each physics step.
    model, data = unit_world(scene, 1.0 / config.physics_hz, "mesh" if render.enabled else "primitive",
                             config.grasp_assist)
    drawn = None if unit.disturbances is None else draw_disturbance(unit.disturbances, unit.seed)

    def path_of(compiled: tuple[Any, Any], disturbed: bool) -> tuple[Episode, dict[str, dict[str, Any]] | None]:
        kwargs: dict[str, Any] = {}
        if disturbed and drawn is not None and unit.disturbances is not None:
            kwargs = {"disturbance": drawn, "max_recoveries": unit.disturbances.max_recoveries}
        run = functools.partial(plan_and_execute, scene, unit.task, np.random.default_rng(unit.seed), config,
                                family=unit.family, scene_index=unit.scene_index, instruction_index=unit.slot,
                                seed=unit.seed, directions=unit.directions, compiled=compiled, **kwargs)
        if beside:
            return _path_beside_images(run, path, render, compiled[0], scene.seed)
        return path.timed(run), None

    t1, c1 = time.perf_counter(), time.process_time()
    path = _PathTimes()
    beside = render.enabled and render.every_frame
    try:
        try:
            episode, images = path_of((model, data), drawn is not None)
            unfired = drawn is not None and "disturbance" not in episode.info
        except PathRejected:
            if drawn is None:
                raise
            unfired = True
        if unfired:
            # The drawn disturbance never came (a family without its moment, no other object to grasp):
            # the episode is made again undisturbed, the bytes a dataset without disturbances has (a
            # disturbed rollout steps its recorded vectors, an undisturbed one its joint targets).
            model, data = unit_world(scene, 1.0 / config.physics_hz, "mesh" if render.enabled else "primitive",
                                     config.grasp_assist)
            episode, images = path_of((model, data), False)
    except PathRejected as exc:
        return EpisodeResult(unit.scene_index, unit.slot, "rejected", time.perf_counter() - t0,
                             time.process_time() - c0, reason=exc.reason, message=str(exc).splitlines()[0][:300],
                             attempts=len(exc.attempts))
    except (PlanningError, ValueError, IndexError, KeyError, ArithmeticError) as exc:
        # A planner bug on one instance must not stop a 10-hour run; it is counted and reported.
        where = traceback.extract_tb(exc.__traceback__)[-1]
        return EpisodeResult(unit.scene_index, unit.slot, "rejected", time.perf_counter() - t0,
                             time.process_time() - c0, reason=f"error_{type(exc).__name__}",
                             message=f"{exc} ({Path(where.filename).name}:{where.lineno})"[:300])
    if images is None and render.enabled:
        images = render.images(model, episode.frames, seed=scene.seed, deflated=True)
    if images is not None:
        episode = dataclasses.replace(episode, images=images)
    t2, c2 = time.perf_counter(), time.process_time()
    file = Path(unit.out) / EPISODE_DIR / unit.file
    extra = {"slot": unit.slot, "instruction": unit.instruction, "task": unit.task.to_program_dict(),
             "split": unit.split}
    written = write_episode(file, episode, extra, render.to_dict() if render.enabled else None, retry=RESUME_HINT)
    c3 = time.process_time()
    label = episode.info.get("disturbance")
    labelled: dict[str, Any] = {} if label is None else {
        "success": bool(episode.success), "disturbance": str(label["kind"]), "outcome": str(label["outcome"])}
    return EpisodeResult(unit.scene_index, unit.slot, "ok", time.perf_counter() - t0, c3 - c0, **labelled,
                         attempts=int(episode.info.get("attempts", 1)), num_frames=written.num_frames,
                         size=written.size, sha256=written.sha256, path_seconds=t1 - t0 + path.wall,
                         render_seconds=t2 - t1 - (0 if beside else path.wall), path_cpu_seconds=c1 - c0 + path.cpu,
                         render_cpu_seconds=c2 - c1 - path.cpu, write_cpu_seconds=c3 - c2)


class _PathTimes:
    """Wall and CPU time of the path, on whichever thread runs it."""

    wall = cpu = 0.0

    def timed(self, run: Callable[..., Episode], **kwargs: Any) -> Episode:
        t, c = time.perf_counter(), time.thread_time()
        try:
            return run(**kwargs)
        finally:
            self.wall, self.cpu = time.perf_counter() - t, time.thread_time() - c


def _path_beside_images(run: Callable[..., Episode], path: _PathTimes, render: RenderConfig, model: Any,
                        seed: int) -> tuple[Episode, dict[str, dict[str, Any]] | None]:
    """The path on a helper thread, its images drawn on this one as its states are recorded.

    Raises:
        whatever the path raises (once it and the drawing are over), or the drawing's error.
    """
    live = LiveStates()
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="samplehd-path") as pool:
        future = pool.submit(path.timed, run, live=live)
        images = render.images_live(model, live, seed)  # returns once the path has finished, either way
        episode = future.result()
    return episode, images


@dataclass(frozen=True)
class RenderUnit:
    """Re-render one episode file from its stored states.

    Attributes:
        path: the episode file.
        scene: its scene.
        physics_hz: physics rate the scene was compiled at [Hz].
        render: the images to render.
        replace: drop the file's existing images first; else keep the cameras and modalities not
            re-rendered (copied unchanged; a camera rendered at other settings is replaced whole, see
            :func:`samplehd.dataset.rerender.merge_camera_settings`).
    """

    path: str
    scene: SceneSpec
    physics_hz: float
    render: RenderConfig
    replace: bool = True


@dataclass(frozen=True)
class RenderResult:
    """The episode file a render unit rewrote.

    Attributes:
        path: the file.
        num_frames: its frames.
        size: its bytes.
        sha256: its digest.
        seconds: wall time of the unit [s].
    """

    path: str
    num_frames: int
    size: int
    sha256: str
    seconds: float


def run_render_unit(unit: RenderUnit) -> RenderResult:
    """Render an episode's images from its states and rewrite its file atomically.

    The file's ``/images`` ``render`` attribute gets the resulting per-camera settings.

    Returns:
        The rewritten file's size and digest.

    Raises:
        DatasetError: the file is unreadable or cannot be written, or (adding) a camera would mix settings.
    """

    t0 = time.perf_counter()


    path = Path(unit.path)
    render = unit.render
    episode = read_episode(path, images="none" if unit.replace else "lazy")
    old = {} if unit.replace else camera_settings(read_meta(path)["render"])
    try:
        settings = merge_camera_settings(old, render, add=not unit.replace)
    except DatasetError as exc:
        raise DatasetError(f"{path}: {exc}") from None
    with h5py.File(path, "r") as f:
        extra = {k: v for k, v in f.attrs.items() if k not in (
            "format_version", "scene_index", "instruction_index", "family", "seed", "success", "num_frames",
            "subtasks", "info")}
    extra = {k: (v.item() if hasattr(v, "item") else v) for k, v in extra.items()}
    if "task" in extra and isinstance(extra["task"], str):
        extra["task"] = json.loads(extra["task"])
    scene = unit.scene
    model, _ = compile_scene(scene, 1.0 / unit.physics_hz)
    images: dict[str, dict[str, Any]] = {}
    for cam, mods in episode.images.items():
        prev = old.get(cam)
        same = prev is not None and cam in settings and all(
            prev.get(k) == settings[cam].get(k) for k in ("mode", "width", "height", *KEYFRAME_KEYS))
        if cam not in render.cameras or same:
            images[cam] = dict(mods)  # kept (lazy: copied chunk by chunk); same settings: modalities merge
    for cam, mods in render.images(model, episode.frames, seed=scene.seed, deflated=True).items():
        images.setdefault(cam, {}).update(mods)
    written = write_episode(path, dataclasses.replace(episode, images=images), extra, render_record(settings))
    return RenderResult(str(path), written.num_frames, written.size, written.sha256, time.perf_counter() - t0)

"""Which images a dataset's episodes get (:class:`RenderConfig`), rendered from the episodes' stored
physics states with :func:`samplehd.render.states.render_states` during ``samplehd generate``,
``samplehd rerender`` and ``samplehd paths``, so all give identical pixels.
"""

from __future__ import annotations

import copy
import functools
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from samplehd.errors import ConfigError, RenderError
from samplehd.record.episode import Episode
from samplehd.render.deflated import DeflatedFrames
from samplehd.render.keyframes import SparseFrames, keyframe_indices
from samplehd.render.photo import LOOKS, photo_options
from samplehd.render.renderer import (
    IMAGE_DTYPES,
    MODALITIES,
    camera_names,
    get_preset,
    image_shape,
    stored_segmentation_dtype,
)
from samplehd.render.states import RESTART, State, render_state_stream, render_states
from samplehd.scene.world import compile_world
from samplehd.schema import bounded, check_fields, from_mapping

__all__ = ["RENDER_MODES", "Planned", "RenderConfig", "StateCallback", "check_cameras"]

RENDER_MODES = ("none", "fast", "hd", "photo")


@dataclass(frozen=True)
class RenderConfig:
    """Which images an episode gets.

    Attributes:
        mode: ``none`` (states only), or the render preset ``fast`` / ``hd`` / ``photo`` (path traced).
        width: image width [px].
        height: image height [px].
        cameras: camera names (``scene`` is the scene's sampled camera; ``operator``, ``wrist``).
        modalities: any of rgb, depth, segmentation.
        every: images at every N-th frame only (1: every frame; 0: none but the subtask ends).
        subtask_ends: also (or only) at the first and last frame of each subtask.
        look: photo preset: ``fixed``, or ``random`` (lights, textures, exposure from the scene's seed).
    """

    mode: str = bounded("fast", choices=RENDER_MODES)
    width: int = bounded(320, lo=8, hi=8192, unit="px")
    height: int = bounded(180, lo=8, hi=8192, unit="px")
    # Camera names are checked against the world by check_cameras (it compiles the world).
    cameras: tuple[str, ...] = bounded(("scene",), nonempty=True, unique=True)
    modalities: tuple[str, ...] = bounded(MODALITIES, choices=MODALITIES, nonempty=True, unique=True)
    every: int = 1
    subtask_ends: bool = False
    look: str = bounded("fixed", choices=LOOKS)

    def __post_init__(self) -> None:
        check_fields(self, "render")
        keyframe_indices(0, self.every, None, self.subtask_ends)  # validates every

    def keyframes(self, num_frames: int, subtask_index: np.ndarray | None) -> np.ndarray:
        """Frames of an episode that get images."""
        return keyframe_indices(num_frames, self.every, subtask_index, self.subtask_ends)

    @property
    def enabled(self) -> bool:
        return self.mode != "none"

    def images(self, model: mujoco.MjModel, frames: Mapping[str, np.ndarray],
               seed: int = 0, deflated: bool = False) -> dict[str, dict[str, Any]]:
        """Render an episode's frames from its stored states: ``images[camera][modality]`` (first axis
        T), or ``{}`` for mode ``none``. With keyframes (``every``, ``subtask_ends``) each stream is a
        :class:`~samplehd.render.keyframes.SparseFrames`. ``seed``: the scene's seed (the photo
        preset's randomised look is drawn from it). ``deflated``: each stream is a
        :class:`~samplehd.render.deflated.DeflatedFrames`, every frame deflated as soon as it is rendered (on a
        helper thread, while the next frames render: ``render_states(overlap=True)``),
        in the dtype the episode file stores (segmentation uint8, or uint16 for a scene with ids past 255),
        for writing (about a tenth of the memory of the raw frames, and no fresh memory per frame).

        Raises:
            DatasetError: the states do not fit the model.
            RenderError: unknown camera or no GL context.
        """
        if not self.enabled:
            return {}
        t = len(frames["qpos"])
        picks = self.keyframes(t, frames.get("subtask_index"))
        photo = photo_options(self.look, seed, where="render.look") if get_preset(self.mode).path_traced else None
        args = (model, frames, self.cameras, self.modalities, self.width, self.height, self.mode)
        if deflated:
            images, keep, seg = self._deflated_streams(model)
            render_states(*args, indices=picks.tolist(), photo=photo, on_frame=keep, segmentation_dtype=seg,
                          overlap=True)
        else:
            images = render_states(*args, indices=picks.tolist(), photo=photo)
        return self._sparse(images, picks, t)

    @property
    def renders_while_planning(self) -> bool:
        """Whether :meth:`images_while_planning` applies: a GL preset at every N-th frame (which frames get
        images is known as each is recorded; subtask ends are known only later, path-traced frames take a
        second each, beside which planning is nothing to hide)."""
        return self.enabled and self.every >= 1 and not self.subtask_ends and not get_preset(self.mode).path_traced

    def images_while_planning(self, model: mujoco.MjModel, plan: Callable[[StateCallback], Episode]) -> Planned:
        """Plan an episode and render its images (as :meth:`images` with ``deflated``) at the same time: ``plan``
        runs on a helper thread with a ``plan_and_execute`` ``on_state`` callback, and this thread renders each
        recorded state as it comes (the path's physics and planning fill the cores the rasteriser leaves idle).
        The frames of an attempt that failed are dropped when the next attempt starts, so the images are
        exactly those :meth:`images` renders from the returned episode's states.

        Returns:
            The episode ``plan`` returned and its images, with when planning ended and its CPU time.

        Raises:
            Whatever ``plan`` raised (``PathRejected`` ...), after rendering stopped; DatasetError, RenderError
            as :meth:`images` (planning is then stopped at its next frame). No thread is left running.
        """
        if not self.renders_while_planning:
            raise ConfigError(f"render: {self.to_dict()} cannot render while planning; use images()")
        images, keep, seg = self._deflated_streams(model)

        def restart() -> None:
            for mods in images.values():
                for stream in mods.values():
                    stream.chunks.clear()

        feed = _StateFeed(self.every)
        worker = threading.Thread(target=feed.run, args=(plan,), name="samplehd-plan")
        worker.start()
        try:
            # A copy of the model: the planner changes its grasp welds (eq_data) while the frames are drawn.
            render_state_stream(copy.copy(model), feed, self.cameras, self.modalities, self.width, self.height,
                                self.mode, on_frame=keep, on_restart=restart, segmentation_dtype=seg, overlap=True)
        finally:
            feed.cancel()
            worker.join()
        episode = feed.outcome()
        t = episode.num_frames
        picks = self.keyframes(t, None)
        if feed.frames != t or any(len(v) != len(picks) for mods in images.values() for v in mods.values()):
            raise RenderError(f"rendered {feed.frames} states while planning, the episode has {t} frames")
        return Planned(episode, self._sparse(images, picks, t), feed.finished_at, feed.cpu_seconds)

    def _deflated_streams(self, model: mujoco.MjModel) -> tuple[
            dict[str, dict[str, Any]], Callable[[str, dict[str, np.ndarray]], None], np.dtype]:
        """Empty :class:`DeflatedFrames` of every camera and modality, the ``on_frame`` that fills them, and the
        segmentation dtype they store."""
        seg = stored_segmentation_dtype(model)
        dtypes = {**IMAGE_DTYPES, "segmentation": seg}
        images: dict[str, dict[str, Any]] = {
            c: {m: DeflatedFrames(image_shape(m, self.width, self.height), dtypes[m]) for m in self.modalities}
            for c in self.cameras}

        def keep(camera: str, frame: dict[str, np.ndarray]) -> None:
            for m, a in frame.items():
                images[camera][m].append(a)

        return images, keep, seg

    @staticmethod
    def _sparse(images: dict[str, dict[str, Any]], picks: np.ndarray, t: int) -> dict[str, dict[str, Any]]:
        """Every frame's streams as they are, or keyframe streams as :class:`SparseFrames`."""
        if len(picks) == t:
            return images
        return {c: {m: SparseFrames(picks, v, t) for m, v in mods.items()} for c, mods in images.items()}

    def to_dict(self) -> dict[str, Any]:
        d = {"mode": self.mode, "width": self.width, "height": self.height, "cameras": list(self.cameras),
             "modalities": list(self.modalities)}
        # Only where set, so that records of every-frame images stay as they were.
        if self.every != 1:
            d["every"] = self.every
        if self.subtask_ends:
            d["subtask_ends"] = True
        if self.look != "fixed":
            d["look"] = self.look
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], where: str = "render") -> RenderConfig:
        return from_mapping(cls, d, where)


StateCallback = Callable[[int, np.ndarray, np.ndarray, np.ndarray, np.float64], None]


@dataclass(frozen=True)
class Planned:
    """What :meth:`RenderConfig.images_while_planning` returns.

    Attributes:
        episode: the planned episode (without images).
        images: its images, as :meth:`RenderConfig.images` with ``deflated`` gives them.
        planned_at: when planning ended (``time.perf_counter``).
        plan_cpu_seconds: CPU time of the planning thread.
    """

    episode: Episode
    images: dict[str, dict[str, Any]]
    planned_at: float
    plan_cpu_seconds: float


class _Cancelled(BaseException):
    """Raised in the planning thread to stop it (rendering failed); a BaseException, so that no handler of the
    planner's errors takes it for one of them."""


class _StateFeed:
    """Recorded states handed from the planning thread (:meth:`put`, the ``on_state`` of ``plan_and_execute``) to
    the rendering one (iteration), in order; a new attempt voids the states before it (:data:`RESTART`)."""

    def __init__(self, every: int) -> None:
        self.every = every
        self.frames = 0  # frames recorded by the current attempt
        self.cpu_seconds = self.finished_at = 0.0
        self._cond = threading.Condition()
        self._items: deque[State | str] = deque()
        self._attempt: int | None = None
        self._done = self._cancelled = False
        self._result: Episode | None = None
        self._error: BaseException | None = None

    def run(self, plan: Callable[[StateCallback], Episode]) -> None:
        """The planning thread: run ``plan`` and keep its episode or its exception."""
        c0 = time.thread_time()
        result, error = None, None
        try:
            result = plan(self.put)
        except BaseException as exc:  # noqa: BLE001 - handed to the caller's thread, raised there
            error = exc
        with self._cond:
            self._result, self._error, self._done = result, error, True
            self.cpu_seconds, self.finished_at = time.thread_time() - c0, time.perf_counter()
            self._cond.notify_all()

    def put(self, attempt: int, qpos: np.ndarray, qvel: np.ndarray, act: np.ndarray, when: np.float64) -> None:
        with self._cond:
            if self._cancelled:
                raise _Cancelled
            if attempt != self._attempt:
                if self._attempt is not None:
                    self._items.append(RESTART)
                self._attempt, self.frames = attempt, 0
            if self.frames % self.every == 0:
                self._items.append((qpos, qvel, act, when))
            self.frames += 1
            self._cond.notify_all()

    def __iter__(self) -> Iterator[State | str]:
        """The rendering thread: each item as it comes, until planning ends (at once when it failed)."""
        while True:
            with self._cond:
                while not self._items and not self._done:
                    self._cond.wait()
                if self._error is not None or not self._items:
                    return
                item = self._items.popleft()
            yield item

    def cancel(self) -> None:
        """Stop the planning thread at its next frame."""
        with self._cond:
            self._cancelled = True

    def outcome(self) -> Episode:
        """The planned episode, or raise what planning raised."""
        if self._error is not None:
            raise self._error
        assert self._result is not None
        return self._result


def check_cameras(config: RenderConfig) -> None:
    """Fail early (before any simulation) on a camera name no scene world has.

    Raises:
        ConfigError: naming the unknown cameras and the valid ones.
    """
    if not config.enabled:
        return
    valid = _world_cameras()
    bad = [c for c in config.cameras if c not in valid]
    if bad:
        raise ConfigError(f"render.cameras: unknown camera(s) {bad}; valid: {', '.join(valid)}")


@functools.cache
def _world_cameras() -> tuple[str, ...]:
    """Cameras of every scene world (compiled once per process) plus the scene's own ``scene``."""
    return tuple(sorted({*camera_names(compile_world()[0]), "scene"}))

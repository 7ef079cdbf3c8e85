"""Render from stored physics states, without re-simulating: the one way every stage does it.

For every frame the stored ``qpos``, ``qvel``, ``act`` (and ``time`` when recorded) are written into
the compiled scene's ``MjData``, the poses are computed, and the renderer draws them.
``samplehd generate`` and ``samplehd rerender`` (episode images), ``samplehd replay`` (videos and
contact sheets), ``samplehd paths`` and the web viewer (frames of state-only episodes) all call
:func:`set_state` / :func:`render_states`, so they give identical pixels for the same state.
``samplehd generate`` draws an episode's states while its rollout is still recorded (:class:`LiveStates`,
:func:`render_live`), by the same loop (:func:`render_stream`) and from the same values.

:func:`set_state` runs all of ``mj_forward``; :func:`pose_state`, which :func:`render_states` uses, runs only
the stages of it whose results a frame is drawn from (body, geom, site, camera and light poses, tendon
paths), in the same order, so their poses are bit for bit those of ``mj_forward`` without its collision
detection and dynamics (most of its cost, paid every frame of an episode).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

import mujoco
import numpy as np

from samplehd.errors import DatasetError
from samplehd.render.image_spec import ImageSpec
from samplehd.render.renderer import IMAGE_DTYPES

__all__ = ["OVERLAP_BUFFERS", "OVERLAP_GROUP_BYTES", "LiveStates", "Superseded", "State", "pose_state",
           "render_live", "render_states", "render_stream", "set_state"]

# One recorded state: qpos, qvel, act (or None), time (or None).
State = tuple[np.ndarray, np.ndarray, "np.ndarray | None", "float | None"]

# Groups of frame buffers that take turns when on_frame runs beside the render loop: one being rendered,
# one being handed over, one spare (so a slow call does not stall the renderer at once).
OVERLAP_BUFFERS = 3
# Frames are handed to the helper thread in groups of up to 8 whose arrays take at most this many bytes.
# Each hand-over wakes the helper, which then takes the GIL back after every deflate call: the render loop,
# whose MuJoCo calls let go of the GIL, waited for it about 0.4 ms per frame when every frame was handed
# over alone (320x180; `samplehd bench paths handoff` compares the ways, docs/PERFORMANCE.md).
OVERLAP_GROUP_BYTES = 8 << 20
_OVERLAP_GROUP_FRAMES = 8


def set_state(model: mujoco.MjModel, data: mujoco.MjData, qpos: np.ndarray, qvel: np.ndarray,
              act: np.ndarray | None = None, time: float | None = None) -> None:
    """Write one recorded state into ``data`` and run ``mj_forward``.

    Raises:
        DatasetError: the state's sizes do not fit the model (the episode belongs to another scene).
    """
    _write_state(model, data, qpos, qvel, act, time)
    mujoco.mj_forward(model, data)


def pose_state(model: mujoco.MjModel, data: mujoco.MjData, qpos: np.ndarray, qvel: np.ndarray,
               act: np.ndarray | None = None, time: float | None = None) -> None:
    """Write one recorded state into ``data`` and compute what drawing it needs: the position stages of
    ``mj_forward`` that give poses (kinematics, centres of mass, cameras and lights, flexes, tendon paths),
    without collision detection, constraints and dynamics. The poses are bit for bit ``mj_forward``'s.
    A model with rangefinder sensors (drawn as rays from the sensor readings) gets all of ``mj_forward``.

    Raises:
        DatasetError: the state's sizes do not fit the model (the episode belongs to another scene).
    """
    _write_state(model, data, qpos, qvel, act, time)
    if _draws_sensors(model):
        mujoco.mj_forward(model, data)
        return
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    mujoco.mj_camlight(model, data)
    mujoco.mj_flex(model, data)
    mujoco.mj_tendon(model, data)


def _draws_sensors(model: mujoco.MjModel) -> bool:
    return bool(model.nsensor) and bool(np.any(model.sensor_type == mujoco.mjtSensor.mjSENS_RANGEFINDER))


def _write_state(model: mujoco.MjModel, data: mujoco.MjData, qpos: np.ndarray, qvel: np.ndarray,
                 act: np.ndarray | None, time: float | None) -> None:
    qpos, qvel = np.asarray(qpos), np.asarray(qvel)
    if qpos.shape != (model.nq,) or qvel.shape != (model.nv,):
        raise DatasetError(f"recorded state has nq={qpos.shape[-1]}, nv={qvel.shape[-1]}, but the model has "
                           f"nq={model.nq}, nv={model.nv}; compile the episode's own scene")
    data.qpos[:] = qpos
    data.qvel[:] = qvel
    if model.na and act is not None:
        data.act[:] = act
    if time is not None:
        data.time = float(time)


def render_states(
    model: mujoco.MjModel,
    frames: Mapping[str, np.ndarray],
    image: ImageSpec,
    indices: Sequence[int] | None = None,
    data: mujoco.MjData | None = None,
    photo: Any = None,
    on_frame: Callable[[str, dict[str, np.ndarray]], None] | None = None,
    segmentation_dtype: Any = np.int32,
    overlap: bool = False,
    overlap_group: int | None = None,
) -> dict[str, dict[str, np.ndarray]]:
    """Render recorded frames: ``images[camera][modality]`` with the frame as first axis.

    Args:
        model: the episode's compiled scene (``compile_scene(spec)``).
        frames: per-frame arrays; ``qpos`` and ``qvel`` are used, ``act`` and ``time`` when present.
        image: cameras, modalities (rgb T,H,W,3 uint8; depth T,H,W float32 [m]; segmentation T,H,W int32),
            size and render preset.
        indices: frames to render (default: all).
        data: an ``MjData`` to reuse (default: a new one); it is left holding the last frame's poses
            (:func:`pose_state`: no contacts or forces).
        photo: the photo preset's options (``samplehd.render.photo.PhotoOptions``; default: the fixed look).
        on_frame: called with each camera and its images of each frame in turn, instead of keeping them; the
            arrays are reused for the next frame (copy what must outlive the call). ``{}`` is then returned.
        segmentation_dtype: int32, or uint8/uint16 where the model's ids fit (the dtype episode files store).
        overlap: with ``on_frame``, call it on one helper thread while the next frames render (in the same
            order, one call at a time; frames are handed over in groups of up to 8 within
            :data:`OVERLAP_GROUP_BYTES`, and :data:`OVERLAP_BUFFERS` groups of arrays take turns), so that
            work that releases the GIL (deflating, say) runs beside the rasteriser instead of after it. An
            exception raised by ``on_frame`` is raised here, and no call is left running when this returns
            or raises.
        overlap_group: frames per hand-over with ``overlap`` (default: up to 8, see above).

    Raises:
        DatasetError: the states do not fit the model.
        RenderError: unknown camera or modality, or no GL context.
    """
    picks = range(len(frames["qpos"])) if indices is None else indices
    # Without on_frame, each frame is rendered straight into its slot of the episode's streams (no per-frame
    # arrays to stack).
    out = None if on_frame is not None else _frame_arrays(len(picks), image, segmentation_dtype)
    render_stream(model, _picked(frames, picks), image, data, photo, on_frame, segmentation_dtype, overlap,
                  overlap_group, out)
    return out if out is not None else {}


def _picked(frames: Mapping[str, np.ndarray], picks: Iterable[int]) -> Iterator[State]:
    act, time = frames.get("act"), frames.get("time")
    for k in picks:
        yield (frames["qpos"][k], frames["qvel"][k], None if act is None else act[k],
               None if time is None else time[k])


def render_stream(
    model: mujoco.MjModel,
    states: Iterable[State],
    image: ImageSpec,
    data: mujoco.MjData | None = None,
    photo: Any = None,
    on_frame: Callable[[str, dict[str, np.ndarray]], None] | None = None,
    segmentation_dtype: Any = np.int32,
    overlap: bool = False,
    overlap_group: int | None = None,
    out: dict[str, dict[str, np.ndarray]] | None = None,
) -> int:
    """Render states as they come (:func:`render_states`, whose arguments these are, over any iterable of
    ``(qpos, qvel, act, time)``): each frame goes to ``on_frame``, or into slot i of ``out``'s arrays.
    Returns the number of frames rendered.
    """
    if overlap_group is not None and overlap_group < 1:
        raise ValueError(f"overlap_group {overlap_group}: must be at least 1")
    if (on_frame is None) == (out is None):
        raise ValueError("render_stream needs either on_frame or out")
    data = data if data is not None else mujoco.MjData(model)
    # With on_frame, one frame's arrays serve every frame (no fresh memory per frame); with overlap, a few
    # groups' arrays take turns.
    overlap = overlap and on_frame is not None
    group = overlap_group or _group_frames(image, _dtypes(segmentation_dtype)) if overlap else 1
    n = 0  # slots that take turns (0: frame i goes to slot i of the caller's out)
    if out is None:
        n = OVERLAP_BUFFERS * group if overlap else 1
        out = _frame_arrays(n, image, segmentation_dtype)
    views: list[tuple[str, dict[str, np.ndarray]]] = []  # the frames of the group being rendered
    count = 0
    cameras, modalities = image.cameras, image.modalities
    with image.renderer(model, photo=photo) as renderer, _Handoff(overlap) as handoff:
        for i, (qpos, qvel, act, time) in enumerate(states):
            pose_state(model, data, qpos, qvel, act, time)
            slot = i % n if n else i
            if slot % group == 0:
                handoff.wait(slot // group)  # the helper is done with this group's arrays (or raises its error)
            for cam in cameras:
                images = renderer.render(data, cam, modalities, out={m: a[slot] for m, a in out[cam].items()})
                if on_frame is not None and not overlap:
                    on_frame(cam, images)
            if overlap:
                assert on_frame is not None
                views += [(cam, {m: a[slot] for m, a in out[cam].items()}) for cam in cameras]
                if slot % group == group - 1:
                    handoff.submit(slot // group, on_frame, views)
                    views = []
            count = i + 1
        if views:
            assert on_frame is not None
            handoff.submit((count - 1) % n // group, on_frame, views)
        handoff.wait_all()
    return count


class Superseded(Exception):
    """The rollout whose states were being rendered was abandoned (:class:`LiveStates`)."""


class LiveStates:
    """The states of a rollout while it is recorded, so that they can be rendered beside it.

    One thread records: :meth:`restart` at the start of every attempt (the states so far are dropped),
    :meth:`put` for each state, and :meth:`finish` once, with whether the last attempt is the episode.
    Another renders: :meth:`next_attempt`, then :meth:`states` of that attempt, which waits for each
    next state and raises :class:`Superseded` when a new attempt begins or the rollout fails. The recording
    thread never waits for the rendering one.
    """

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._attempt = 0
        self._states: list[State] = []
        self._done: bool | None = None  # None while recording; then whether the last attempt succeeded

    @property
    def attempts(self) -> int:
        """How many attempts have begun."""
        return self._attempt

    def restart(self) -> None:
        """A new attempt begins: the states recorded so far are void."""
        with self._cond:
            self._attempt += 1
            self._states = []
            self._cond.notify_all()

    def put(self, qpos: np.ndarray, qvel: np.ndarray, act: np.ndarray | None, time: float | None) -> None:
        """The next state of the current attempt (arrays the recorder does not write again)."""
        with self._cond:
            self._states.append((qpos, qvel, act, time))
            self._cond.notify_all()

    def finish(self, success: bool) -> None:
        """Recording is over: the current attempt's states are the episode's (``success``), or there is none.
        Only the first call counts."""
        with self._cond:
            if self._done is None:
                self._done = bool(success)
            self._cond.notify_all()

    def next_attempt(self) -> int | None:
        """Wait for an attempt to render: the newest one, or None once recording ended without an episode."""
        with self._cond:
            self._cond.wait_for(lambda: self._attempt > 0 or self._done is not None)
            return None if self._done is False or self._attempt == 0 else self._attempt

    def states(self, attempt: int) -> Iterator[State]:
        """The states of ``attempt`` in order, each as soon as it is recorded, until the attempt is the episode.

        Raises:
            Superseded: a newer attempt began, or recording ended without an episode.
        """
        k = 0
        while True:
            with self._cond:
                self._cond.wait_for(lambda k=k: self._attempt != attempt or k < len(self._states)
                                    or self._done is not None)
                if self._attempt != attempt or self._done is False:
                    raise Superseded(f"attempt {attempt} was abandoned")
                if k == len(self._states):
                    return
                state = self._states[k]
            yield state
            k += 1


def render_live(model: mujoco.MjModel, live: LiveStates,
                on_attempt: Callable[[], Callable[[str, dict[str, np.ndarray]], None]],
                image: ImageSpec, photo: Any = None, segmentation_dtype: Any = np.int32,
                overlap: bool = True) -> int | None:
    """Render a rollout's states while it is recorded (:class:`LiveStates`), attempt after attempt.

    Every attempt is drawn by a new renderer from its first state, as :func:`render_states` draws a
    finished episode, so the frames are the same. ``on_attempt`` is called when an attempt's rendering
    begins and returns that attempt's ``on_frame`` (see :func:`render_states`); the frames of an abandoned
    attempt went to an ``on_frame`` that is then dropped.

    Returns:
        The episode's number of frames, or None when recording ended without an episode.
    """
    while (attempt := live.next_attempt()) is not None:
        try:
            return render_stream(model, live.states(attempt), image, photo=photo, on_frame=on_attempt(),
                                 segmentation_dtype=segmentation_dtype, overlap=overlap)
        except Superseded:
            continue
    return None


def _dtypes(segmentation_dtype: Any) -> dict[str, np.dtype]:
    return {**IMAGE_DTYPES, "segmentation": np.dtype(segmentation_dtype)}


def _frame_arrays(n: int, image: ImageSpec, segmentation_dtype: Any) -> dict[str, dict[str, np.ndarray]]:
    """``[camera][modality]`` arrays of ``n`` frames each."""
    dtypes = _dtypes(segmentation_dtype)
    return {c: {m: np.empty((n, *image.shape(m)), dtype=dtypes[m]) for m in image.modalities if m in dtypes}
            for c in image.cameras}


def _group_frames(image: ImageSpec, dtypes: Mapping[str, np.dtype]) -> int:
    """How many frames to hand to the helper thread at a time (see :data:`OVERLAP_GROUP_BYTES`)."""
    frame = sum(int(np.prod(image.shape(m))) * dtypes[m].itemsize for m in image.modalities if m in dtypes)
    return max(1, min(_OVERLAP_GROUP_FRAMES, OVERLAP_GROUP_BYTES // max(1, frame * len(image.cameras))))


class _Handoff:
    """Calls ``on_frame`` for groups of whole frames on one helper thread, in order, and tracks which group of
    frame slots each pending call still reads; does nothing when not ``enabled``. Leaving the ``with`` block
    (normally or by an exception) cancels what has not started and waits for the running call, so no thread
    outlives it."""

    def __init__(self, enabled: bool) -> None:
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="samplehd-frames") if enabled else None
        self._pending: dict[int, Future[None]] = {}

    def __enter__(self) -> _Handoff:
        return self

    def __exit__(self, *exc: object) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)

    def submit(self, group: int, on_frame: Callable[[str, dict[str, np.ndarray]], None],
               views: list[tuple[str, dict[str, np.ndarray]]]) -> None:
        assert self._pool is not None

        def call() -> None:
            for cam, images in views:
                on_frame(cam, images)

        self._pending[group] = self._pool.submit(call)

    def wait(self, group: int) -> None:
        """Block until the call reading ``group``'s slots has finished; raise its exception if it failed."""
        done = self._pending.pop(group, None)
        if done is not None:
            done.result()

    def wait_all(self) -> None:
        """Block until every call has finished; raise the first exception among them."""
        for group in list(self._pending):
            self.wait(group)

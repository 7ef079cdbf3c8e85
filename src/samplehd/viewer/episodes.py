"""Episodes as the viewer shows them: summaries for lists, per-frame series for the player's plots
and timeline, single frames of the stored images read one at a time on demand, and the rejected
instruction candidates (paths that failed, from the generation journal).

Episodes are read through ``samplehd.dataset.reader.DatasetReader`` (HDF5 containers, never
written). While a dataset is being generated the reader is renewed whenever the folder changes;
a file that cannot be read is listed as unreadable instead of failing the page.

An episode is named by its file stem (``s000012_03`` = scene 12, instruction slot 3): stable while
files are added, unlike the episode index, which is final only once generation completes.
"""

from __future__ import annotations

import io
import json
import threading
from collections import OrderedDict
from pathlib import Path
from typing import Any, TypedDict

import numpy as np
from PIL import Image

from samplehd.dataset.journal import JournalRecord, read_journal
from samplehd.dataset.layout import CANDIDATES_FILE, EPISODE_DIR, INFO_FILE, JOURNAL_FILE
from samplehd.dataset.reader import DatasetReader
from samplehd.envs.config import CAMERAS
from samplehd.errors import DatasetError
from samplehd.render.renderer import MODALITIES
from samplehd.viewer.index import FileState
from samplehd.world.layout import LAYOUT

__all__ = ["PLOT_FIELDS", "EpisodeStore", "disturbance_bands", "failure_reason", "open_episode_store",
           "subtask_segments"]

# Frame fields the player needs (the physics states stay on disk).
PLOT_FIELDS = ("time", "subtask_index", "target_object", "joint_pos", "gripper_opening", "gripper_command",
               "steering", "tcp_pos", "object_pos", "grasped_object", "safety_event")

_JOINT_NAMES = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
                "wrist_3_joint")


def failure_reason(success: bool, info: dict[str, Any]) -> str:
    """One line saying why an episode failed ("" when it succeeded or nothing is recorded)."""
    if success:
        return ""
    for key in ("failure_reason", "reason"):
        if isinstance(info.get(key), str) and info[key]:
            return info[key]
    check = info.get("check")
    if isinstance(check, dict) and check.get("reason"):
        return str(check["reason"])
    attempts = info.get("failed_attempts")
    if isinstance(attempts, list) and attempts and isinstance(attempts[-1], dict):
        last = attempts[-1]
        return str(last.get("message") or last.get("reason") or "")
    return ""


class Band(TypedDict):
    """A timeline band of the player: frames ``start`` to ``end`` (exclusive), ``kind`` disturbance or
    recovery, and its label."""

    start: int
    end: int
    kind: str
    name: str


class Segment(TypedDict):
    """A run of frames with one subtask and target: frames ``start`` to ``end`` (exclusive), the
    subtask's index and name, and the target object's index."""

    start: int
    end: int
    index: int
    name: str
    target: int


def disturbance_bands(info: dict[str, Any]) -> list[Band]:
    """The timeline bands of a disturbed episode (``info["disturbance"]``, see
    :mod:`samplehd.record.disturbances`): ``{start, end (exclusive), kind: disturbance | recovery, name}``
    for the frames the disturbance acts in and for the recovery segment; none for other episodes."""
    lab = info.get("disturbance")
    if not isinstance(lab, dict):
        return []
    bands: list[Band] = []
    if int(lab.get("frame", -1)) >= 0:
        bands.append({"start": int(lab["frame"]), "end": int(lab.get("last_frame", lab["frame"])) + 1,
                      "kind": "disturbance", "name": f"{lab.get('kind')}"
                      + (f" → {lab['failure']}" if lab.get("failure") else "")})
    if int(lab.get("recovery_first", -1)) >= 0:
        bands.append({"start": int(lab["recovery_first"]), "end": int(lab["recovery_last"]) + 1, "kind": "recovery",
                      "name": f"recovery ({lab.get('outcome')})"})
    return bands


def subtask_segments(subtask_index: np.ndarray, target_object: np.ndarray,
                     names: list[str]) -> list[Segment]:
    """Runs of equal (subtask, target) as ``{start, end (exclusive), index, name, target}``."""
    idx = np.asarray(subtask_index).astype(np.int64)
    tgt = np.asarray(target_object).astype(np.int64)
    out: list[Segment] = []
    start = 0
    for f in range(1, len(idx) + 1):
        if f == len(idx) or idx[f] != idx[start] or tgt[f] != tgt[start]:
            k = int(idx[start])
            out.append({"start": start, "end": f, "index": k,
                        "name": names[k] if 0 <= k < len(names) else f"subtask {k}", "target": int(tgt[start])})
            start = f
    return out


def _layout() -> dict[str, list[float] | float]:
    return {"table_size": list(LAYOUT.table_size), "robot_base": list(LAYOUT.robot_base),
            "workspace_min": list(LAYOUT.workspace_min), "workspace_max": list(LAYOUT.workspace_max),
            "workspace_center": [float(v) for v in LAYOUT.workspace_center], "band": LAYOUT.band}


def _attr_json(attrs: Any, key: str, default: Any) -> Any:
    value = attrs.get(key)
    if value is None:
        return default
    if isinstance(value, bytes):
        value = value.decode("utf-8", "replace")
    if isinstance(value, str):
        try:
            return json.loads(value)
        except json.JSONDecodeError:
            return value
    return value


def _rounded(values: np.ndarray, digits: int = 5) -> list[Any]:
    arr = np.asarray(values)
    if arr.dtype.kind == "f":
        arr = np.round(arr.astype(np.float64), digits)
        return np.where(np.isfinite(arr), arr, np.nan).tolist()
    return arr.tolist()


class EpisodeStore:
    """Read-only access to the episodes of one ``samplehd generate`` dataset, through
    :class:`samplehd.dataset.reader.DatasetReader`; safe from many threads.

    A new reader is made whenever ``info.json``, ``candidates.json``, ``journal.jsonl`` or the
    ``episodes/`` folder changes, so a dataset being generated shows its new episodes. Per-episode
    attributes are cached by file (path, mtime, size).

    Args:
        root: the dataset folder.
        instructions: callable returning ``(instructions, state)`` (for instruction texts).
        scene: callable from a scene index to its scene dict (to rebuild worlds for rendering).
        renderer: a :class:`~samplehd.viewer.state_render.StateRenderer` for episodes stored without
            images (None: such episodes show the top view only).
    """

    def __init__(self, root: Path, instructions: Any = None, scene: Any = None, renderer: Any = None) -> None:
        self.root = Path(root)
        self._instructions = instructions
        self._scene = scene
        self.renderer = renderer
        self._states: OrderedDict[str, tuple[tuple[int, int], dict[str, np.ndarray]]] = OrderedDict()
        self._lock = threading.Lock()
        self._reader_key: tuple[Any, ...] | None = None
        self._reader: Any = None
        self._reader_error = ""
        self._meta: dict[str, tuple[tuple[int, int], dict[str, Any]]] = {}
        self._journal_key: tuple[int, int] | None = None
        self._journal_cache: dict[tuple[int, int], int] = {}

    # -- reader --------------------------------------------------------------------------------
    def _stamp(self, name: str) -> tuple[int, int]:
        try:
            st = (self.root / name).stat()
        except OSError:
            return (0, -1)
        return st.st_mtime_ns, st.st_size

    def reader(self) -> Any:
        """The current DatasetReader, or None when the folder is not a ``samplehd generate`` dataset."""
        key = tuple(self._stamp(n) for n in (INFO_FILE, CANDIDATES_FILE, JOURNAL_FILE, EPISODE_DIR))
        with self._lock:
            if key == self._reader_key:
                return self._reader
        try:
            reader, error = DatasetReader(self.root), ""
            reader.episodes  # noqa: B018 - list them now, under the same key
        except DatasetError as exc:
            reader, error = None, str(exc)
        with self._lock:
            self._reader_key, self._reader, self._reader_error = key, reader, error
        return reader

    def _entries(self) -> list[tuple[str, int, Any]]:
        """(stem, reader index, EpisodeEntry) of every episode."""
        reader = self.reader()
        if reader is None:
            return []
        return [(Path(e.file).stem, i, e) for i, e in enumerate(reader.episodes)]

    def _locate(self, name: str) -> tuple[Any, int, Any]:
        for stem, i, entry in self._entries():
            if stem == name:
                path = (self.root / entry.file).resolve()
                if not path.is_relative_to(self.root.resolve()):
                    raise DatasetError(f"episode {name}: its file {entry.file!r} lies outside the dataset; refused")
                return self.reader(), i, entry
        raise DatasetError(f"episode {name}: not in the dataset (yet)")

    def state(self) -> FileState:
        """``ok`` for a complete dataset whose episode files are all there with their recorded sizes,
        ``damaged`` for a complete one where they are not (what ``samplehd validate`` would report,
        never shown as progress), ``partial`` while generating, ``missing`` without episodes."""
        reader = self.reader()
        if reader is None:
            return FileState("episodes", "missing", f"no episodes: {self._reader_error}")
        count = len(reader.episodes)
        if not reader.complete:
            status = reader.info.get("status", "in_progress")
            return FileState("episodes", "partial", f"generation {status}: {count} episodes written so far")
        damaged = [e for e in reader.episodes if self._damage(e)]
        if damaged:
            return FileState("episodes", "damaged", f"{len(damaged)} of {count} episode files damaged, e.g. "
                             f"{damaged[0].file}: {self._damage(damaged[0])}; `samplehd validate {self.root}` lists "
                             f"every problem")
        return FileState("episodes", "ok")

    def _damage(self, entry: Any) -> str:
        """What is wrong with a finished episode's file on sight (no hashing): missing or another size."""
        try:
            size = (self.root / entry.file).stat().st_size
        except OSError:
            return "missing"
        return f"{size} bytes, info.json records {entry.size}" if 0 <= entry.size != size else ""

    # -- listing -------------------------------------------------------------------------------
    def _episode_meta(self, reader: Any, index: int, entry: Any) -> dict[str, Any]:
        path = self.root / entry.file
        try:
            st = path.stat()
            key = (st.st_mtime_ns, st.st_size)
        except OSError:
            key = (0, -1)
        with self._lock:
            hit = self._meta.get(entry.file)
        if hit is not None and hit[0] == key:
            return hit[1]
        try:
            read = reader.episode_meta(index)
            meta = {"success": read.success, "failure_reason": failure_reason(read.success, read.info),
                    "num_frames": read.num_frames, "instruction": read.instruction or "",
                    "cameras": {c: list(m) for c, m in read.images.items()},
                    "image_frames": {c: list(f) for c, f in read.image_frames.items()},
                    "family": read.family, "readable": True}
        except DatasetError as exc:
            meta = {"success": False, "failure_reason": f"unreadable: {exc}", "readable": False, "cameras": {}}
        with self._lock:
            self._meta[entry.file] = (key, meta)
        return meta

    def count(self) -> int:
        """Number of episodes (cheap: no episode file is opened)."""
        return len(self._entries())

    def summaries(self) -> list[dict[str, Any]]:
        """One summary per episode, in the dataset's episode order.

        Cheap for thousands of episodes: no episode file is opened. A dataset stores only episodes
        whose path succeeded, so ``success`` is True unless the file, once opened for the player,
        said otherwise; frame counts of a dataset still being generated come from the journal.
        """
        texts = self._instruction_texts()
        frames = self._journal_frames()
        out = []
        for stem, i, entry in self._entries():
            with self._lock:
                hit = self._meta.get(entry.file)
            num_frames = entry.num_frames if entry.num_frames >= 0 else frames.get((entry.scene_index, entry.slot), -1)
            summary = {"episode": stem, "index": i, "file": entry.file, "scene_index": entry.scene_index,
                       "slot": entry.slot, "instruction_index": entry.instruction_index, "family": entry.family,
                       "split": entry.split, "num_frames": num_frames, "success": True, "failure_reason": "",
                       "instruction": texts.get((entry.scene_index, entry.slot), "")}
            if hit is not None:
                summary.update({k: v for k, v in hit[1].items() if k != "cameras" and v not in ("", None)})
                summary["success"] = hit[1]["success"]
            damage = self._damage(entry) if self.reader() is not None and self.reader().complete else ""
            if damage:
                summary.update(success=False, failure_reason=f"damaged: {damage}", readable=False)
            out.append(summary)
        return out

    def _journal_frames(self) -> dict[tuple[int, int], int]:
        """Frame counts of written episodes from the generation journal (empty when absent)."""
        key = self._stamp("journal.jsonl")
        with self._lock:
            if self._journal_key == key:
                return self._journal_cache
        try:
            records = read_journal(self.root)
        except OSError:
            records = []
        counts = {(int(r.get("scene_index", -1)), int(r.get("slot", -1))): int(r.get("num_frames", -1))
                  for r in records if r.get("status") == "ok"}
        with self._lock:
            self._journal_key, self._journal_cache = key, counts
        return counts

    def rejections(self) -> list[JournalRecord]:
        """Instruction candidates whose path was rejected: ``{scene_index, slot, reason, message}``."""
        reader = self.reader()
        if reader is None:
            return []
        try:
            records = reader.rejections()
        except (DatasetError, OSError) as exc:
            return [{"scene_index": -1, "slot": -1, "reason": "journal_unreadable", "message": str(exc)}]
        return [{"scene_index": int(r.get("scene_index", -1)), "slot": int(r.get("slot", -1)),
                 "reason": str(r.get("reason", "")), "message": str(r.get("message", ""))} for r in records]

    def _instruction_texts(self) -> dict[tuple[int, int], str]:
        if self._instructions is None:
            return {}
        items, _ = self._instructions()
        return {(int(q.get("image_index", -1)), int(q.get("slot", -1))): str(q.get("instruction", ""))
                for q in items}

    def version(self, name: str) -> tuple[int, int]:
        """(mtime, size) of the episode's file, to key caches."""
        _, _, entry = self._locate(name)
        return self._stamp(entry.file)

    # -- one episode ---------------------------------------------------------------------------
    def detail(self, name: str) -> dict[str, Any]:
        """Everything the player draws: summary, subtasks and segments, cameras, per-frame series."""
        reader, i, entry = self._locate(name)
        meta = reader.episode_meta(i)
        frames = reader.frames(i, PLOT_FIELDS)
        info = meta.info
        subtasks = list(meta.subtasks)
        self._episode_meta(reader, i, entry)  # caches success, failure reason and cameras for the listing
        summary = next(s for s in self.summaries() if s["episode"] == name)
        summary["cameras"] = {c: list(m) for c, m in meta.images.items()}
        # Cameras with images at keyframes only (rerender --every/--subtask-ends): the frames that have them.
        summary["image_frames"] = {c: list(f) for c, f in meta.image_frames.items()}
        summary["rendered_on_demand"] = False
        if not summary["cameras"] and self._renderable(entry.scene_index):
            summary["cameras"] = {c: list(MODALITIES) for c in CAMERAS}
            summary["rendered_on_demand"] = True
        stems = [stem for stem, _, _ in self._entries()]
        position = stems.index(name)
        series: dict[str, Any] = {key: _rounded(frames[key]) for key in PLOT_FIELDS}
        series["joint_names"] = list(_JOINT_NAMES)
        return {
            **summary,
            "previous": stems[position - 1] if position > 0 else None,
            "next": stems[position + 1] if position + 1 < len(stems) else None,
            "control_hz": float(info.get("control_hz", 20.0) or 20.0),
            "subtasks": subtasks,
            "segments": subtask_segments(frames["subtask_index"], frames["target_object"], subtasks),
            "bands": disturbance_bands(info),
            "task": meta.to_dict().get("task"),
            "render": meta.render,
            "series": series,
            "layout": _layout(),
            "info": {k: v for k, v in info.items() if k != "scene"},  # the scene has its own page
        }

    def frame(self, name: str, t: int, camera: str, modality: str) -> np.ndarray:
        """One stored image: rgb (H, W, 3) uint8, depth (H, W) [m], or segmentation ids (H, W).

        Raises:
            DatasetError: no such camera/modality in the file, or frame out of range.
        """
        reader, i, entry = self._locate(name)
        cameras = self._episode_meta(reader, i, entry).get("cameras", {})
        if not cameras:
            return self._render(name, reader, i, entry, t, camera or "scene", modality)
        camera = camera or next(iter(cameras))
        if camera not in cameras or modality not in cameras[camera]:
            valid = ", ".join(f"{c}/{m}" for c, ms in cameras.items() for m in ms)
            raise DatasetError(f"episode {name}: no {camera}/{modality} images; stored: {valid}")
        keyframes = self._episode_meta(reader, i, entry).get("image_frames", {}).get(camera)
        if keyframes and t not in keyframes:  # keyframes only: show the latest keyframe at or before t
            t = max([k for k in keyframes if k <= t] or [keyframes[0]])
        try:
            pixels = np.asarray(reader.image(i, camera, modality, t))
        except IndexError as exc:
            raise DatasetError(f"episode {name}: frame {t} out of range ({exc})") from None
        if pixels.ndim == 1 and pixels.dtype == np.uint8:  # an encoded frame (PNG bytes): decode, never execute

            with Image.open(io.BytesIO(pixels.tobytes())) as image:
                pixels = np.asarray(image.convert("RGB"))
        return pixels

    def _renderable(self, scene_index: int) -> bool:
        """Whether frames of this scene's episodes can be rendered (a renderer, and a scene spec)."""
        if self.renderer is None or self._scene is None:
            return False
        try:
            return isinstance(self._scene(scene_index).get("spec"), dict)
        except DatasetError:
            return False

    def _render(self, name: str, reader: Any, i: int, entry: Any, t: int, camera: str,
                modality: str) -> np.ndarray:
        """Render frame ``t`` of an episode stored without images from its recorded state."""
        if self.renderer is None or self._scene is None:
            raise DatasetError(f"episode {name}: stores no images (generated with render mode none) and this viewer "
                               f"renders none (render=False); `samplehd rerender` adds them, or view with rendering")
        if not self._renderable(entry.scene_index):
            raise DatasetError(f"episode {name}: stores no images, and scene {entry.scene_index} has no 'spec' "
                               f"to render them from")
        key = self._stamp(entry.file)
        with self._lock:
            hit = self._states.get(name)
        if hit is None or hit[0] != key:
            states = reader.frames(i, ("qpos", "qvel", "act"))
            with self._lock:
                self._states[name] = (key, states)
                while len(self._states) > 4:
                    self._states.popitem(last=False)
        else:
            states = hit[1]
        if not 0 <= t < len(states["qpos"]):
            raise DatasetError(f"episode {name}: frame {t} outside 0..{len(states['qpos']) - 1}")
        scene = self._scene(entry.scene_index)
        return self.renderer.render(scene, {k: v[t] for k, v in states.items()}, camera, modality)


def open_episode_store(root: Path, instructions: Any = None, scene: Any = None,
                       renderer: Any = None) -> EpisodeStore | None:
    """The episode store of a dataset folder."""
    return EpisodeStore(root, instructions, scene, renderer)

"""Episodes as the viewer shows them: summaries for lists, per-frame series for the player's plots
and timeline, and single frames of the stored images, read one at a time on demand.

Episodes are the per-episode HDF5 containers of ``samplehd.dataset`` (``episodes/*.h5``); they are
read through its container functions, never written. Files appear while a dataset is being
generated: the folder is rescanned when it changes, temporary files are skipped, and a file that
cannot be read yet is listed as unreadable instead of failing the page.

An episode is named by its file stem (``s000012_03``), stable while files are added.
"""

from __future__ import annotations

import io
import json
import threading
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.errors import DatasetError
from samplehd.viewer.index import FileState

__all__ = ["PLOT_FIELDS", "EpisodeStore", "failure_reason", "open_episode_store", "subtask_segments"]

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


def subtask_segments(subtask_index: np.ndarray, target_object: np.ndarray,
                     names: list[str]) -> list[dict[str, Any]]:
    """Runs of equal (subtask, target) as ``{start, end (exclusive), index, name, target}``."""
    idx = np.asarray(subtask_index).astype(np.int64)
    tgt = np.asarray(target_object).astype(np.int64)
    out: list[dict[str, Any]] = []
    start = 0
    for f in range(1, len(idx) + 1):
        if f == len(idx) or idx[f] != idx[start] or tgt[f] != tgt[start]:
            k = int(idx[start])
            out.append({"start": start, "end": f, "index": k,
                        "name": names[k] if 0 <= k < len(names) else f"subtask {k}", "target": int(tgt[start])})
            start = f
    return out


def _layout() -> dict[str, Any]:
    from samplehd.scene.layout import LAYOUT

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
    """Read-only access to the episode files of one dataset folder, safe from many threads.

    Args:
        root: the dataset folder (episodes are in ``root/episodes``).
        instructions: callable returning the dataset's instructions (for text and indices).
    """

    def __init__(self, root: Path, instructions: Any = None) -> None:
        self.root = Path(root)
        self.folder = self.root / "episodes"
        self._instructions = instructions
        self._lock = threading.Lock()
        self._summaries: dict[str, tuple[tuple[int, int], dict[str, Any]]] = {}
        self._scan_key: tuple[int, int] | None = None
        self._order: list[str] = []

    # -- listing -------------------------------------------------------------------------------
    def _files(self) -> list[Path]:
        from samplehd.dataset.layout import is_temporary, parse_episode_name

        if not self.folder.is_dir():
            return []
        out = [p for p in self.folder.iterdir()
               if p.is_file() and not is_temporary(p.name) and parse_episode_name(p.name) is not None]
        return sorted(out, key=lambda p: parse_episode_name(p.name) or (0, 0))

    def _summary(self, path: Path) -> dict[str, Any]:
        import h5py

        from samplehd.dataset.layout import parse_episode_name

        scene_index, slot = parse_episode_name(path.name) or (-1, -1)
        base: dict[str, Any] = {"episode": path.stem, "file": f"episodes/{path.name}", "scene_index": scene_index,
                                "slot": slot, "instruction_index": -1, "family": "", "success": False,
                                "failure_reason": "", "num_frames": 0, "readable": True}
        try:
            with h5py.File(path, "r") as f:
                a = f.attrs
                info = _attr_json(a, "info", {})
                info = info if isinstance(info, dict) else {}
                success = bool(a.get("success", False))
                base.update({
                    "scene_index": int(a.get("scene_index", scene_index)),
                    "instruction_index": int(a.get("instruction_index", -1)),
                    "family": str(a.get("family", "")),
                    "success": success,
                    "failure_reason": failure_reason(success, info),
                    "num_frames": int(a.get("num_frames", 0)),
                    "instruction": str(a.get("instruction", "")),
                    "cameras": {cam: sorted(f["images"][cam]) for cam in f["images"]} if "images" in f else {},
                })
        except (OSError, KeyError, ValueError, RuntimeError) as exc:
            base.update({"readable": False, "failure_reason": f"unreadable: {exc}"})
        return base

    def _rescan(self) -> list[str]:
        files = self._files()
        stamps = {}
        for p in files:
            try:
                st = p.stat()
            except FileNotFoundError:
                continue
            stamps[p.stem] = ((st.st_mtime_ns, st.st_size), p)
        for stem, (key, path) in stamps.items():
            with self._lock:
                hit = self._summaries.get(stem)
            if hit is None or hit[0] != key:
                summary = self._summary(path)
                with self._lock:
                    self._summaries[stem] = (key, summary)
        with self._lock:
            for stem in set(self._summaries) - set(stamps):
                del self._summaries[stem]
            self._order = [p.stem for p in files if p.stem in stamps]
            return list(self._order)

    def state(self) -> FileState:
        """``ok`` when episodes exist, ``missing`` when the folder has none (yet)."""
        if not self.folder.is_dir():
            return FileState("episodes", "missing", "episodes/ has not been written yet")
        if not self._order and not self._rescan():
            return FileState("episodes", "missing", "episodes/ holds no episode yet")
        return FileState("episodes", "ok")

    def summaries(self) -> list[dict[str, Any]]:
        """Summaries of every readable or unreadable episode file, in (scene, slot) order."""
        order = self._rescan()
        texts = self._instruction_texts()
        out = []
        with self._lock:
            for stem in order:
                s = dict(self._summaries[stem][1])
                if not s.get("instruction"):
                    s["instruction"] = texts.get(s["instruction_index"], "")
                out.append(s)
        return out

    def _instruction_texts(self) -> dict[int, str]:
        if self._instructions is None:
            return {}
        items, _ = self._instructions()
        return {int(q.get("instruction_index", -1)): str(q.get("instruction", "")) for q in items}

    def _path(self, name: str) -> Path:
        from samplehd.dataset.layout import EPISODE_SUFFIX, parse_episode_name

        if parse_episode_name(f"{name}{EPISODE_SUFFIX}") is None:
            raise DatasetError(f"episode {name!r}: not an episode name (expected like s000012_03)")
        path = self.folder / f"{name}{EPISODE_SUFFIX}"
        if not path.is_file():
            raise DatasetError(f"episode {name}: no such episode file (yet)")
        return path

    def version(self, name: str) -> tuple[int, int]:
        """(mtime, size) of the episode's file, to key caches."""
        st = self._path(name).stat()
        return st.st_mtime_ns, st.st_size

    # -- one episode ---------------------------------------------------------------------------
    def detail(self, name: str) -> dict[str, Any]:
        """Everything the player draws: summary, subtasks and segments, cameras, per-frame series."""
        import h5py

        from samplehd.dataset.container import read_frames

        path = self._path(name)
        summary = self._summary(path)
        if not summary["readable"]:
            raise DatasetError(f"episode {name}: {summary['failure_reason']}")
        frames = read_frames(path, PLOT_FIELDS)
        with h5py.File(path, "r") as f:
            subtasks = _attr_json(f.attrs, "subtasks", [])
            info = _attr_json(f.attrs, "info", {})
            task = _attr_json(f.attrs, "task", None)
            render = _attr_json(f["images"].attrs, "render", {}) if "images" in f else {}
        info = info if isinstance(info, dict) else {}
        info = {k: v for k, v in info.items() if k != "scene"}  # the scene is shown on its own page
        order = self._order or self._rescan()
        position = order.index(name) if name in order else -1
        series = {key: _rounded(frames[key]) for key in PLOT_FIELDS}
        series["joint_names"] = list(_JOINT_NAMES)
        texts = self._instruction_texts()
        return {
            **summary,
            "instruction": summary.get("instruction") or texts.get(summary["instruction_index"], ""),
            "previous": order[position - 1] if position > 0 else None,
            "next": order[position + 1] if 0 <= position < len(order) - 1 else None,
            "control_hz": float(info.get("control_hz", 20.0) or 20.0),
            "subtasks": [str(s) for s in subtasks],
            "segments": subtask_segments(frames["subtask_index"], frames["target_object"], [str(s) for s in subtasks]),
            "task": task,
            "render": render,
            "series": series,
            "layout": _layout(),
            "info": info,
        }

    def frame(self, name: str, t: int, camera: str, modality: str) -> np.ndarray:
        """One stored image: rgb (H, W, 3) uint8, depth (H, W) [m], or segmentation ids (H, W).

        Raises:
            DatasetError: no such camera/modality in the file, or frame out of range.
        """
        from samplehd.dataset.container import FrameImages

        path = self._path(name)
        cameras = self._summary(path).get("cameras", {})
        if not cameras:
            raise DatasetError(f"episode {name}: stores no images (generated with render mode none)")
        camera = camera or next(iter(cameras))
        if camera not in cameras or modality not in cameras[camera]:
            valid = ", ".join(f"{c}/{m}" for c, ms in cameras.items() for m in ms)
            raise DatasetError(f"episode {name}: no {camera}/{modality} images; stored: {valid}")
        images = FrameImages(path, f"images/{camera}/{modality}")
        if not 0 <= t < len(images):
            raise DatasetError(f"episode {name}: frame {t} outside 0..{len(images) - 1}")
        pixels = np.asarray(images[t])
        if pixels.ndim == 1 and pixels.dtype == np.uint8:  # an encoded frame (PNG/JPEG bytes): decode, never execute
            from PIL import Image

            with Image.open(io.BytesIO(pixels.tobytes())) as image:
                pixels = np.asarray(image.convert("RGB"))
        return pixels


def open_episode_store(root: Path, instructions: Any = None) -> EpisodeStore | None:
    """The episode store of a dataset folder, or None when the folder has no ``episodes/`` and the
    dataset package (h5py) is unavailable."""
    try:
        import h5py  # noqa: F401

        import samplehd.dataset.container  # noqa: F401
    except ImportError:
        return None
    return EpisodeStore(root, instructions)

"""What the viewer knows about a dataset folder: scenes, instructions and episodes, read tolerantly.

A dataset may still be being written while it is browsed. Every file is re-read when its size or
modification time changes; a file that is missing or does not parse yet (a partial write) gives a
*state* (``missing`` / ``partial``) instead of an error, and the scene list then falls back to the
per-scene files ``scenes/<stem>.json`` that are already complete. Nothing is ever executed or
unpickled: JSON, PNG and NumPy arrays loaded with ``allow_pickle=False`` only.

Scenes are keyed by their ``image_index``; instructions by their ``instruction_index``; an
instruction belongs to the scene whose ``image_index`` it carries.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from samplehd.dataset.journal import JournalRecord
from samplehd.dataset.layout import DatasetInfo
from samplehd.errors import DatasetError
from samplehd.language.instruction_file import InstructionEntry
from samplehd.scene.annotate import SceneAnnotation

__all__ = [
    "FILTER_KEYS",
    "DatasetIndex",
    "FileState",
    "filter_scene_summaries",
    "is_dataset_dir",
    "matches_instruction",
    "scene_summary",
]

# Query keys of the scene grid's filters, each matched against a scene summary's set of the same name.
FILTER_KEYS = ("family", "class", "colour", "material", "split", "success")

# Files or folders whose presence makes a folder browsable.
_MARKERS = ("info.json", "scenes.json", "scenes", "instructions.json", "candidates.json", "episodes")


@dataclass(frozen=True)
class FileState:
    """How far one dataset file has been written.

    Attributes:
        name: file name relative to the dataset root.
        state: ``ok``, ``missing`` or ``partial`` (exists but does not parse yet).
        detail: one line saying why, empty when ok.
    """

    name: str
    state: str
    detail: str = ""

    def to_dict(self) -> dict[str, str]:
        return {"name": self.name, "state": self.state, "detail": self.detail}


def is_dataset_dir(path: Path) -> bool:
    """Whether ``path`` is a folder holding any dataset file (info, scenes, instructions, episodes)."""
    return path.is_dir() and any((path / m).exists() for m in _MARKERS)


class _JsonCache:
    """JSON documents keyed by path, re-read when (mtime, size) changes; thread-safe."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._docs: dict[Path, tuple[tuple[int, int], Any, str]] = {}

    def read(self, path: Path) -> tuple[Any, FileState]:
        """The parsed document (or None) and the file's state."""
        name = path.name
        try:
            st = path.stat()
        except FileNotFoundError:
            return None, FileState(name, "missing", f"{name} has not been written yet")
        key = (st.st_mtime_ns, st.st_size)
        with self._lock:
            hit = self._docs.get(path)
        if hit is not None and hit[0] == key:
            doc, problem = hit[1], hit[2]
        else:
            try:
                doc, problem = json.loads(path.read_bytes()), ""
            except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
                doc, problem = None, f"{name} does not parse yet ({type(exc).__name__}: {exc})"
            with self._lock:
                self._docs[path] = (key, doc, problem)
        if problem:
            return None, FileState(name, "partial", problem)
        return doc, FileState(name, "ok")


def _as_int(value: Any, default: int) -> int:
    try:
        return int(value)
    except (TypeError, ValueError):
        return default


def scene_summary(scene: Mapping[str, Any], instructions: Iterable[Mapping[str, Any]],
                  episodes: Iterable[Mapping[str, Any]], rejected: bool = False) -> dict[str, Any]:
    """What the scene grid shows and filters on for one scene.

    Args:
        scene: CLEVR-layout scene dict.
        instructions: that scene's instructions.
        episodes: that scene's episode summaries (``success`` key).
        rejected: whether a path of one of its instruction candidates was rejected (a failure).

    Returns:
        ``{index, stem, split, num_objects, objects, class, colour, material, family, success,
        num_instructions, num_episodes}`` where class/colour/material/family/success are sorted
        lists of the values present (success values: ``success``, ``failure``, ``none``).
    """
    objects = [o for o in scene.get("objects", []) if isinstance(o, Mapping)]
    instructions = list(instructions)
    episodes = list(episodes)
    outcomes = {"success" if e.get("success") else "failure" for e in episodes} | ({"failure"} if rejected else set())
    outcomes = outcomes or {"none"}
    filename = str(scene.get("image_filename", ""))
    return {
        "index": _as_int(scene.get("image_index"), -1),
        "stem": filename.rsplit(".", 1)[0],
        "split": [str(scene.get("split", "unknown"))],
        "num_objects": len(objects),
        "objects": [f"{o.get('colour', o.get('color', ''))} {o.get('name', o.get('shape', ''))}".strip()
                    for o in objects],
        "class": sorted({str(o.get("name", o.get("shape", ""))) for o in objects}),
        "colour": sorted({str(o.get("colour", o.get("color", ""))) for o in objects}),
        "material": sorted({str(o.get("material", "")) for o in objects}),
        "family": sorted({str(q.get("family", "")) for q in instructions}),
        "success": sorted(outcomes),
        "num_instructions": len(instructions),
        "num_episodes": len(episodes),
    }


def filter_scene_summaries(summaries: Iterable[Mapping[str, Any]],
                           criteria: Mapping[str, str]) -> list[Mapping[str, Any]]:
    """Summaries matching every criterion: ``criteria[key]`` must be in ``summary[key]``.

    Args:
        summaries: outputs of :func:`scene_summary`.
        criteria: filter key (one of :data:`FILTER_KEYS`) → wanted value; empty values are ignored.

    Raises:
        DatasetError: an unknown filter key.
    """
    unknown = sorted(set(criteria) - set(FILTER_KEYS))
    if unknown:
        raise DatasetError(f"unknown scene filter(s) {unknown}; valid: {list(FILTER_KEYS)}")
    wanted = {k: v for k, v in criteria.items() if v}
    return [s for s in summaries if all(v in s.get(k, ()) for k, v in wanted.items())]


def matches_instruction(record: Mapping[str, Any], instruction: Mapping[str, Any]) -> bool:
    """Whether an episode or rejection record belongs to an instruction: same scene and slot when the
    instruction has a slot (``samplehd generate``), else the same instruction index."""
    if "slot" in instruction and "slot" in record:
        return (_as_int(record.get("scene_index"), -1) == _as_int(instruction.get("image_index"), -2)
                and _as_int(record.get("slot"), -1) == _as_int(instruction.get("slot"), -2))
    return _as_int(record.get("instruction_index"), -1) == _as_int(instruction.get("instruction_index"), -2)


class DatasetIndex:
    """Read-only view of one dataset folder, safe to use from many request threads.

    Args:
        root: the dataset folder.
        episodes: source of episode summaries and frames (``None``: the folder has none).

    Raises:
        DatasetError: ``root`` is not a folder or holds no dataset file.
    """

    def __init__(self, root: Path, episodes: Any | None = None) -> None:
        root = Path(root)
        if not root.is_dir():
            raise DatasetError(f"{root}: no such dataset folder")
        if not is_dataset_dir(root):
            raise DatasetError(f"{root}: not a samplehd dataset (expected any of {', '.join(_MARKERS)})")
        self.root = root.resolve()
        self.episodes = episodes
        self._json = _JsonCache()

    # -- files ---------------------------------------------------------------------------------
    def info(self) -> tuple[DatasetInfo, FileState]:
        """``info.json`` (or ``{}``) and its state."""
        doc, state = self._json.read(self.root / "info.json")
        return (doc if isinstance(doc, dict) else {}), state

    def scenes(self) -> tuple[dict[int, SceneAnnotation], FileState]:
        """Scenes by image index, and the state of ``scenes.json``.

        While ``scenes.json`` is missing or partial, the complete per-scene files are used.
        """
        doc, state = self._json.read(self.root / "scenes.json")
        scenes: list[Any] = []
        if isinstance(doc, dict) and isinstance(doc.get("scenes"), list):
            scenes = doc["scenes"]
        elif doc is not None:
            state = FileState("scenes.json", "partial", "scenes.json has no 'scenes' list")
        if not scenes:
            folder = self.root / "scenes"
            for path in sorted(folder.glob("*.json")) if folder.is_dir() else ():
                one, one_state = self._json.read(path)
                if one_state.state == "ok" and isinstance(one, dict) and "objects" in one:
                    scenes.append(one)
            if scenes and state.state != "ok":
                state = FileState("scenes.json", state.state,
                                  f"{state.detail}; showing {len(scenes)} per-scene files from scenes/")
        out: dict[int, SceneAnnotation] = {}
        for position, scene in enumerate(scenes):
            if isinstance(scene, dict):
                out[_as_int(scene.get("image_index"), position)] = scene
        return out, state

    def instructions(self) -> tuple[list[InstructionEntry], FileState]:
        """Instructions (``instructions`` or CLEVR's ``questions`` list) and the file's state.

        While ``instructions.json`` is not written yet (``samplehd generate`` writes it last), the
        instruction candidates of ``candidates.json`` are shown instead.
        """
        doc, state = self._json.read(self.root / "instructions.json")
        if state.state != "ok":
            candidates, cand_state = self._json.read(self.root / "candidates.json")
            if cand_state.state == "ok" and isinstance(candidates, dict):
                doc = candidates
                state = FileState("instructions.json", state.state,
                                  f"{state.detail}; showing the instruction candidates of candidates.json")
        items: Any = []
        if isinstance(doc, dict):
            items = doc.get("instructions", doc.get("questions", []))
        if not isinstance(items, list):
            return [], FileState("instructions.json", "partial", "instructions.json has no 'instructions' list")
        out = []
        for position, q in enumerate(items):
            if isinstance(q, dict):
                q = dict(q)
                q.setdefault("instruction_index", q.get("question_index", position))
                out.append(q)
        return out, state

    def candidates(self) -> list[InstructionEntry]:
        """Instruction candidates of ``candidates.json`` (``samplehd generate``), or []."""
        doc, state = self._json.read(self.root / "candidates.json")
        items = doc.get("instructions", []) if isinstance(doc, dict) and state.state == "ok" else []
        return [q for q in items if isinstance(q, dict)] if isinstance(items, list) else []

    def episode_summaries(self) -> tuple[list[dict[str, Any]], FileState]:
        """Episode summaries from the episode source, and its state."""
        if self.episodes is None:
            return [], FileState("episodes", "missing", "this folder holds no episodes")
        return self.episodes.summaries(), self.episodes.state()

    def rejections(self) -> list[JournalRecord]:
        """Instruction candidates whose path was rejected (``{scene_index, slot, reason, message}``)."""
        if self.episodes is None or not hasattr(self.episodes, "rejections"):
            return []
        return self.episodes.rejections()

    # -- derived -------------------------------------------------------------------------------
    def status(self) -> dict[str, Any]:
        """States of every dataset file, and counts; what the page's banner shows."""
        info, info_state = self.info()
        scenes, scenes_state = self.scenes()
        instructions, instr_state = self.instructions()
        if self.episodes is None:
            ep_count, ep_state = 0, FileState("episodes", "missing", "this folder holds no episodes")
        else:
            ep_count, ep_state = self.episodes.count(), self.episodes.state()
        # info.json of a finished dataset lists every episode (thousands): send the count instead
        if isinstance(info.get("episodes"), list):
            info = {**info, "episodes": f"{len(info['episodes'])} entries (see /files/info.json)"}
        return {
            "root": str(self.root),
            "name": self.root.name,
            "info": info,
            "files": [s.to_dict() for s in (info_state, scenes_state, instr_state, ep_state)],
            "counts": {"scenes": len(scenes), "instructions": len(instructions), "episodes": ep_count},
        }

    def instructions_of(self, scene_index: int) -> list[InstructionEntry]:
        """The instructions whose ``image_index`` is ``scene_index``."""
        items, _ = self.instructions()
        return [q for q in items if _as_int(q.get("image_index"), -1) == scene_index]

    def instruction(self, instruction_index: int) -> InstructionEntry:
        """One instruction by index; raises DatasetError when absent."""
        items, state = self.instructions()
        for q in items:
            if _as_int(q.get("instruction_index"), -1) == instruction_index:
                return q
        raise DatasetError(f"instruction {instruction_index}: not in the dataset ({state.state}, {len(items)} read)")

    def scene(self, scene_index: int) -> SceneAnnotation:
        """One scene by image index; raises DatasetError when absent."""
        scenes, state = self.scenes()
        if scene_index not in scenes:
            raise DatasetError(f"scene {scene_index}: not in the dataset ({state.state}, {len(scenes)} read)")
        return scenes[scene_index]

    def summaries(self) -> list[dict[str, Any]]:
        """Scene-grid summaries of every scene, in index order."""
        scenes, _ = self.scenes()
        instructions, _ = self.instructions()
        episodes, _ = self.episode_summaries()
        by_scene: dict[int, list[dict[str, Any]]] = {}
        for q in instructions:
            by_scene.setdefault(_as_int(q.get("image_index"), -1), []).append(q)
        eps_by_scene: dict[int, list[dict[str, Any]]] = {}
        for e in episodes:
            eps_by_scene.setdefault(_as_int(e.get("scene_index"), -1), []).append(e)
        rejected = {_as_int(r.get("scene_index"), -1) for r in self.rejections()}
        out = []
        for i in sorted(scenes):
            summary = scene_summary(scenes[i], by_scene.get(i, []), eps_by_scene.get(i, []), i in rejected)
            try:
                summary["has_image"] = self.image_path(i, "rgb").is_file()
            except DatasetError:
                summary["has_image"] = False
            out.append(summary)
        return out

    def image_path(self, scene_index: int, modality: str) -> Path:
        """Path of a scene's ``rgb`` / ``depth`` / ``segmentation`` PNG (it may not exist yet).

        Raises:
            DatasetError: unknown modality or scene.
        """
        folders = {"rgb": "images", "depth": "depth", "segmentation": "segmentation"}
        if modality not in folders:
            raise DatasetError(f"modality {modality!r}: valid: {sorted(folders)}")
        scene = self.scene(scene_index)
        filename = Path(str(scene.get("image_filename", f"{scene_index:06d}.png"))).name
        stem = filename.rsplit(".", 1)[0]
        path = (self.root / folders[modality] / f"{stem}.png").resolve()
        if not path.is_relative_to(self.root):
            raise DatasetError(f"scene {scene_index}: image_filename {filename!r} points outside the dataset")
        return path

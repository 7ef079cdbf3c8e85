"""Read a samplehd dataset directory: metadata, scenes, instructions and episodes.

Example:
    >>> reader = DatasetReader("outputs/demo/dataset")  # doctest: +SKIP
    >>> ep = reader.episode(0)                           # doctest: +SKIP
    >>> ep.frames["joint_pos"].shape, ep.images["scene"]["rgb"][10].shape  # doctest: +SKIP
    ((309, 6), (180, 320, 3))

The reader also works on a dataset that is still being generated: it then lists the episode files
written so far (skipping temporary files) and the instruction candidates they belong to.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.catalogue.loader import LEGACY_CATALOGUE
from samplehd.dataset.container import read_episode, read_frames, read_image, read_meta
from samplehd.dataset.journal import JournalRecord, read_journal
from samplehd.dataset.layout import (
    CANDIDATES_FILE,
    EPISODE_DIR,
    FORMAT_VERSION,
    INFO_FILE,
    INSTRUCTIONS_FILE,
    SCENE_DIR,
    SCENES_FILE,
    DatasetInfo,
    InfoEpisode,
    is_temporary,
    parse_episode_name,
)
from samplehd.dataset.outputs import inside_dataset
from samplehd.dataset.validate import validate_episode_file
from samplehd.errors import DatasetError, SamplehdError
from samplehd.fileio import not_a_regular_file, read_json
from samplehd.language.instruction_file import InstructionEntry
from samplehd.record.episode import Episode
from samplehd.scene.annotate import SceneAnnotation
from samplehd.tasks.task import Task, parse_task

__all__ = ["DatasetReader", "EpisodeEntry", "EpisodeMeta"]


@dataclass(frozen=True)
class EpisodeEntry:
    """One episode of a dataset, as listed in ``info.json``.

    Attributes:
        instruction_index: index into ``instructions.json`` (the dataset's numbering of episodes).
        scene_index: index into ``scenes.json``.
        slot: the instruction's position among its scene's candidates.
        file: path of the episode file relative to the dataset root.
        seed: seed of the episode's randomness.
        family: task family.
        split: train or test.
        num_frames: frames in the episode (-1 when unknown: dataset still being written).
        size: file size [bytes] (-1 when unknown).
        sha256: file digest ("" when unknown).
    """

    instruction_index: int
    scene_index: int
    slot: int
    file: str
    seed: int
    family: str
    split: str
    num_frames: int = -1
    size: int = -1
    sha256: str = ""

    def to_dict(self) -> dict[str, object]:
        return dict(self.__dict__)

    @classmethod
    def from_dict(cls, d: InfoEpisode) -> EpisodeEntry:
        return cls(**{k: d[k] for k in cls.__dataclass_fields__ if k in d})


# The root attributes an episode file holds (in the writer's order), the ones read into typed fields.
_META_ATTRS = ("format_version", "scene_index", "instruction_index", "family", "seed", "success", "num_frames",
               "subtasks", "info", "slot", "instruction", "task")


@dataclass(frozen=True)
class EpisodeMeta:
    """An episode file's attributes, without frames or images
    (:func:`samplehd.dataset.container.read_meta`, typed).

    Attributes:
        stem: the file's name without its suffix.
        format_version: the file's format version.
        scene_index: index into ``scenes.json``.
        instruction_index: the episode's index in the dataset (its ``instruction_index``).
        family: task family.
        seed: seed of the episode's randomness.
        success: the checker's verdict on the final state.
        num_frames: recorded frames.
        subtasks: subtask names, indexed by the frames' ``subtask_index``.
        info: checker report, grasp choices, control rate, disturbance, ... (free-form JSON object).
        slot: the instruction's position among its scene's candidates (None: not recorded).
        instruction: the instruction's text (None: not recorded).
        task: the task (None: not recorded).
        render: the render settings of the stored images (None: no images).
        images: stored modalities per camera.
        image_frames: per camera with images at keyframes only, the frames that have them.
        extra: any other root attributes of the file, in its order.
    """

    stem: str
    format_version: str
    scene_index: int
    instruction_index: int
    family: str
    seed: int
    success: bool
    num_frames: int
    subtasks: tuple[str, ...]
    info: dict[str, Any]
    slot: int | None = None
    instruction: str | None = None
    task: Task | None = None
    render: dict[str, Any] | None = None
    images: dict[str, tuple[str, ...]] = field(default_factory=dict)
    image_frames: dict[str, tuple[int, ...]] = field(default_factory=dict)
    extra: dict[str, object] = field(default_factory=dict)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> EpisodeMeta:
        """From :func:`samplehd.dataset.container.read_meta`'s mapping."""
        task = d.get("task")
        family = str(d["family"])
        return cls(
            stem=str(d["stem"]), format_version=str(d.get("format_version", "")), scene_index=int(d["scene_index"]),
            instruction_index=int(d["instruction_index"]), family=family, seed=int(d["seed"]),
            success=bool(d["success"]), num_frames=int(d["num_frames"]),
            subtasks=tuple(str(x) for x in d["subtasks"]), info=dict(d["info"]),
            slot=int(d["slot"]) if "slot" in d else None,
            instruction=str(d["instruction"]) if "instruction" in d else None,
            task=parse_task(task, family) if isinstance(task, Mapping) else None,
            render=dict(d["render"]) if isinstance(d.get("render"), Mapping) else None,
            images={c: tuple(m) for c, m in (d.get("images") or {}).items()},
            image_frames={c: tuple(f) for c, f in (d.get("image_frames") or {}).items()},
            extra={k: v for k, v in d.items()
                   if k not in (*_META_ATTRS, "stem", "render", "images", "image_frames")})

    def to_dict(self) -> dict[str, object]:
        """As :func:`samplehd.dataset.container.read_meta` reads it: the task as the file stores it
        (the executor's ``{type, objects, subject, relation}``, keys sorted)."""
        d: dict[str, Any] = {"stem": self.stem, "format_version": self.format_version,
                             "scene_index": self.scene_index, "instruction_index": self.instruction_index,
                             "family": self.family, "seed": self.seed, "success": self.success,
                             "num_frames": self.num_frames, "subtasks": list(self.subtasks), "info": self.info}
        if self.slot is not None:
            d["slot"] = self.slot
        if self.instruction is not None:
            d["instruction"] = self.instruction
        if self.task is not None:
            d["task"] = dict(sorted(self.task.to_program_dict().items()))
        d.update(self.extra)
        d["render"] = self.render
        d["images"] = {c: list(m) for c, m in self.images.items()}
        d["image_frames"] = {c: list(f) for c, f in self.image_frames.items()}
        return d


class DatasetReader:
    """Read access to a dataset directory written by ``samplehd generate``.

    Attributes:
        root: the dataset directory.
        info: ``info.json`` (empty-ish with ``status: "in_progress"`` while generation runs).
        complete: whether generation finished (``info.json`` lists the episodes).

    Args:
        path: the dataset directory.

    Raises:
        DatasetError: ``path`` is not a dataset directory.
    """

    def __init__(self, path: str | Path) -> None:
        self.root = Path(path)
        if not self.root.is_dir():
            raise DatasetError(f"{self.root}: not a dataset directory (does not exist)")
        info_path = self.root / INFO_FILE
        if not info_path.exists():
            raise DatasetError(f"{self.root}: not a samplehd dataset ({INFO_FILE} is missing)")
        self.info: DatasetInfo = read_json(info_path)
        if not isinstance(self.info, dict):
            raise DatasetError(f"{info_path}: expected a JSON object, got {type(self.info).__name__}")
        version = self.info.get("format_version")
        if version != FORMAT_VERSION:
            raise DatasetError(f"{info_path}: format_version {version!r} is not one this samplehd reads "
                               f"(valid: {FORMAT_VERSION!r}); use the samplehd version that wrote it")
        self.complete = self.info.get("status") == "complete"
        self._scenes: list[SceneAnnotation] | None = None
        self._instructions: list[InstructionEntry] | None = None
        self._episodes: list[EpisodeEntry] | None = None

    # --- metadata -------------------------------------------------------------------------------
    @property
    def config(self) -> dict[str, Any]:
        """The resolved generation config."""
        return dict(self.info.get("config", {}))

    @property
    def catalogue(self) -> str:
        """The built-in object catalogue the scenes were drawn from (``info.json``'s record, else the
        config's of a dataset still being written; ``procedural`` for datasets older than the choice)."""
        recorded = self.info.get("catalogue")
        if isinstance(recorded, dict) and isinstance(recorded.get("name"), str):
            return recorded["name"]
        scene = self.config.get("scene")
        return str(scene.get("catalogue", LEGACY_CATALOGUE)) if isinstance(scene, dict) else LEGACY_CATALOGUE

    @property
    def scenes(self) -> list[SceneAnnotation]:
        """Scene annotations (CLEVR layout), sorted by ``image_index``."""
        if self._scenes is None:
            path = self.root / SCENES_FILE
            if path.exists():
                self._scenes = _entries(path, "scenes", "image_index")
            else:
                found = []
                for p in sorted((self.root / SCENE_DIR).glob("*.json")):
                    if not is_temporary(p.name):
                        try:
                            found.append(read_json(p))
                        except DatasetError:
                            continue  # being written
                self._scenes = sorted(found, key=lambda s: s["image_index"])
        return self._scenes

    def scene(self, index: int) -> SceneAnnotation:
        """The scene with ``image_index == index``."""
        for s in self.scenes:
            if s["image_index"] == index:
                return s
        raise DatasetError(f"{self.root}: no scene {index}")

    @property
    def instructions(self) -> list[InstructionEntry]:
        """Instructions with episodes, in ``instruction_index`` order (CLEVR question-file entries)."""
        if self._instructions is None:
            if self.complete:
                self._instructions = _entries(self.root / INSTRUCTIONS_FILE, "instructions", "image_index")
            else:
                by_key = {(c["image_index"], c["slot"]): c for c in self._candidates()}
                self._instructions = []
                for e in self.episodes:
                    entry = dict(by_key.get((e.scene_index, e.slot), {}))
                    entry["instruction_index"] = e.instruction_index
                    self._instructions.append(entry)
        return self._instructions

    def _candidates(self) -> list[InstructionEntry]:
        path = self.root / CANDIDATES_FILE
        return list(read_json(path)["instructions"]) if path.exists() else []

    @property
    def episodes(self) -> list[EpisodeEntry]:
        """Every episode, in ``instruction_index`` order."""
        if self._episodes is None:
            if self.complete:
                self._episodes = [self._entry(i, e) for i, e in enumerate(self.info.get("episodes") or [])]
            else:
                self._episodes = self._scan_episodes()
        return self._episodes

    def _entry(self, index: int, entry: Any) -> EpisodeEntry:
        """Episode ``index`` of ``info.json``, its file checked to lie inside the dataset folder."""
        where = f"{self.root / INFO_FILE} episodes[{index}]"
        if not isinstance(entry, dict):
            raise DatasetError(f"{where}: {entry!r} is not an episode entry (a JSON object with file, seed, "
                               f"...); the file is damaged: regenerate or restore it")
        missing = [k for k in ("instruction_index", "scene_index", "slot", "file", "seed", "family", "split")
                   if k not in entry]
        if missing:
            raise DatasetError(f"{where}: lacks {', '.join(missing)}; the file is damaged: regenerate or restore it")
        inside_dataset(self.root, entry["file"], f"{where}.file")
        try:
            return EpisodeEntry.from_dict(entry)
        except TypeError as exc:
            raise DatasetError(f"{where}: {exc}") from None

    def _scan_episodes(self) -> list[EpisodeEntry]:
        cands = {(c["image_index"], c["slot"]): c for c in self._candidates()}
        keys = []
        folder = self.root / EPISODE_DIR
        for p in sorted(folder.iterdir()) if folder.is_dir() else []:
            key = parse_episode_name(p.name)
            if key is not None and not is_temporary(p.name):
                keys.append((key, p))
        out = []
        for i, ((scene, slot), p) in enumerate(sorted(keys)):
            c = cands.get((scene, slot), {})
            out.append(EpisodeEntry(i, scene, slot, f"{EPISODE_DIR}/{p.name}", int(c.get("seed", -1)),
                                    str(c.get("family", "")), str(c.get("split", ""))))
        return out

    def check_intact(self, verify: bool = False) -> None:
        """Check that every listed episode file is there with its recorded size, before a command
        changes or exports the dataset (so a damaged dataset is refused, never made worse).

        Args:
            verify: also read every episode file whole and compare it with ``info.json`` (SHA-256,
                frames, shapes, stored images), as ``samplehd validate`` does: what a command that
                rewrites the episodes runs first, so it never re-hashes (launders) a damaged file.

        Raises:
            DatasetError: one line naming the first missing or damaged file (``samplehd validate``
                lists them all).
        """
        if self.complete and not isinstance(self.info.get("episodes"), list):
            raise DatasetError(f"{self.root / INFO_FILE}: episodes: missing or not a list")
        hint = f"nothing was changed; `samplehd validate {self.root}` lists every problem"
        if self.complete:
            if not (self.root / SCENES_FILE).is_file():  # else the scenes would be read from scenes/ unseen
                raise DatasetError(f"{self.root / SCENES_FILE}: missing, but {INFO_FILE} says the dataset is "
                                   f"complete; {hint}")
            self.scenes, self.instructions  # noqa: B018 - both files readable and of the right shape
            seen: dict[str, int] = {}
            for k, entry in enumerate(self.info["episodes"]):
                file = entry.get("file") if isinstance(entry, dict) else None
                if isinstance(file, str) and file in seen:
                    raise DatasetError(f"{self.root / INFO_FILE}: episodes[{k}] lists {file!r} again (as "
                                       f"episodes[{seen[file]}] does); each episode file once; {hint}")
                if isinstance(file, str):
                    seen[file] = k
        for i, e in enumerate(self.episodes):
            path = self.episode_path(i)
            why = not_a_regular_file(path)
            if why is not None:
                raise DatasetError(f"{path}: is {why}, not an episode file; {hint}")
            if not path.is_file():
                raise DatasetError(f"{path}: missing, but {INFO_FILE} lists it; {hint}")
            size = path.stat().st_size
            if e.size >= 0 and size != e.size:
                raise DatasetError(f"{path}: {size} bytes, but {INFO_FILE} records {e.size} (damaged or "
                                   f"truncated); {hint}")
        if verify and self.complete:
            # While a rerender is unfinished its episodes hold either the old or the new images: check
            # the files against their recorded digests and frames, not against one render setting.
            render = None if "rerender" in self.info else self.info.get("render")
            for i, entry in enumerate(self.info["episodes"]):
                problems = validate_episode_file(self.episode_path(i), entry, render)
                if problems:
                    raise DatasetError(f"{problems[0]}; {hint}")

    def __len__(self) -> int:
        return len(self.episodes)

    def __iter__(self) -> Iterator[Episode]:
        for i in range(len(self)):
            yield self.episode(i)

    # --- episodes -------------------------------------------------------------------------------
    def episode_path(self, index: int) -> Path:
        """Path of episode ``index``'s file."""
        eps = self.episodes
        if not 0 <= index < len(eps):
            raise DatasetError(f"{self.root}: no episode {index}; valid: 0..{len(eps) - 1}")
        return inside_dataset(self.root, eps[index].file, f"{self.root / INFO_FILE} episodes[{index}].file")

    def episode(self, index: int, images: str = "lazy") -> Episode:
        """Episode ``index`` (its ``instruction_index``).

        Args:
            index: the episode / instruction index.
            images: ``"lazy"`` (each ``images[cam][mod]`` reads one frame per index, see
                :class:`samplehd.dataset.container.FrameImages`), ``"load"`` (arrays) or ``"none"``.

        Raises:
            DatasetError: no such episode, or its file is truncated or corrupted.
        """

        return read_episode(self.episode_path(index), images=images, instruction_index=index)

    def episode_meta(self, index: int) -> EpisodeMeta:
        """Episode ``index``'s attributes without frames or images: stem, family, success, num_frames,
        subtasks, info (checker report, control_hz), task, render settings and stored ``images``
        {camera: modalities} (empty, with ``render`` None, for an episode stored without images).

        Raises:
            DatasetError: no such episode, or its file is truncated or corrupted.
        """
        path = self.episode_path(index)
        try:
            return replace(EpisodeMeta.from_dict(read_meta(path)), instruction_index=index)
        except (KeyError, TypeError, ValueError, SamplehdError) as exc:
            raise DatasetError(f"{path}: not an episode file this samplehd reads ({exc})") from None

    def listing(self) -> list[dict[str, Any]]:
        """A cheap listing of every episode (attributes only); unreadable files are listed with
        ``error`` set instead of raising."""
        out = []
        for i, e in enumerate(self.episodes):
            try:
                meta = self.episode_meta(i).to_dict()
                meta.pop("info", None)
            except DatasetError as exc:
                meta = {"stem": Path(e.file).stem, "error": str(exc)}
            out.append({**e.to_dict(), **meta, "instruction_index": i})
        return out

    def frames(self, index: int, fields: list[str] | tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
        """Selected frame fields of episode ``index`` (no images, no other fields are read)."""
        return read_frames(self.episode_path(index), fields)

    def image(self, index: int, camera: str, modality: str, frame: int) -> Any:
        """One decoded image frame: rgb uint8 H×W×3, depth float32 [m], segmentation ids."""
        return read_image(self.episode_path(index), camera, modality, frame)

    def rejections(self) -> list[JournalRecord]:
        """Instruction candidates whose ground-truth path failed: {scene_index, slot, reason, message}."""
        return [r for r in read_journal(self.root) if r.get("status") == "rejected"]

    def instruction(self, index: int) -> InstructionEntry:
        """The instruction entry of episode ``index``."""
        return self.instructions[index]


def _entries(path: Path, key: str, index: str) -> list[dict[str, Any]]:
    """The ``key`` list of a CLEVR-layout file, each entry an object with an integer ``index``."""
    doc = read_json(path)
    items = doc.get(key) if isinstance(doc, dict) else None
    if not isinstance(items, list):
        raise DatasetError(f"{path}: expected {{info, {key}: [...]}}; the file is damaged: regenerate or restore it")
    for k, item in enumerate(items):
        if not isinstance(item, dict) or not isinstance(item.get(index), int):
            raise DatasetError(f"{path}: {key}[{k}] is not an entry with an integer {index}; the file is damaged: "
                               f"regenerate or restore it")
    return items

"""A generated dataset's files as the viewer tests read them, and the states a real dataset passes
through, made from a copy of it: mid-generation (``samplehd generate`` still running) and an episode
whose success check failed. Everything is written the way the dataset's writer writes it."""

from __future__ import annotations

import dataclasses
import json
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from samplehd.dataset.layout import (
    EPISODE_DIR,
    INFO_FILE,
    INSTRUCTIONS_FILE,
    JOURNAL_FILE,
    SCENES_FILE,
    tmp_path,
)

__all__ = ["DatasetFiles", "finish_generation", "read_dataset_files", "stop_generation_midway",
           "write_failed_episode"]


@dataclass(frozen=True)
class DatasetFiles:
    """A complete dataset's own files, parsed: what the viewer must show.

    Attributes:
        root: the dataset folder.
        info: ``info.json``.
        scenes: ``scenes.json``'s scenes, in index order.
        instructions: ``instructions.json``'s instructions.
        candidates: ``candidates.json``'s instruction candidates.
        journal: ``journal.jsonl``'s records (one per attempted candidate).
    """

    root: Path
    info: dict[str, Any]
    scenes: list[dict[str, Any]]
    instructions: list[dict[str, Any]]
    candidates: list[dict[str, Any]]
    journal: list[dict[str, Any]]

    @property
    def episodes(self) -> list[dict[str, Any]]:
        """``info.json``'s episode entries, in episode order."""
        return self.info["episodes"]

    @property
    def stems(self) -> list[str]:
        """Episode names as the viewer gives them (file stems, ``s000001_00``), in episode order."""
        return [Path(e["file"]).stem for e in self.episodes]

    @property
    def rejections(self) -> list[dict[str, Any]]:
        """Journal records of rejected paths."""
        return [r for r in self.journal if r["status"] == "rejected"]

    def candidate(self, scene_index: int, slot: int) -> dict[str, Any]:
        return next(q for q in self.candidates if (q["image_index"], q["slot"]) == (scene_index, slot))

    def instructions_of(self, scene_index: int) -> list[dict[str, Any]]:
        return [q for q in self.instructions if q["image_index"] == scene_index]

    def outcomes(self, scene_index: int) -> set[str]:
        """What the scene grid's ``success`` filter should find for a scene."""
        found = {"success" for e in self.episodes if e["scene_index"] == scene_index}
        found |= {"failure" for r in self.rejections if r["scene_index"] == scene_index}
        return found or {"none"}


def read_dataset_files(root: Path) -> DatasetFiles:
    """Parse the files of a complete dataset."""
    return DatasetFiles(
        root=root,
        info=json.loads((root / INFO_FILE).read_text()),
        scenes=json.loads((root / SCENES_FILE).read_text())["scenes"],
        instructions=json.loads((root / INSTRUCTIONS_FILE).read_text())["instructions"],
        candidates=json.loads((root / "candidates.json").read_text())["instructions"],
        journal=[json.loads(line) for line in (root / JOURNAL_FILE).read_text().splitlines() if line],
    )


def stop_generation_midway(root: Path, files: DatasetFiles, written: str, unlogged: str, writing: str) -> None:
    """Turn a copy of a complete dataset into the state ``samplehd generate`` leaves it in midway.

    ``info.json`` is the writer's first, ``in_progress`` one; ``scenes.json`` and
    ``instructions.json`` (written last) do not exist yet. Episode ``written`` is finished and
    journaled; ``unlogged``'s file is written but its journal line is only half appended; ``writing``
    is a half-written temporary file; every other episode is not started. Rejected paths stay
    journaled.

    Args:
        root: a copy of the dataset ``files`` describes (changed in place).
        files: the complete dataset's files.
        written, unlogged, writing: episode names (file stems).
    """
    info = {k: files.info[k] for k in ("format_version", "versions", "config")}
    (root / INFO_FILE).write_text(json.dumps({**info, "status": "in_progress"}))
    (root / SCENES_FILE).unlink()
    (root / INSTRUCTIONS_FILE).unlink()
    episodes = root / EPISODE_DIR
    for path in sorted(episodes.iterdir()):
        if path.stem == writing:
            half = path.read_bytes()[: path.stat().st_size // 2]
            tmp_path(path).write_bytes(half)
        if path.stem not in (written, unlogged):
            path.unlink()
    by_stem = {f"s{r['scene_index']:06d}_{r['slot']:02d}": r for r in files.journal}
    lines = [json.dumps(r, sort_keys=True) + "\n" for r in files.rejections]
    lines.append(json.dumps(by_stem[written], sort_keys=True) + "\n")
    torn = json.dumps(by_stem[unlogged], sort_keys=True)
    (root / JOURNAL_FILE).write_text("".join(lines) + torn[: len(torn) // 2])


def finish_generation(root: Path, files: DatasetFiles) -> None:
    """Give a copy the complete dataset's files back, the way generation ends (episodes, journal, then
    the metadata written last)."""
    shutil.copytree(files.root / EPISODE_DIR, root / EPISODE_DIR, dirs_exist_ok=True)
    for path in (root / EPISODE_DIR).iterdir():
        if path.name.startswith("."):
            path.unlink()
    for name in (JOURNAL_FILE, INSTRUCTIONS_FILE, SCENES_FILE, INFO_FILE):
        shutil.copy(files.root / name, root / name)


def write_failed_episode(root: Path, stem: str, reason: str) -> None:
    """Rewrite episode ``stem`` of ``root`` with the dataset's own writer as one whose success check
    failed: a generated dataset keeps only successes, but the file format and the viewer hold
    failures too (recorded rollouts)."""
    from samplehd.dataset.container import read_episode, read_meta, write_episode

    path = root / EPISODE_DIR / f"{stem}.h5"
    meta = read_meta(path)
    episode = read_episode(path, images="load")
    info = {**episode.info, "check": {**episode.info.get("check", {}), "success": False, "reason": reason}}
    write_episode(path, dataclasses.replace(episode, success=False, info=info),
                  extra={k: meta[k] for k in ("slot", "instruction", "task", "split") if k in meta},
                  render=meta["render"])

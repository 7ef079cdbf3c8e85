"""Names and path templates of a samplehd dataset directory (see docs/FORMAT.md).

Every file name a writer or reader uses comes from here, so the layout is defined in one place.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, TypedDict

from samplehd.catalogue.model import CatalogueRecord

__all__ = [
    "CANDIDATES_FILE",
    "DatasetInfo",
    "InfoEpisode",
    "DEPTH_DIR",
    "EPISODE_DIR",
    "EPISODE_SUFFIX",
    "FORMAT_VERSION",
    "IMAGE_DIR",
    "INFO_FILE",
    "INSTRUCTIONS_FILE",
    "JOURNAL_FILE",
    "RESUME_HINT",
    "RUNS_FILE",
    "SCENES_FILE",
    "SCENE_DIR",
    "SEGMENTATION_DIR",
    "TMP_MARK",
    "episode_name",
    "is_temporary",
    "parse_episode_name",
    "scene_image_files",
    "tmp_path",
]


class InfoEpisode(TypedDict, total=False):
    """One item of ``info.json``'s ``episodes`` (:class:`samplehd.dataset.reader.EpisodeEntry` reads it);
    a disturbed episode adds its labels ``success``, ``disturbance`` and ``outcome``."""

    instruction_index: int
    scene_index: int
    slot: int
    file: str
    seed: int
    family: str
    split: str
    num_frames: int
    size: int
    sha256: str
    success: bool
    disturbance: str
    outcome: str


class DatasetInfo(TypedDict, total=False):
    """``info.json`` (docs/FORMAT.md): written ``in_progress`` at the start (format, versions, machine,
    config, catalogue) and completed at the end (counts, rejections, seeds, render settings, episodes);
    ``rerender`` is present while a rerender is unfinished."""

    format_version: str
    status: str
    versions: dict[str, str]
    machine: dict[str, Any]
    config: dict[str, Any]
    catalogue: CatalogueRecord
    counts: dict[str, Any]
    target_reached: bool
    rejections: dict[str, Any]
    seeds: dict[str, Any]
    render: dict[str, Any]
    rerender: dict[str, Any]
    episodes: list[InfoEpisode]


FORMAT_VERSION = "1.0"

INFO_FILE = "info.json"
SCENES_FILE = "scenes.json"
INSTRUCTIONS_FILE = "instructions.json"
CANDIDATES_FILE = "candidates.json"
JOURNAL_FILE = "journal.jsonl"
RUNS_FILE = "runs.jsonl"
SCENE_DIR = "scenes"
EPISODE_DIR = "episodes"
# The scene camera's images of each scene (named after the scene's image_filename stem).
IMAGE_DIR = "images"
DEPTH_DIR = "depth"
SEGMENTATION_DIR = "segmentation"
EPISODE_SUFFIX = ".h5"
# What a failed write during generation tells the user to do once the cause is fixed.
RESUME_HINT = "run the same generate command again with `resume`"
# Temporary files start with a dot and contain this mark; readers skip them.
TMP_MARK = ".tmp-"


def episode_name(scene_index: int, slot: int) -> str:
    """File name of the episode of instruction slot ``slot`` of scene ``scene_index``."""
    return f"s{scene_index:06d}_{slot:02d}{EPISODE_SUFFIX}"


def parse_episode_name(name: str) -> tuple[int, int] | None:
    """(scene index, slot) of an episode file name, or None for anything else."""
    if not name.endswith(EPISODE_SUFFIX) or name.startswith(".") or not name.startswith("s"):
        return None
    stem = name[1 : -len(EPISODE_SUFFIX)]
    scene, sep, slot = stem.partition("_")
    if not sep or not scene.isdigit() or not slot.isdigit():
        return None
    return int(scene), int(slot)


def scene_image_files(root: Path, image_filename: str) -> dict[str, Path]:
    """The image files of one scene: ``rgb`` (PNG), ``depth_png`` (uint16 millimetres), ``depth`` (the exact
    float32 metres, ``.npy``) and ``segmentation`` (instance-id PNG)."""
    stem = Path(image_filename).stem
    return {"rgb": root / IMAGE_DIR / f"{stem}.png", "depth_png": root / DEPTH_DIR / f"{stem}.png",
            "depth": root / DEPTH_DIR / f"{stem}.npy", "segmentation": root / SEGMENTATION_DIR / f"{stem}.png"}


def tmp_path(path: Path) -> Path:
    """A temporary name next to ``path`` (same file system, so a rename is atomic)."""
    return path.with_name(f".{path.name}{TMP_MARK}{os.getpid()}")


def is_temporary(name: str) -> bool:
    """Whether a file name is a writer's temporary file."""
    return name.startswith(".") and TMP_MARK in name

"""Readers that turn a samplehd dataset folder into the examples each model trains on.

Splits are the dataset's own (every ``test_every``-th scene is a test scene, with its instructions
and episodes). Training examples leave out what the generalisation levels hold out
(:mod:`samplehd.language.levels`); test examples carry their level so metrics can be split by it.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from samplehd.dataset.reader import DatasetReader
from samplehd.errors import ConfigError, DatasetError
from samplehd.language.levels import episode_level, held_out_instruction, held_out_object

__all__ = ["instruction_examples", "open_dataset", "scene_examples", "training_split"]


def open_dataset(path: str | Path) -> DatasetReader:
    """A reader for the ``dataset`` folder; one-line errors when it is not a dataset."""
    try:
        reader = DatasetReader(path)
    except DatasetError as exc:
        raise ConfigError(f"dataset={path}: {exc}", field="dataset") from None
    if not reader.scenes:
        raise ConfigError(f"dataset={path}: holds no scenes", field="dataset")
    return reader


def instruction_examples(reader: DatasetReader) -> dict[str, list[dict[str, Any]]]:
    """Every instruction candidate of the dataset (a path need not have succeeded for its language).

    Returns:
        ``{"train": [...], "test": [...]}``; each item is the instruction entry plus ``level``
        (L1–L4) and ``scene`` (its scene annotation). Train leaves out held-out paraphrases.
    """
    scenes = {s["image_index"]: s for s in reader.scenes}
    entries = reader._candidates() or reader.instructions  # noqa: SLF001 - candidates hold every instruction
    out: dict[str, list[dict[str, Any]]] = {"train": [], "test": []}
    for e in entries:
        scene = scenes.get(e.get("image_index"))
        if scene is None:
            continue
        item = dict(e, scene=scene, level=episode_level(e, scene))
        if scene.get("split") == "test":
            out["test"].append(item)
        elif not held_out_instruction(e):
            out["train"].append(item)
    if not out["train"]:
        raise ConfigError(f"dataset={reader.root}: no training instructions (candidates.json is empty)",
                          field="dataset")
    return out


def scene_examples(reader: DatasetReader) -> dict[str, list[dict[str, Any]]]:
    """Scenes with their images: ``{"train": [...], "test": [...]}`` of dicts with ``annotation``,
    ``rgb``, ``depth`` and ``segmentation`` paths and ``train_objects`` (indices of the objects
    whose attributes training may use: the held-out classes and combinations are left out)."""
    root = reader.root
    out: dict[str, list[dict[str, Any]]] = {"train": [], "test": []}
    for s in reader.scenes:
        stem = Path(s["image_filename"]).stem
        paths = {"rgb": root / "images" / f"{stem}.png", "depth": root / "depth" / f"{stem}.npy",
                 "segmentation": root / "segmentation" / f"{stem}.png"}
        missing = [str(p) for p in paths.values() if not p.exists()]
        if missing:
            raise ConfigError(f"dataset={root}: scene image missing: {missing[0]} (generate with scene images)",
                              field="dataset")
        keep = [i for i, o in enumerate(s["objects"]) if not held_out_object(o)]
        out["test" if s.get("split") == "test" else "train"].append(
            {"annotation": s, **paths, "train_objects": keep})
    if not out["train"]:
        raise ConfigError(f"dataset={root}: no training scenes", field="dataset")
    return out


def training_split(reader: Any, dataset: str | Path, families: Sequence[str] | None = None
                   ) -> tuple[list[int], list[int]]:
    """(training, test) episode indices of a dataset (of ``families``, if given): every test-split
    episode; the training split's episodes of level L1 (seen templates and objects: the other levels
    are held out for evaluation). One line naming ``dataset`` when no training episode is left."""
    scenes = {s["image_index"]: s for s in reader.scenes}
    train_k, test_k = [], []
    for e in reader.episodes:
        if families and e.family not in families:
            continue
        ins = reader.instruction(e.instruction_index)
        if e.split == "test":
            test_k.append(e.instruction_index)
        elif not held_out_instruction(ins) and episode_level(ins, scenes[e.scene_index]) == "L1":
            train_k.append(e.instruction_index)
    if not train_k:
        raise ConfigError(f"dataset={dataset}: no training episodes", field="dataset")
    return train_k, test_k

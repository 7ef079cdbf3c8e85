"""``instructions.json``: instructions for a set of scenes, in the layout of CLEVR's question file.

Layout::

    {
      "info": {"version": "1.0", "samplehd_version": ..., "seed": 0, "per_scene": 5,
               "balance": "templates", "families": [...], "templates": [{family, name, filename,
               index}], "scenes_info": {...}, "counts": {"families": {...}, "templates": {...}},
               "rejections": {reason: count}, "scenes": N, "scenes_without_instructions": M},
      "instructions": [
        {"split": "train", "image_index": 0, "image_filename": "...png",
         "instruction_index": 0, "instruction": "Move the red mug to the left side of the table.",
         "template_filename": "place.json", "template_index": 0, "template_name": "place_one",
         "family": "place",
         "task": {"type": "place", "objects": [2], "subject": "left", "relation": null},
         "targets": [2],
         "program": [{"type": "scene", "inputs": [], "value_inputs": []}, ...],
         "program_sequence": "place[left] scene filter_colour[red] filter_name[mug]",
         "params": {"R1": 2, "P": "left"},
         "references": {"R1": {"filters": {"colour": "red", "name": "mug"}, ...}}},
        ...
      ]
    }

CLEVR names its list ``questions``; samplehd names it ``instructions`` (a reader that expects
``questions`` can alias it). ``instruction_index`` counts over the whole file; ``template_index``
is the template's position in ``template_filename``, as CLEVR's ``question_family_index``.
``targets`` lists every object the task involves: the moved objects, then the subject object.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, TypedDict

import numpy as np

from samplehd.errors import ConfigError, DatasetError
from samplehd.fileio import read_json
from samplehd.language.constraints import Reachable, default_reachable
from samplehd.language.generator import TemplateBalancer, generate_instructions
from samplehd.language.scene import parse_scene
from samplehd.language.templates import Template, default_templates
from samplehd.version import __version__

__all__ = [
    "INSTRUCTIONS_FORMAT_VERSION",
    "InstructionEntry",
    "assign_splits",
    "generate_instruction_file",
    "parse_split_ratio",
    "read_instructions",
    "write_instructions",
]

INSTRUCTIONS_FORMAT_VERSION = "1.0"


class InstructionEntry(TypedDict, total=False):
    """One entry of ``instructions`` (the module docstring's layout); a dataset's entries add ``slot``,
    ``seed``, the episode's ``instruction_index`` and (instruction candidates) its ``file`` and
    ``candidate_index``. ``task`` is the executor's ``{type, objects, subject, relation}``
    (:meth:`samplehd.tasks.task.Task.to_program_dict`)."""

    split: str
    image_index: int
    image_filename: str
    instruction_index: int
    instruction: str
    template_filename: str
    template_index: int
    template_name: str
    family: str
    task: dict[str, Any]
    targets: list[int]
    program: list[dict[str, Any]]
    program_sequence: str
    params: dict[str, Any]
    references: dict[str, Any]
    slot: int
    seed: int
    file: str
    candidate_index: int


def parse_split_ratio(text: str) -> dict[str, float]:
    """Parse ``"train=0.9,test=0.1"`` (fractions are normalised to sum to 1).

    Raises:
        ConfigError: the text is malformed or a fraction is negative.
    """
    out: dict[str, float] = {}
    for item in text.split(","):
        name, sep, value = item.partition("=")
        try:
            fraction = float(value)
        except ValueError:
            fraction = -1.0
        if not sep or not name.strip() or not math.isfinite(fraction) or fraction < 0:
            raise ConfigError(
                f"split_ratio={text!r}: expected NAME=FRACTION[,NAME=FRACTION...], e.g. train=0.9,test=0.1",
                field="split_ratio",
            )
        out[name.strip()] = fraction
    total = sum(out.values())
    if total <= 0:
        raise ConfigError(f"split_ratio={text!r}: fractions sum to 0", field="split_ratio")
    return {k: v / total for k, v in out.items()}


def assign_splits(n_scenes: int, ratio: Mapping[str, float], rng: np.random.Generator) -> list[str]:
    """Assign each scene a split so that the counts follow ``ratio`` (largest remainders)."""
    names = list(ratio)
    exact = [ratio[k] * n_scenes for k in names]
    counts = [int(e) for e in exact]
    for k in sorted(range(len(names)), key=lambda k: counts[k] - exact[k])[: n_scenes - sum(counts)]:
        counts[k] += 1
    labels = [name for name, c in zip(names, counts, strict=True) for _ in range(c)]
    order = rng.permutation(n_scenes)
    out = [""] * n_scenes
    for position, scene in enumerate(order):
        out[int(scene)] = labels[position]
    return out


def generate_instruction_file(
    scenes: Iterable[Mapping[str, Any]],
    seed: int = 0,
    *,
    per_scene: int = 5,
    balance: str = "templates",
    families: Sequence[str] | None = None,
    templates: Sequence[Template] | None = None,
    reachable: Reachable = default_reachable,
    split_ratio: Mapping[str, float] | None = None,
    scenes_info: Mapping[str, Any] | None = None,
    progress: Callable[[int, int], None] | None = None,
    source: str = "scenes",
    total: int | None = None,
) -> dict[str, Any]:
    """Generate instructions for every scene and return the ``instructions.json`` document.

    Scene ``k`` draws from ``numpy.random.default_rng([seed, k])``; template use counts are shared
    across scenes in order, so the same scenes and seed give the same file.

    Args:
        scenes: scene dicts (CLEVR layout), in order; an iterator is consumed as scenes arrive
            (give ``total``).
        seed: the seed.
        per_scene: instructions to make per scene (fewer where a scene allows fewer).
        balance: ``"templates"`` or ``"families"``.
        families: only these families (default: all).
        templates: templates (default: the shipped ones).
        reachable: reachability test for pick and place points.
        split_ratio: reassign scene splits by these fractions (default: keep each scene's split).
        scenes_info: the scenes file's ``info``, copied into ``info.scenes_info``.
        progress: called as ``progress(done, total)`` after each scene.
        source: name of the scenes file for error messages.
        total: number of scenes (default: ``len(scenes)``).

    Raises:
        SceneError: a scene is malformed (the message names the scene index and field).
        ConfigError: bad balance, families or split ratio.
    """
    pool = list(templates if templates is not None else default_templates())
    balancer = TemplateBalancer(balance)
    count = total if total is not None else len(scenes)  # type: ignore[arg-type]
    splits = assign_splits(count, split_ratio, np.random.default_rng([seed, 1 << 30])) if split_ratio else None
    entries: list[dict[str, Any]] = []
    rejections: Counter[str] = Counter()
    empty = 0
    for k, raw in enumerate(scenes):
        scene = parse_scene(raw, where=f"{source}: scene {k}")
        result = generate_instructions(
            scene,
            np.random.default_rng([seed, k]),
            pool,
            per_scene=per_scene,
            balance=balance,
            families=families,
            reachable=reachable,
            balancer=balancer,
        )
        rejections.update(result.rejections)
        empty += not result.instructions
        for inst in result.instructions:
            entry = {
                "split": splits[k] if splits else scene.split,
                "image_index": scene.image_index,
                "image_filename": scene.image_filename,
                "instruction_index": len(entries),
            }
            entry.update(inst.to_dict())
            entries.append(entry)
        if progress is not None:
            progress(k + 1, count)
    info = {
        "version": INSTRUCTIONS_FORMAT_VERSION,
        "samplehd_version": __version__,
        "seed": seed,
        "per_scene": per_scene,
        "balance": balance,
        "families": sorted({t.family for t in pool if families is None or t.family in families}),
        "split_ratio": dict(split_ratio) if split_ratio else None,
        "templates": [{"family": t.family, "name": t.name, "filename": t.filename, "index": t.index} for t in pool],
        "scenes_info": dict(scenes_info or {}),
        "scenes": count,
        "scenes_without_instructions": empty,
        "counts": {
            "families": dict(sorted(balancer.family_counts.items())),
            "templates": dict(sorted(balancer.template_counts.items())),
            "splits": dict(sorted(Counter(e["split"] for e in entries).items())),
        },
        "rejections": dict(sorted(rejections.items())),
    }
    return {"info": info, "instructions": entries}


def write_instructions(path: str | Path, document: Mapping[str, Any]) -> Path:
    """Write an ``instructions.json`` document (creating parent folders)."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(path.suffix + ".tmp")
        with tmp.open("w", encoding="utf-8") as f:
            json.dump(document, f, indent=1)
            f.write("\n")
        tmp.replace(path)
    except OSError as exc:
        raise DatasetError(f"{path}: cannot write: {exc.strerror}") from None
    return path


_REQUIRED = ("image_index", "instruction", "family", "task", "program", "program_sequence")


def read_instructions(path: str | Path) -> dict[str, Any]:
    """Read and check an ``instructions.json`` (a ``questions`` list is accepted too).

    Raises:
        DatasetError: the file is missing, not JSON, or an entry lacks a field.
    """
    path = Path(path)
    data = read_json(path, DatasetError)
    if not isinstance(data, Mapping):
        raise DatasetError(f"{path}: expected {{info, instructions: [...]}}")
    entries = data.get("instructions", data.get("questions"))
    if not isinstance(entries, list):
        raise DatasetError(f"{path}: instructions: missing or not a list")
    for k, e in enumerate(entries):
        if not isinstance(e, Mapping):
            raise DatasetError(f"{path}: instructions[{k}]: expected an object")
        for key in _REQUIRED:
            if key not in e:
                raise DatasetError(f"{path}: instructions[{k}]: {key}: missing")
    return {"info": dict(data.get("info", {})), "instructions": entries}

"""Dataset statistics: counts per family, class, colour, material; frames per episode; rejections by
reason; and PNG bar charts of them drawn with Pillow."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any, TypedDict

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from samplehd.dataset.layout import DatasetInfo
from samplehd.dataset.reader import DatasetReader

__all__ = ["DatasetStats", "dataset_stats", "plot_bars", "write_plots"]


class FramesPerEpisode(TypedDict, total=False):
    """Episode lengths [frames]: min, median, mean, max, and a histogram ``{bin_start: count}`` of bins
    ``bin_width`` wide (empty when the dataset has no episode yet)."""

    min: int
    median: float
    mean: float
    max: int
    bin_width: int
    histogram: dict[int, int]


class DisturbanceStats(TypedDict, total=False):
    """Episodes of a dataset made with disturbances: ``{kind: {outcome: n}}``, and the same counts flat
    as ``{"kind outcome": n}``; both absent without disturbances."""

    disturbances: dict[str, dict[str, int]]
    disturbance_outcomes: dict[str, int]


class DatasetStats(DisturbanceStats):
    """The counts of :func:`dataset_stats` (see its docstring)."""

    scenes: int
    episodes: int
    frames: int
    families: dict[str, int]
    splits: dict[str, int]
    classes: dict[str, int]
    colours: dict[str, int]
    materials: dict[str, int]
    objects_per_scene: dict[int, int]
    frames_per_episode: FramesPerEpisode
    rejections: dict[str, dict[str, int]]


def dataset_stats(root: str | Path) -> DatasetStats:
    """Counts of a (complete or in-progress) dataset.

    Returns:
        ``{scenes, episodes, frames, families, splits, classes, colours, materials, objects_per_scene,
        frames_per_episode: {min, median, mean, max, bin_width, histogram: {bin_start: count}} (every
        bin from the lowest to the highest, empty ones too; bin ``k`` holds ``k .. k + bin_width - 1``),
        rejections: {scenes, instructions, paths}}`` — classes/colours/materials count scene objects; a
        dataset made with disturbances adds ``disturbances: {kind: {outcome: n}}`` and the same counts
        flat as ``disturbance_outcomes: {"kind outcome": n}`` (plotted).
    """
    reader = DatasetReader(root)
    scenes = reader.scenes
    objs = [o for s in scenes for o in s.get("objects", [])]
    frames = np.array([e.num_frames for e in reader.episodes if e.num_frames >= 0], dtype=np.int64)
    fpe: FramesPerEpisode = {}
    if len(frames):
        width = max(25, int(np.ceil((frames.max() - frames.min() + 1) / 12 / 25.0)) * 25)
        counts = Counter(int(b) for b in (frames // width) * width)
        starts = range(min(counts), max(counts) + width, width)
        fpe = {"min": int(frames.min()), "median": float(np.median(frames)), "mean": float(frames.mean()),
               "max": int(frames.max()), "bin_width": width, "histogram": {k: counts.get(k, 0) for k in starts}}
    rej = dict(reader.info.get("rejections", {}))
    if not rej.get("paths"):
        rej["paths"] = dict(Counter(r.get("reason", "?") for r in reader.rejections()))
    insts = reader.instructions
    return {
        "scenes": len(scenes),
        "episodes": len(reader.episodes),
        "frames": int(frames.sum()) if len(frames) else 0,
        "families": dict(sorted(Counter(i.get("family", "?") for i in insts).items())),
        "splits": dict(sorted(Counter(i.get("split", "?") for i in insts).items())),
        "classes": dict(sorted(Counter(o.get("name", "?") for o in objs).items())),
        "colours": dict(sorted(Counter(o.get("colour", o.get("color", "?")) for o in objs).items())),
        "materials": dict(sorted(Counter(o.get("material", "?") for o in objs).items())),
        "objects_per_scene": dict(sorted(Counter(len(s.get("objects", [])) for s in scenes).items())),
        "frames_per_episode": fpe,
        "rejections": {k: dict(sorted(v.items())) for k, v in rej.items() if isinstance(v, dict)},
        **_disturbance_stats(reader.info),
    }


def _disturbance_stats(info: DatasetInfo) -> DisturbanceStats:
    """``{disturbances: {kind: {outcome: n}}, disturbance_outcomes: {"kind outcome": n}}`` of a dataset
    made with disturbances (from info.json's episode entries); empty without."""
    entries = [e for e in info.get("episodes", []) if isinstance(e, dict) and "disturbance" in e]
    if not entries and "disturbances" not in info.get("counts", {}):
        return {}
    by_kind: dict[str, Counter[str]] = {}
    for e in entries:
        by_kind.setdefault(str(e["disturbance"]), Counter())[str(e.get("outcome", "?"))] += 1
    table = {k: dict(sorted(v.items())) for k, v in sorted(by_kind.items())}
    flat = {f"{k} {o}": n for k, v in table.items() for o, n in v.items()}
    return {"disturbances": table, "disturbance_outcomes": flat}


def plot_bars(path: Path, title: str, counts: dict[Any, int], width: int = 720) -> Path:
    """A horizontal bar chart PNG of ``counts`` (Pillow only)."""
    font = ImageFont.load_default()
    items = list(counts.items())
    row, top, left = 18, 30, 170
    height = top + row * max(len(items), 1) + 12
    img = Image.new("RGB", (width, height), "white")
    d = ImageDraw.Draw(img)
    d.text((8, 8), title, fill="black", font=font)
    vmax = max([v for _, v in items] or [1]) or 1
    for k, (label, v) in enumerate(items):
        y = top + k * row
        d.text((8, y + 2), str(label)[:26], fill="black", font=font)
        w = int((width - left - 70) * v / vmax)
        d.rectangle([left, y + 2, left + max(w, 1), y + row - 3], fill=(70, 110, 190))
        d.text((left + w + 6, y + 2), str(v), fill="black", font=font)
    path.parent.mkdir(parents=True, exist_ok=True)
    img.save(path)
    return path


def write_plots(stats: DatasetStats, out: Path) -> list[Path]:
    """Write one PNG per count table of :func:`dataset_stats` into ``out``."""
    written = []
    for key in ("families", "classes", "colours", "materials", "splits", "objects_per_scene", "disturbance_outcomes"):
        if stats.get(key):
            written.append(plot_bars(out / f"{key}.png", key.replace("_", " "), stats[key]))
    fpe = stats.get("frames_per_episode", {})
    hist = fpe.get("histogram")
    if hist:
        width = int(fpe["bin_width"])
        labels = {f"{k}-{k + width - 1}": v for k, v in sorted((int(k), v) for k, v in hist.items())}
        written.append(plot_bars(out / "frames_per_episode.png", "frames per episode", labels))
    for kind, counts in stats.get("rejections", {}).items():
        if counts:
            written.append(plot_bars(out / f"rejections_{kind}.png", f"{kind} rejections by reason", counts))
    return written

"""Seeded synthetic scenes in the scenes-file layout, for tests and benchmarks of this package.

Not the scene sampler: objects get random classes, sizes, materials, colours and positions on the
workspace, with table parts from :func:`samplehd.world.layout.table_parts_of` and relationships
from :func:`samplehd.world.relations.compute_relationships`. Class prototypes live in
``synthetic_objects.json``.
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.world.layout import DIRECTIONS, LAYOUT, TableLayout, table_parts_of
from samplehd.world.relations import compute_relationships

__all__ = ["synthetic_scene", "synthetic_scenes_file"]

_PROTOTYPES = Path(__file__).with_name("synthetic_objects.json")


@cache
def _prototypes() -> dict[str, Any]:
    with _PROTOTYPES.open(encoding="utf-8") as f:
        return json.load(f)


def _pick(rng: np.random.Generator, items: list[str]) -> str:
    return items[int(rng.integers(len(items)))]


def synthetic_scene(
    rng: np.random.Generator,
    n_objects: int,
    image_index: int = 0,
    split: str = "train",
    layout: TableLayout = LAYOUT,
    classes: list[str] | None = None,
    margin: float = 0.02,
) -> dict[str, Any]:
    """Return one random scene dict (CLEVR layout with SAMPLE-HD fields).

    Args:
        rng: random generator.
        n_objects: number of objects.
        image_index: the scene's index.
        split: the scene's split name.
        layout: table geometry.
        classes: classes to draw from (default: all prototypes).
        margin: relationship margin [m].
    """
    protos = _prototypes()
    names = classes or sorted(protos["classes"])
    sizes = list(protos["sizes"])
    lo, hi = np.asarray(layout.workspace_min), np.asarray(layout.workspace_max)
    objects: list[dict[str, Any]] = []
    placed: list[tuple[np.ndarray, float]] = []
    for _ in range(n_objects):
        name = _pick(rng, names)
        p = protos["classes"][name]
        size = _pick(rng, sizes)
        scale = protos["sizes"][size]
        extents = [round(e * scale, 4) for e in p["extents"]]
        radius = 0.5 * max(extents[:2])
        xy = lo + rng.random(2) * (hi - lo)
        for _try in range(60):  # keep objects apart when there is room; crowded scenes may overlap
            if all(np.hypot(*(xy - q)) > radius + r for q, r in placed):
                break
            xy = lo + rng.random(2) * (hi - lo)
        placed.append((xy, radius))
        colour = _pick(rng, p["colours"])
        aff = {
            "graspable": True,
            "handle_pickable": False,
            "container": False,
            "stackable_on": False,
            "stackable": False,
            **p["affordances"],
        }
        obj: dict[str, Any] = {
            "name": name,
            "shape": name,
            "color": colour,
            "colour": colour,
            "material": _pick(rng, p["materials"]),
            "size": size,
            "weight": protos["weights"][size],
            "table_part": table_parts_of(xy, layout),
            "3d_coords": [
                round(float(xy[0]), 4),
                round(float(xy[1]), 4),
                round(layout.table_height + extents[2] / 2, 4),
            ],
            "rotation": round(float(rng.uniform(0.0, 360.0)), 2),
            "pixel_coords": [0, 0, 0.0],
            "mass": round(0.2 * scale**3, 3),
            "bbox": {"extents": extents},
            "affordances": aff,
        }
        if "opening_radius" in p:
            obj["opening_radius"] = round(p["opening_radius"] * scale, 4)
        if "top_extent" in p:
            obj["top_extent"] = [round(e * scale, 4) for e in p["top_extent"]]
        objects.append(obj)
    return {
        "split": split,
        "image_index": image_index,
        "image_filename": f"SAMPLEHD_{split}_{image_index:06d}.png",
        "directions": {k: list(v) for k, v in DIRECTIONS.items()},
        "objects": objects,
        "relationships": compute_relationships(objects, DIRECTIONS, margin),
    }


def synthetic_scenes_file(
    rng: np.random.Generator, n_scenes: int, min_objects: int = 3, max_objects: int = 5
) -> dict[str, Any]:
    """Return a scenes file ``{info, scenes}`` of random scenes with min..max objects each."""
    scenes = [
        synthetic_scene(rng, int(rng.integers(min_objects, max_objects + 1)), image_index=i) for i in range(n_scenes)
    ]
    return {"info": {"version": "synthetic", "split": "train"}, "scenes": scenes}

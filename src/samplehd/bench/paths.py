"""Ground-truth path figures and the small scene/task generator the motion tests use.

:func:`simple_scene` places random catalogue objects upright on the workspace without overlap (the
real sampler in ``samplehd.scene.sampler`` also checks occlusion and settles the objects);
:func:`random_task` draws a task of a family whose objects satisfy the family's needs (graspable
moved objects, a container that fits, a flat base, room in the destination). Both take an explicit
generator, so the oracle statistics are reproducible from their seeds.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from samplehd.scene.layout import LAYOUT, OPPOSITE_PART, TABLE_PARTS, table_parts_of

__all__ = ["random_task", "simple_scene"]


def _instance(rng: np.random.Generator, classes: list[str] | None = None) -> Any:
    from samplehd.catalogue import ObjectInstance, load_catalogue

    cat = load_catalogue()
    names = classes or sorted(cat.classes)
    cls = cat.object_class(str(rng.choice(names)))
    variant = cls.variants[str(rng.choice(sorted(cls.variants)))]
    pairs = [p for p in variant.menu.pairs] or [(c, m) for c in variant.menu.colour for m in variant.menu.material
                                                  if cat.compatible(c, m)]
    colour, material = pairs[int(rng.integers(len(pairs)))]
    size = str(rng.choice(list(variant.menu.size)))
    return ObjectInstance(cls.name, variant.name, colour, material, size)


def simple_scene(rng: np.random.Generator, num_objects: int | None = None, index: int = 0, seed: int = 0,
                 classes: list[str] | None = None) -> Any:
    """A scene of 3–5 random objects standing upright, apart, inside the workspace.

    Args:
        rng: random generator.
        num_objects: number of objects (default: 3–5 at random).
        index: scene index.
        seed: seed recorded in the scene.
        classes: restrict to these classes.

    Returns:
        A ``samplehd.scene.spec.SceneSpec``.
    """
    from samplehd.catalogue import object_facts
    from samplehd.scene.spec import SceneObject, SceneSpec

    n = int(num_objects if num_objects is not None else rng.integers(3, 6))
    placed: list[tuple[np.ndarray, float]] = []
    objects = []
    lo, hi = np.array(LAYOUT.workspace_min), np.array(LAYOUT.workspace_max)
    for _ in range(200):
        if len(objects) == n:
            break
        inst = _instance(rng, classes)
        f = object_facts(inst)
        r = float(f.footprint_radius)
        for _try in range(60):
            xy = rng.uniform(lo + 0.5 * r, hi - 0.5 * r)
            if not LAYOUT.in_reach(xy):
                continue
            if all(np.linalg.norm(xy - p) > r + pr + 0.03 for p, pr in placed):
                yaw = float(rng.uniform(-math.pi, math.pi))
                placed.append((xy, r))
                objects.append(SceneObject(inst, (float(xy[0]), float(xy[1]), LAYOUT.table_height),
                                           (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))))
                break
    return SceneSpec(index=index, seed=seed, objects=tuple(objects))


def random_task(scene: Any, family: str, rng: np.random.Generator) -> dict[str, Any] | None:
    """A task dict of ``family`` on ``scene`` in the language executor's format, or None if the scene
    has no suitable objects."""
    from samplehd.catalogue import object_facts

    facts = [object_facts(o.instance) for o in scene.objects]
    pos = [np.asarray(o.pos[:2]) for o in scene.objects]
    n = len(facts)
    movable = [i for i in range(n) if facts[i].affordances.graspable and facts[i].graspable_sites]
    if not movable:
        return None
    if family in ("place", "remove"):
        if family == "remove":
            parts = [p for p in TABLE_PARTS if any(p in table_parts_of(pos[i]) for i in range(n))]
            rng.shuffle(parts)
            for p in parts:
                inside = [i for i in range(n) if p in table_parts_of(pos[i])]
                if all(i in movable for i in inside):
                    return {"type": "place", "objects": sorted(inside), "subject": OPPOSITE_PART[p]}
            return None
        part = str(rng.choice(TABLE_PARTS))
        cand = [i for i in movable if part not in table_parts_of(pos[i])]
        if not cand:
            return None
        k = 2 if len(cand) >= 2 and rng.random() < 0.3 else 1
        return {"type": "place", "objects": sorted(int(i) for i in rng.choice(cand, size=k, replace=False)),
                "subject": part}
    if family == "pick_up":
        return {"type": "pick_up", "objects": [int(rng.choice(movable))], "subject": None}
    if family == "place_relative":
        i = int(rng.choice(movable))
        ref = int(rng.choice([j for j in range(n) if j != i]))
        rel = str(rng.choice(["left", "right", "front", "behind"]))
        return {"type": "place_relative", "objects": [i], "subject": ref, "relation": rel}
    if family == "put":
        pairs = [(i, c) for i in movable for c in range(n) if c != i and facts[c].opening is not None
                 and facts[c].affordances.container and facts[i].footprint_radius < 0.8 * facts[c].opening.radius]
        if not pairs:
            return None
        i, c = pairs[int(rng.integers(len(pairs)))]
        return {"type": "put", "objects": [i], "subject": c}
    if family == "stack":
        pairs = [(i, b) for i in movable for b in range(n) if b != i and facts[b].affordances.stackable_on
                 and facts[i].affordances.stackable and facts[b].top.flat]
        if not pairs:
            return None
        i, b = pairs[int(rng.integers(len(pairs)))]
        return {"type": "stack", "objects": [i], "subject": b}
    if family == "stack_three":
        bases = [b for b in range(n) if facts[b].affordances.stackable_on and facts[b].top.flat]
        for b in rng.permutation(bases) if bases else []:
            mids = [m for m in movable if m != b and facts[m].affordances.stackable
                    and facts[m].affordances.stackable_on and facts[m].top.flat]
            for m in rng.permutation(mids) if mids else []:
                tops = [t for t in movable if t not in (b, m) and facts[t].affordances.stackable]
                if tops:
                    return {"type": "stack_three", "objects": [int(m), int(rng.choice(tops))], "subject": int(b)}
        return None
    raise ValueError(f"unknown family {family!r}")

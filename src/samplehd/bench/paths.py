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

from samplehd.world.layout import LAYOUT, OPPOSITE_PART, TABLE_PARTS, table_parts_of

__all__ = ["oracle_success", "oracle_table", "random_task", "run", "simple_scene"]


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


def _oracle_scene(args: tuple[int, int, int, str, tuple[str, ...] | None]) -> list[dict[str, Any]]:
    """Sample one scene with the real sampler, generate instructions with the real generator
    (families balanced), and run the oracle on each; returns one result dict per instruction."""
    import time

    import mujoco

    import samplehd  # noqa: F401
    from samplehd.language.generator import generate_instructions
    from samplehd.motion.assist import compile_scene_with_assist as compile_scene
    from samplehd.record.paths import PathRejected, plan_and_execute
    from samplehd.scene.annotate import annotate_scene
    from samplehd.scene.sampler import sample_scene

    index, seed, per_scene, out, families = args
    results = []
    try:
        sampled = sample_scene(index, seed)
    except Exception as exc:  # noqa: BLE001 - a scene the sampler cannot make is skipped, counted
        return [{"scene": index, "family": "-", "success": False, "reason": f"scene: {exc}", "skipped": True}]
    scene = sampled.scene
    model, data = compile_scene(scene)
    start = mujoco.MjData(model)
    mujoco.mj_copyData(start, model, data)
    ann = annotate_scene(scene, model, data, 640, 360)
    rng = np.random.default_rng(seed)
    gen = generate_instructions(ann, rng, per_scene=per_scene, balance="families", families=families)
    for k, ins in enumerate(gen.instructions):
        mujoco.mj_copyData(data, model, start)
        t0 = time.perf_counter()
        r: dict[str, Any] = {"scene": index, "instruction": k, "family": ins.family, "text": ins.text,
                             "task": ins.task.to_dict(),
                             "classes": [scene.objects[i].instance.class_name for i in ins.targets]}
        try:
            ep = plan_and_execute(scene, ins.task.to_dict(), np.random.default_rng([seed, k]), family=ins.family,
                                  instruction_index=k, directions=ann["directions"], compiled=(model, data))
            r.update(success=True, attempts=ep.info["attempts"], frames=ep.num_frames,
                     failed=[a["reason"] for a in ep.info["failed_attempts"]],
                     disturbed=ep.info["check"]["disturbed"], fallen=ep.info["check"]["fallen"])
        except PathRejected as exc:
            r.update(success=False, reason=exc.reason, failed=[a["reason"] for a in exc.attempts],
                     message=str(exc)[:200])
        r["seconds"] = time.perf_counter() - t0
        results.append(r)
        if out:
            import json

            with open(out, "a", encoding="utf-8") as f:
                f.write(json.dumps(r) + "\n")
    return results


def oracle_success(num_scenes: int, base_seed: int, per_scene: int = 5, workers: int = 2,
                   out: str = "", families: tuple[str, ...] | None = None) -> list[dict[str, Any]]:
    """Oracle success over real sampled scenes and generated instructions.

    Args:
        num_scenes: scenes to sample (seeds ``base_seed + i``).
        base_seed: first seed.
        per_scene: instructions per scene.
        workers: worker processes.
        out: JSONL file to append per-instruction results to as they finish ("" for none).
        families: only instructions of these families (None: all, balanced).

    Returns:
        One dict per instruction: family, success, attempts, frames, reason, seconds.
    """
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    jobs = [(i, base_seed + i, per_scene, out, families) for i in range(num_scenes)]
    results: list[dict[str, Any]] = []
    if workers <= 1:
        for j in jobs:
            results += _oracle_scene(j)
        return results
    with ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn")) as pool:
        for rs in pool.map(_oracle_scene, jobs, chunksize=1):
            results += rs
    return results


def oracle_table(results: list[dict[str, Any]]) -> str:
    """Per family: attempted, first-try and final success rates, and failure reasons."""
    from collections import Counter, defaultdict

    by: dict[str, Counter] = defaultdict(Counter)
    for r in results:
        if r.get("skipped"):
            continue
        c = by[r["family"]]
        c["n"] += 1
        if r["success"]:
            c["ok"] += 1
            c["first"] += int(r.get("attempts", 1) == 1)
        else:
            c["reason:" + r["reason"]] += 1
    lines = [f"{'family':15s} {'pairs':>5s} {'first try':>10s} {'after retries':>14s}  failures"]
    tot = Counter()
    for fam in sorted(by):
        c = by[fam]
        tot.update({k: v for k, v in c.items() if not k.startswith("reason:")})
        fails = ", ".join(f"{k[7:]} {v}" for k, v in c.items() if k.startswith("reason:"))
        lines.append(f"{fam:15s} {c['n']:5d} {c['first'] / c['n']:10.1%} {c['ok'] / c['n']:14.1%}  {fails}")
    if tot["n"]:
        lines.append(f"{'all':15s} {tot['n']:5d} {tot['first'] / tot['n']:10.1%} {tot['ok'] / tot['n']:14.1%}")
    dist = sum(1 for r in results if r.get("success") and r.get("disturbed"))
    lines.append(f"succeeded episodes that disturbed an uninvolved object (> 2 cm or 15 deg): {dist}")
    return "\n".join(lines)


def _bench_scene() -> Any:
    from samplehd.catalogue import ObjectInstance
    from samplehd.scene.spec import SceneObject, SceneSpec

    up = (1.0, 0.0, 0.0, 0.0)
    t = LAYOUT.table_height
    return SceneSpec(index=0, seed=0, objects=(
        SceneObject(ObjectInstance("food_box", "flat", "red", "plastic", "medium"), (0.02, -0.25, t), up),
        SceneObject(ObjectInstance("soda_can", "standard", "red", "metal", "medium"), (0.05, 0.12, t), up),
        SceneObject(ObjectInstance("bowl", "round", "white", "ceramic", "medium"), (0.20, -0.05, t), up),
        SceneObject(ObjectInstance("glass", "short", "transparent", "glass", "medium"), (-0.08, -0.05, t), up),
    ))


def run(repeats: int = 3) -> list[Any]:
    """Episode frames/s: state-only, and with ``fast`` RGB+depth+segmentation at 320×180 and 640×360.

    One place episode (about 250 frames at 20 Hz) of a 4-object scene; frames/s counts planning,
    physics, recording and the checker, plus rendering every frame from the operator camera.
    """
    import statistics
    import time

    from samplehd.bench import Figure
    from samplehd.motion.assist import compile_scene_with_assist
    from samplehd.record.paths import plan_and_execute
    from samplehd.record.replay import render_episode

    scene = _bench_scene()
    task = {"type": "place", "objects": [1], "subject": "left"}
    rates: dict[str, list[float]] = {k: [] for k in ("state", "320x180", "640x360", "cpu state", "cpu 320x180",
                                                         "cpu 640x360")}
    frames = 0
    for r in range(repeats):
        model, data = compile_scene_with_assist(scene)
        t0, c0 = time.perf_counter(), time.process_time()
        ep = plan_and_execute(scene, task, np.random.default_rng(r), compiled=(model, data))
        sim, sim_cpu = time.perf_counter() - t0, time.process_time() - c0
        frames = ep.num_frames
        rates["state"].append(frames / sim)
        rates["cpu state"].append(frames / sim_cpu)
        for w, h in ((320, 180), (640, 360)):
            t1, c1 = time.perf_counter(), time.process_time()
            render_episode(model, ep, ("operator",), ("rgb", "depth", "segmentation"), w, h, "fast")
            rates[f"{w}x{h}"].append(frames / (sim + time.perf_counter() - t1))
            rates[f"cpu {w}x{h}"].append(frames / (sim_cpu + time.process_time() - c1))
    note = f"place episode, {frames} frames, 20 Hz control / 500 Hz physics, operator camera"
    med = {k: statistics.median(v) for k, v in rates.items()}
    cpu_note = note + "; per CPU second (process time), less sensitive to other load"
    return [
        Figure("paths", "episode frames/s state-only", med["state"], "1/s", note),
        Figure("paths", "episode frames/s rgb+depth+seg 320x180 fast", med["320x180"], "1/s", note),
        Figure("paths", "episode frames/s rgb+depth+seg 640x360 fast", med["640x360"], "1/s", note),
        Figure("paths", "episode frames/CPU-s state-only", med["cpu state"], "1/s", cpu_note),
        Figure("paths", "episode frames/CPU-s rgb+depth+seg 320x180 fast", med["cpu 320x180"], "1/s", cpu_note),
        Figure("paths", "episode frames/CPU-s rgb+depth+seg 640x360 fast", med["cpu 640x360"], "1/s", cpu_note),
    ]

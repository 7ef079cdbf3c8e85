"""Ground-truth path figures: episode frames/s, and the oracle success rate on scenes from the real
sampler with instructions from the real generator (its language constraints decide which tasks a
scene affords; nothing here re-implements them). Every draw comes from an explicit seed, so the
oracle statistics are reproducible.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from collections import Counter, defaultdict
from typing import Any

import mujoco
import numpy as np

from samplehd.bench import Figure
from samplehd.catalogue import ObjectInstance
from samplehd.catalogue.loader import CATALOGUES, DEFAULT_CATALOGUE
from samplehd.errors import ConfigError
from samplehd.language.generator import generate_instructions
from samplehd.motion.assist import compile_scene_with_assist
from samplehd.record.paths import PathRejected, plan_and_execute
from samplehd.render.deflated import deflating
from samplehd.render.image_spec import ImageSpec
from samplehd.render.renderer import IMAGE_DTYPES, MODALITIES, stored_segmentation_dtype
from samplehd.render.states import render_states
from samplehd.scene.annotate import annotate_scene
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import sample_scene
from samplehd.scene.spec import SceneObject, SceneSpec
from samplehd.scene.world import OPERATOR_CAMERA
from samplehd.workers import Backend
from samplehd.world.layout import LAYOUT

__all__ = ["add_arguments", "handoff", "oracle_success", "oracle_table", "report", "run"]


def _oracle_scene(args: tuple[int, int, int, str, tuple[str, ...] | None, str]) -> list[dict[str, Any]]:
    """Sample one scene with the real sampler, generate instructions with the real generator
    (families balanced), and run the oracle on each; returns one result dict per instruction."""
    index, seed, per_scene, out, families, catalogue = args
    results = []
    try:
        sampled = sample_scene(index, seed, SceneConfig(catalogue=catalogue))
    except Exception as exc:  # noqa: BLE001 - a scene the sampler cannot make is skipped, counted
        return [{"scene": index, "family": "-", "success": False, "reason": f"scene: {exc}", "skipped": True}]
    scene = sampled.scene
    model, data = compile_scene_with_assist(scene)
    start = mujoco.MjData(model)
    mujoco.mj_copyData(start, model, data)
    ann = annotate_scene(scene, model, data, 640, 360)
    rng = np.random.default_rng(seed)
    gen = generate_instructions(ann, rng, per_scene=per_scene, balance="families", families=families)
    for k, ins in enumerate(gen.instructions):
        mujoco.mj_copyData(data, model, start)
        t0 = time.perf_counter()
        r: dict[str, Any] = {"scene": index, "instruction": k, "family": ins.family, "text": ins.text,
                             "task": ins.task.to_program_dict(),
                             "classes": [scene.objects[i].instance.class_name for i in ins.targets]}
        try:
            ep = plan_and_execute(scene, ins.task.to_program_dict(), np.random.default_rng([seed, k]),
                                  family=ins.family, instruction_index=k, directions=ann["directions"],
                                  compiled=(model, data))
            r.update(success=True, attempts=ep.info["attempts"], frames=ep.num_frames,
                     failed=[a["reason"] for a in ep.info["failed_attempts"]],
                     disturbed=ep.info["check"]["disturbed"], fallen=ep.info["check"]["fallen"])
        except PathRejected as exc:
            r.update(success=False, reason=exc.reason, failed=[a["reason"] for a in exc.attempts],
                     message=str(exc)[:200])
        r["seconds"] = time.perf_counter() - t0
        results.append(r)
        if out:
            with open(out, "a", encoding="utf-8") as f:
                f.write(json.dumps(r) + "\n")
    return results


def oracle_success(num_scenes: int, base_seed: int, per_scene: int = 5, workers: int = 2,
                   out: str = "", families: tuple[str, ...] | None = None,
                   catalogue: str = DEFAULT_CATALOGUE) -> list[dict[str, Any]]:
    """Oracle success over real sampled scenes and generated instructions.

    Args:
        num_scenes: scenes to sample (seeds ``base_seed + i``).
        base_seed: first seed.
        per_scene: instructions per scene.
        workers: worker processes.
        out: JSONL file to append per-instruction results to as they finish ("" for none).
        families: only instructions of these families (None: all, balanced).
        catalogue: built-in catalogue the scenes draw from (``shop-vrb`` or ``procedural``).

    Returns:
        One dict per instruction: family, success, attempts, frames, reason, seconds.
    """
    jobs = [(i, base_seed + i, per_scene, out, families, catalogue) for i in range(num_scenes)]
    results: list[dict[str, Any]] = []
    for _, rs in Backend(workers=workers).map(_oracle_scene, jobs):
        results += rs
    return results


def oracle_table(results: list[dict[str, Any]]) -> str:
    """Per family: attempted, first-try and final success rates, and failure reasons."""
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


def _bench_scene() -> SceneSpec:
    up = (1.0, 0.0, 0.0, 0.0)
    t = LAYOUT.table_height
    return SceneSpec(index=0, seed=0, objects=(
        SceneObject(ObjectInstance("food_box", "flat", "red", "plastic", "medium"), (0.02, -0.25, t), up),
        SceneObject(ObjectInstance("soda_can", "standard", "red", "metal", "medium"), (0.05, 0.12, t), up),
        SceneObject(ObjectInstance("bowl", "round", "white", "ceramic", "medium"), (0.20, -0.05, t), up),
        SceneObject(ObjectInstance("glass", "short", "transparent", "glass", "medium"), (-0.08, -0.05, t), up),
    ))


def run(repeats: int = 3) -> list[Figure]:
    """Episode frames/s: state-only, and with ``fast`` RGB+depth+segmentation at 320×180 and 640×360.

    One place episode (about 250 frames at 20 Hz) of a 4-object scene; frames/s counts planning,
    physics, recording and the checker, plus rendering every frame from the operator camera.
    """


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
            render_states(model, ep.frames, ImageSpec(w, h, "fast", (OPERATOR_CAMERA.name,), MODALITIES))
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


def handoff(rounds: int = 24, width: int = 320, height: int = 180, span: int = 48) -> str:
    """What deflating an episode's images costs the render loop, by how frames reach the deflater.

    The benchmark episode's states are rendered (``fast``, RGB+depth+segmentation, operator camera) by
    :func:`render_states` with nothing done per frame (the reference), with each frame deflated in the loop,
    and deflated on the helper thread beside it (``overlap``) one frame per hand-over and in the default
    groups, as an episode file stores them. Each round renders ``span`` consecutive states (a different
    stretch each round) four times, one per way, in a rotating order; each way's wall and CPU time per frame
    is compared with the reference of its own round (short rounds: the machine's speed drifts less within
    one than between whole episodes).
    """
    scene = _bench_scene()
    model, data = compile_scene_with_assist(scene)
    frames = plan_and_execute(scene, {"type": "place", "objects": [1], "subject": "left"},
                              np.random.default_rng(0), compiled=(model, data)).frames
    seg = stored_segmentation_dtype(model)
    dtypes = {**IMAGE_DTYPES, "segmentation": seg}

    image = ImageSpec(width, height, "fast", (OPERATOR_CAMERA.name,), MODALITIES)
    shapes = {m: image.shape(m) for m in MODALITIES}
    # Each way: whether frames are deflated, and render_states' overlap and overlap_group.
    ways: dict[str, tuple[bool, bool, int | None]] = {
        "renderer only": (False, False, None),
        "deflated in the loop": (True, False, None),
        "beside, 1 frame per hand-over": (True, True, 1),
        "beside, groups (default)": (True, True, None),
    }
    n = len(frames["qpos"])
    span = min(span, n)

    def run_one(name: str, start: int = 0) -> tuple[float, float]:
        deflate, overlap, group = ways[name]
        on_frame = deflating((OPERATOR_CAMERA.name,), shapes, dtypes)[1] if deflate else (lambda c, i: None)
        kw: dict[str, Any] = {"on_frame": on_frame, "overlap": overlap, "overlap_group": group}
        t0, c0 = time.perf_counter(), time.process_time()
        render_states(model, frames, image, segmentation_dtype=seg, indices=range(start, start + span), **kw)
        return 1000 * (time.perf_counter() - t0) / span, 1000 * (time.process_time() - c0) / span

    names = list(ways)
    run_one(names[0])  # warm-up: the first renderer of a process makes the GL context
    got: dict[str, list[tuple[float, float]]] = {n: [] for n in names}
    for k in range(rounds):
        start = (k * span) % (n - span + 1)
        for name in names[k % len(names):] + names[:k % len(names)]:
            got[name].append(run_one(name, start))
    lines = [f"{rounds} rounds of {span} of the episode's {n} states at {width}x{height}; ms per frame (median) "
             "and the reference's rate as a share of each way's, median (range) of the rounds",
             f"{'':32s} {'wall ms':>8s} {'CPU ms':>8s}   {'wall share':>18s}   {'CPU share':>18s}"]
    for name in names:
        cells = []
        for i in (0, 1):
            v = sorted(ref[i] / x[i] for ref, x in zip(got[names[0]], got[name], strict=True))
            cells.append(f"{statistics.median(v):6.1%} ({v[0]:.0%}-{v[-1]:.0%})")
        lines.append(f"{name:32s} {statistics.median(x[0] for x in got[name]):8.2f} "
                     f"{statistics.median(x[1] for x in got[name]):8.2f}   {cells[0]:>18s}   {cells[1]:>18s}")
    return "\n".join(lines)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """``samplehd bench paths speed|oracle|table|handoff``: episode frames/s, the oracle success rate on real
    sampled scenes and generated instructions (``table`` re-reads an oracle run's JSONL), or what deflating
    an episode's images costs the render loop (:func:`handoff`)."""
    parser.add_argument("what", choices=["speed", "oracle", "table", "handoff"])
    parser.add_argument("--repeats", type=int, default=3, help="speed: repeats; handoff: 8 x R rounds of 48 frames")
    parser.add_argument("--width", type=int, default=320, help="handoff: image width [px]")
    parser.add_argument("--height", type=int, default=180, help="handoff: image height [px]")
    parser.add_argument("--scenes", type=int, default=70)
    parser.add_argument("--seed", type=int, default=5000)
    parser.add_argument("--per-scene", type=int, default=5)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--families", nargs="+", default=None, help="oracle: only these families")
    parser.add_argument("--out", default="", help="JSONL of per-instruction results (oracle: written, table: read)")
    parser.add_argument("--catalogue", choices=list(CATALOGUES), default=DEFAULT_CATALOGUE,
                        help="oracle: the built-in catalogue the scenes draw from")


def report(args: argparse.Namespace) -> int:
    """Print the chosen figures."""
    if args.what == "handoff":
        for flag, v, lo, hi in (("--width", args.width, 8, 8192), ("--height", args.height, 8, 8192),
                                ("--repeats", args.repeats, 1, 1000)):
            if not lo <= v <= hi:
                raise ConfigError(f"{flag} {v}: must be {lo}..{hi}")
        print(handoff(8 * args.repeats, args.width, args.height))
        return 0
    if args.what == "speed":
        for f in run(args.repeats):
            print(f"{f.name:48s} {f.value:10.1f} {f.unit}   ({f.note})")
        return 0
    if args.what == "oracle":
        families = tuple(args.families) if args.families else None
        results = oracle_success(args.scenes, args.seed, args.per_scene, args.workers, args.out, families,
                                 args.catalogue)
    else:
        with open(args.out, encoding="utf-8") as f:
            results = [json.loads(line) for line in f]
    print(oracle_table(results))
    frames: dict[str, list[int]] = defaultdict(list)
    for r in results:
        if r.get("success"):
            frames[r["family"]].append(int(r["frames"]))
    print("frames per episode (mean, at 20 Hz):")
    for fam, v in sorted(frames.items()):
        print(f"  {fam:15s} {sum(v) / len(v):7.1f}  (n={len(v)})")
    return 0

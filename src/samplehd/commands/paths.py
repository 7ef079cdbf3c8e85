"""Generate ground-truth motion paths for instructions: plan, execute in physics, check success,
record one frame per control step (optionally with images), write one episode file per succeeded
instruction, and summarise attempts, successes and rejection reasons.

Outputs in OUT: ``episodes/episode_{instruction_index:06d}.npz`` (see
``samplehd.record.recorder.write_episode_npz``), ``summary.json``
``{attempted, succeeded, first_try, by_family: {family: {attempted, succeeded, first_try}},
rejections: {reason: count}, frames, seconds}``, ``results.jsonl`` (one line per instruction) and
``config.json`` (the resolved options).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from samplehd.errors import ConfigError

HELP = "generate ground-truth motion paths (episodes) for instructions"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scenes", required=True, type=Path, help="scenes directory (with scenes.json) or file")
    parser.add_argument("--instructions", required=True, type=Path, help="instructions.json")
    parser.add_argument("--out", required=True, type=Path, help="output directory")
    parser.add_argument("--cameras", default="", help="comma-separated cameras to render per frame (none: states only)")
    parser.add_argument("--modalities", default="rgb", help="comma-separated: rgb, depth, segmentation")
    parser.add_argument("--width", type=int, default=320, help="image width [px]")
    parser.add_argument("--height", type=int, default=180, help="image height [px]")
    parser.add_argument("--preset", default="fast", choices=["fast", "hd"], help="render quality preset")
    parser.add_argument("--workers", type=int, default=1, help="parallel worker processes")
    parser.add_argument("--seed", type=int, default=0, help="base seed (per instruction: seed + instruction_index)")
    parser.add_argument("--limit", type=int, default=0, help="only the first N instructions (0: all)")
    parser.add_argument("--max-attempts", type=int, default=3, help="attempts per instruction before rejecting")


def _split(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def load_scenes(path: Path) -> dict[int, dict[str, Any]]:
    """Scenes of a scenes.json (or a directory holding one), by image_index."""
    import json

    from samplehd.errors import DatasetError

    file = path / "scenes.json" if path.is_dir() else path
    try:
        data = json.loads(file.read_text(encoding="utf-8"))
    except OSError as exc:
        raise DatasetError(f"{file}: cannot read: {exc.strerror}") from None
    except json.JSONDecodeError as exc:
        raise DatasetError(f"{file}: not valid JSON: {exc.msg} at line {exc.lineno}") from None
    scenes = data.get("scenes") if isinstance(data, dict) else None
    if not isinstance(scenes, list):
        raise DatasetError(f"{file}: expected {{info, scenes: [...]}}")
    out = {}
    for k, s in enumerate(scenes):
        if "spec" not in s:
            raise DatasetError(f"{file}: scenes[{k}]: spec: missing (write scenes with `samplehd scenes`)")
        out[int(s.get("image_index", k))] = s
    return out


def _job(args: tuple[dict[str, Any], dict[str, Any], dict[str, Any]]) -> dict[str, Any]:
    """Run one instruction in a worker; returns a small JSON-ready result."""
    import time

    import numpy as np

    import samplehd  # noqa: F401  (GL backend before mujoco)
    from samplehd.errors import SamplehdError
    from samplehd.motion.assist import compile_scene_with_assist
    from samplehd.record.paths import PathConfig, PathRejected, plan_and_execute
    from samplehd.record.recorder import write_episode_npz
    from samplehd.scene.spec import SceneSpec

    scene_d, entry, opts = args
    t0 = time.perf_counter()
    idx = int(entry.get("instruction_index", 0))
    family = str(entry.get("family", entry["task"].get("type", "")))
    seed = int(opts["seed"]) + idx
    res: dict[str, Any] = {"instruction_index": idx, "family": family, "seed": seed}
    try:
        scene = SceneSpec.from_dict(scene_d["spec"])
        model, data = compile_scene_with_assist(scene)
        cfg = PathConfig(max_attempts=int(opts["max_attempts"]))
        ep = plan_and_execute(scene, entry["task"], np.random.default_rng(seed), cfg, family=family,
                              scene_index=int(scene_d.get("image_index", scene.index)), instruction_index=idx,
                              seed=seed, directions=scene_d.get("directions"), compiled=(model, data))
        if opts["cameras"]:
            import dataclasses

            from samplehd.record.replay import render_episode

            images = render_episode(model, ep, opts["cameras"], opts["modalities"], opts["width"], opts["height"],
                                    opts["preset"])
            ep = dataclasses.replace(ep, images=images)
        path = write_episode_npz(Path(opts["out"]) / "episodes" / f"episode_{idx:06d}.npz", ep)
        res.update(success=True, attempts=int(ep.info["attempts"]), frames=ep.num_frames, file=str(path),
                   failed=[a["reason"] for a in ep.info["failed_attempts"]])
    except PathRejected as exc:
        res.update(success=False, reason=exc.reason, message=str(exc), failed=[a["reason"] for a in exc.attempts])
    except SamplehdError as exc:
        res.update(success=False, reason=type(exc).__name__, message=str(exc))
    res["seconds"] = time.perf_counter() - t0
    return res


def summarise(results: list[dict[str, Any]]) -> dict[str, Any]:
    """The summary.json content from per-instruction results."""
    from collections import Counter

    by: dict[str, dict[str, int]] = {}
    rej: Counter[str] = Counter()
    for r in results:
        f = by.setdefault(r["family"], {"attempted": 0, "succeeded": 0, "first_try": 0})
        f["attempted"] += 1
        if r["success"]:
            f["succeeded"] += 1
            f["first_try"] += int(r.get("attempts", 1) == 1)
        else:
            rej[r["reason"]] += 1
    return {
        "attempted": len(results),
        "succeeded": sum(int(r["success"]) for r in results),
        "first_try": sum(f["first_try"] for f in by.values()),
        "by_family": dict(sorted(by.items())),
        "rejections": dict(rej.most_common()),
        "frames": int(sum(r.get("frames", 0) for r in results)),
        "seconds": float(sum(r.get("seconds", 0.0) for r in results)),
    }


def format_summary(summary: dict[str, Any]) -> str:
    """The summary as a plain-text table."""
    lines = [f"{'family':16s} {'attempted':>9s} {'first try':>9s} {'succeeded':>9s} {'rate':>7s}"]
    for fam, f in summary["by_family"].items():
        rate = f["succeeded"] / f["attempted"] if f["attempted"] else 0.0
        lines.append(f"{fam:16s} {f['attempted']:9d} {f['first_try']:9d} {f['succeeded']:9d} {rate:7.1%}")
    a, s = summary["attempted"], summary["succeeded"]
    lines.append(f"{'all':16s} {a:9d} {summary['first_try']:9d} {s:9d} {(s / a if a else 0):7.1%}")
    if summary["rejections"]:
        lines.append("rejections: " + ", ".join(f"{k} {v}" for k, v in summary["rejections"].items()))
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    import json
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    from samplehd.language.instruction_file import read_instructions

    cams, mods = _split(args.cameras), _split(args.modalities)
    bad = [m for m in mods if m not in ("rgb", "depth", "segmentation")]
    if bad:
        raise ConfigError(f"--modalities: unknown {bad}; valid: rgb, depth, segmentation")
    if args.workers < 1 or args.max_attempts < 1 or args.width < 16 or args.height < 16:
        raise ConfigError("--workers and --max-attempts must be >= 1, --width/--height >= 16")
    scenes = load_scenes(args.scenes)
    entries = read_instructions(args.instructions)["instructions"]
    if args.limit:
        entries = entries[: args.limit]
    missing = sorted({int(e["image_index"]) for e in entries} - set(scenes))
    if missing:
        raise ConfigError(f"{args.instructions}: instructions refer to scenes {missing[:5]} not in {args.scenes}")
    args.out.mkdir(parents=True, exist_ok=True)
    opts = {"seed": args.seed, "max_attempts": args.max_attempts, "cameras": cams, "modalities": mods,
            "width": args.width, "height": args.height, "preset": args.preset, "out": str(args.out)}
    (args.out / "config.json").write_text(json.dumps({**opts, "scenes": str(args.scenes),
                                                      "instructions": str(args.instructions),
                                                      "workers": args.workers, "limit": args.limit}, indent=2))
    jobs = [(scenes[int(e["image_index"])], dict(e), opts) for e in entries]
    results: list[dict[str, Any]] = []
    with (args.out / "results.jsonl").open("w", encoding="utf-8") as log:
        def done(r: dict[str, Any]) -> None:
            results.append(r)
            log.write(json.dumps(r) + "\n")
            log.flush()
            status = "ok" if r["success"] else f"rejected ({r['reason']})"
            print(f"[{len(results)}/{len(jobs)}] instruction {r['instruction_index']} {r['family']}: {status} "
                  f"{r['seconds']:.1f} s", flush=True)

        if args.workers == 1:
            for j in jobs:
                done(_job(j))
        else:
            with ProcessPoolExecutor(args.workers, mp_context=mp.get_context("spawn")) as pool:
                for r in pool.map(_job, jobs, chunksize=1):
                    done(r)
    summary = summarise(sorted(results, key=lambda r: r["instruction_index"]))
    (args.out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(format_summary(summary))
    print(f"wrote {args.out / 'summary.json'}")
    return 0

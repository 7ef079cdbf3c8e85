"""Dataset generation figures: end-to-end frames/s (states only, ``fast`` RGB+depth+segmentation at
320×180, ``hd`` at 640×360) for 1 and 2 workers, bytes per 1000 frames per container (HDF5 vs Zarr), and
the projected wall time of the ``sample-hd`` preset here and on a 64-core Ray cluster.

Work sets (real scenes, planner, physics; the ``tiny`` preset's 3-object scenes): states only, 6 scenes
× 3 instruction candidates; with images, 2 scenes × 1 candidate (rendering dominates). ``hd`` is too slow
on a CPU rasteriser to run whole episodes in a benchmark, so its end-to-end figure composes the measured
states-only rate with the measured hd render rate of stored states (frames/s = 1 / (1/states + 1/render))
and the measured 2-worker scaling; the note of each figure says which.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from samplehd.bench import Figure, print_figures
from samplehd.dataset.config import GenerateConfig, preset_config
from samplehd.dataset.container import read_episode, write_episode
from samplehd.dataset.generate import generate_dataset
from samplehd.dataset.journal import read_journal
from samplehd.dataset.reader import DatasetReader
from samplehd.dataset.render import RenderConfig
from samplehd.scene.spec import SceneSpec, compile_scene
from samplehd.workers import Backend

__all__ = ["add_arguments", "bench_config", "container_sizes", "projection", "report", "run"]

_MICRO: dict[str, Any] = {"num_scenes": 2, "seed": 0, "test_every": 2, "scene": {"min_objects": 3, "max_objects": 3},
                          "instructions": {"per_scene": 2}, "render": {"mode": "none"}}


def bench_config(mode: str = "none", width: int = 320, height: int = 180, scenes: int = 6, per_scene: int = 3) -> Any:
    """The benchmark's work set with the given render settings."""
    d = json.loads(json.dumps(_MICRO))
    d["render"] = {"mode": mode, "width": width, "height": height}
    d["num_scenes"] = scenes
    d["instructions"] = {"per_scene": per_scene}
    return GenerateConfig.from_dict(d, base=preset_config("tiny"))


def _generate(config: Any, workers: int, root: Path) -> tuple[float, int, Path]:
    out = Path(tempfile.mkdtemp(dir=root)) / "ds"
    t0 = time.perf_counter()
    s = generate_dataset(out, config, Backend("local", workers))
    return time.perf_counter() - t0, s.frames, out


def _dir_size(path: Path) -> tuple[int, int]:
    files = [p for p in path.rglob("*") if p.is_file()]
    return sum(p.stat().st_size for p in files), len(files)


def container_sizes(dataset: Path) -> list[Figure]:
    """Bytes per 1000 frames and write frames/s of every episode of ``dataset`` in HDF5 (the format)
    and in a Zarr v3 directory store (Blosc zstd, one chunk per frame), when zarr is installed."""

    reader = DatasetReader(dataset)
    eps = [reader.episode(i, images="load") for i in range(len(reader))]
    frames = sum(e.num_frames for e in eps)
    tag = "states" if not eps or not eps[0].images else "states+rgb/depth/seg {w}x{h}".format(
        w=reader.info["render"]["width"], h=reader.info["render"]["height"])
    out: list[Figure] = []
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        size = sum(write_episode(Path(tmp) / f"{k}.h5", e).size for k, e in enumerate(eps))
        dt = time.perf_counter() - t0
        out.append(Figure("dataset", f"hdf5 bytes/1000 frames ({tag})", size / frames * 1000, "B",
                          f"{len(eps)} episodes, {frames} frames, states gzip-4 (+shuffle on floats), "
                          "images ISA-L deflate, 1 file/episode"))
        out.append(Figure("dataset", f"hdf5 write frames/s ({tag})", frames / dt, "1/s", "build + fsync + rename"))
        try:
            import zarr
            from zarr.codecs import BloscCodec
        except ImportError:
            return out
        t0 = time.perf_counter()
        nfiles = 0
        zsize = 0
        for k, e in enumerate(eps):
            root = zarr.open_group(str(Path(tmp) / f"{k}.zarr"), mode="w")
            arrays = {f"frames/{n}": a for n, a in e.frames.items()}
            arrays.update({f"images/{c}/{m}": a for c, mods in e.images.items() for m, a in mods.items()})
            for name, a in arrays.items():
                shuffle = "shuffle" if a.dtype.kind == "f" else "noshuffle"
                chunks = (1, *a.shape[1:]) if name.startswith("images") else a.shape
                z = root.create_array(name, shape=a.shape, dtype=a.dtype, chunks=chunks,
                                      compressors=BloscCodec(cname="zstd", clevel=5, shuffle=shuffle))
                z[...] = a
            s, n = _dir_size(Path(tmp) / f"{k}.zarr")
            zsize += s
            nfiles += n
        dt = time.perf_counter() - t0
        out.append(Figure("dataset", f"zarr bytes/1000 frames ({tag})", zsize / frames * 1000, "B",
                          f"Blosc zstd-5, {nfiles / len(eps):.0f} files/episode"))
        out.append(Figure("dataset", f"zarr write frames/s ({tag})", frames / dt, "1/s", "directory store"))
    return out


def projection(unit_seconds: float, success_rate: float, scene_seconds: float, speedup2: float,
               num_scenes: int = 2000, target: int = 8360) -> dict[str, float]:
    """Projected wall time [s] of the sample-hd preset (states only).

    Args:
        unit_seconds: mean wall seconds of one path work unit (one candidate) on one worker.
        success_rate: fraction of candidates whose path succeeds.
        scene_seconds: mean seconds to sample one scene.
        speedup2: measured 2-worker speedup (≤ 2).
        num_scenes: scenes of the preset.
        target: successful episodes wanted.

    Returns:
        ``{serial, here_2_workers, ray_64_cores, candidates}``; the 64-core figure assumes the 2-worker
        parallel efficiency holds (units are independent; the instruction pass is serial but ~10 ms/scene).
    """
    candidates = target / max(success_rate, 1e-9)
    serial = num_scenes * scene_seconds + candidates * unit_seconds
    eff = speedup2 / 2.0
    return {"candidates": candidates, "serial": serial, "here_2_workers": serial / (2 * eff),
            "ray_64_cores": serial / (64 * eff) + num_scenes * 0.01}


def run(repeats: int = 3) -> list[Figure]:
    """Measure everything in the module docstring (about 6-10 minutes on 2 cores)."""
    figures: list[Figure] = []
    root = Path(tempfile.mkdtemp(prefix="bench_dataset_"))
    try:
        rates: dict[int, float] = {}
        last: dict[int, Path] = {}
        for workers in (1, 2):
            runs = [_generate(bench_config(), workers, root) for _ in range(max(1, min(repeats, 2)))]
            rates[workers] = statistics.median(f / dt for dt, f, _ in runs)
            last[workers] = runs[-1][2]
            note = f"median of {len(runs)} runs: 6 scenes, 18 path candidates, {runs[0][1]} frames"
            figures.append(Figure("dataset", f"end-to-end frames/s states only, {workers} worker(s)", rates[workers],
                                  "1/s", note))
        speedup = rates[2] / rates[1]
        figures.append(Figure("dataset", "2-worker speedup states only", speedup, "ratio",
                              f"same run; load average {os.getloadavg()[0]:.1f} (shared machine)"))
        # fast RGB + depth + segmentation at 320x180, whole episodes, end to end
        fast = {}
        for workers in (1, 2):
            dt, frames, ds = _generate(bench_config("fast", 320, 180, scenes=2, per_scene=1), workers, root)
            fast[workers] = frames / dt
            figures.append(Figure("dataset", f"end-to-end frames/s fast rgb+depth+seg 320x180, {workers} worker(s)",
                                  fast[workers], "1/s", f"1 run, {frames} frames, measured"))
        figures.extend(container_sizes(last[1]))
        figures.extend(container_sizes(ds))
        # hd at 640x360: render rate of stored states on a slice of every episode, composed
        reader = DatasetReader(last[1])
        n, t0 = 0, time.perf_counter()
        for i in range(min(len(reader), 4)):
            ep = read_episode(reader.episode_path(i), images="none")
            model, _ = compile_scene(SceneSpec.from_dict(reader.scene(ep.scene_index)["spec"]))
            picks = list(range(0, ep.num_frames, max(1, ep.num_frames // 8)))[:8]
            RenderConfig("hd", 640, 360).images(model, {k: v[picks] for k, v in ep.frames.items()})
            n += len(picks)
        hd_render = n / (time.perf_counter() - t0)
        figures.append(Figure("dataset", "hd rgb+depth+seg 640x360 render frames/s (from states)", hd_render, "1/s",
                              f"{n} frames incl. model compile + GL context per episode"))
        for workers in (1, 2):
            states = rates[1]
            e2e = 1.0 / (1.0 / states + 1.0 / hd_render) * (1.0 if workers == 1 else speedup)
            figures.append(Figure("dataset", f"end-to-end frames/s hd rgb+depth+seg 640x360, {workers} worker(s)",
                                  e2e, "1/s", "composed: 1/(1/states + 1/hd render) × measured 2-worker speedup"))
        # projection of the sample-hd preset, states only, from this run's per-unit costs
        # CPU seconds per unit do not depend on what else runs on the (shared) machine; wall-clock
        # scaling does, so both projections are given.
        journal = read_journal(last[1])
        unit_cpu = statistics.mean(float(r["cpu_seconds"]) for r in journal)
        ok = sum(r["status"] == "ok" for r in journal) / max(len(journal), 1)
        frames_ok = [int(r["num_frames"]) for r in journal if r["status"] == "ok"]
        info = json.loads((last[1] / "runs.jsonl").read_text().splitlines()[-1])
        scene_cpu = info["scene_cpu_seconds"] / bench_config().num_scenes
        fpe = statistics.mean(frames_ok) if frames_ok else 0.0
        figures.append(Figure("dataset", "CPU seconds per path unit (states only)", unit_cpu, "s",
                              f"{len(journal)} units, {ok:.0%} succeed, {fpe:.0f} frames/episode"))
        figures.append(Figure("dataset", "CPU seconds per scene", scene_cpu, "s", "sampling + settling + occlusion"))
        for label, s2 in (("ideal scaling", 2.0), ("measured scaling", speedup)):
            p = projection(unit_cpu, ok, scene_cpu, s2)
            note = (f"{p['candidates']:.0f} candidates × {unit_cpu:.2f} CPU s + 2000 scenes × {scene_cpu:.2f} CPU s, "
                    f"{label} {s2:.2f}")
            figures.append(Figure("dataset", f"sample-hd states only projected here, 2 workers ({label})",
                                  p["here_2_workers"] / 3600, "h", note))
            figures.append(Figure("dataset", f"sample-hd states only projected on 64-core Ray ({label})",
                                  p["ray_64_cores"] / 3600, "h", note + "; 64 workers at that efficiency"))
    finally:
        shutil.rmtree(root, ignore_errors=True)
    return figures


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """``samplehd bench dataset``: the figures, or ``--project DIR`` from a bigger states-only run."""
    parser.add_argument("--repeats", type=int, default=3, help="repeats per figure (medians)")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    parser.add_argument("--project", type=Path, help="dataset dir of a bigger states-only run to project from")
    parser.add_argument("--speedup", type=float, default=1.9, help="2-worker speedup for --project")


def report(args: argparse.Namespace) -> int:
    """Print the figures (or the projection of ``--project``)."""
    if args.project:
        _print_projection(args.project, args.speedup)
        return 0
    print_figures(run(args.repeats), args.json)
    return 0


def _print_projection(root: Path, speedup: float) -> None:
    journal = read_journal(root)
    runs = [json.loads(line) for line in (root / "runs.jsonl").read_text().splitlines()]
    info = json.loads((root / "info.json").read_text())
    key = "cpu_seconds" if all("cpu_seconds" in r for r in journal) else "seconds"
    unit = statistics.mean(float(r[key]) for r in journal)
    ok = sum(r["status"] == "ok" for r in journal) / len(journal)
    frames = [int(r["num_frames"]) for r in journal if r["status"] == "ok"]
    wall = sum(r["seconds"] for r in runs)
    # scene stage wall time × its workers / scenes = seconds per scene on one worker
    scene_s = sum(r["stage_seconds"]["scenes"] * r.get("workers", 1) for r in runs) / info["counts"]["scenes"]
    p = projection(unit, ok, scene_s, speedup)
    print(f"{root}: {len(journal)} path units, mean {unit:.2f} {key}/unit, success {ok:.1%}, "
          f"{statistics.mean(frames):.0f} frames/episode, wall {wall:.0f} s for {info['counts']['scenes']} scenes")
    print(f"sample-hd preset (2000 scenes, 8360 episodes, states only): {p['candidates']:.0f} candidates, "
          f"serial {p['serial'] / 3600:.2f} h, here with 2 workers {p['here_2_workers'] / 3600:.2f} h, "
          f"64-core Ray {p['ray_64_cores'] / 3600:.2f} h (2-worker speedup {speedup:.2f} assumed to hold)")

"""Dataset generation figures (see samplehd.bench.dataset): end-to-end frames/s states only, fast
320×180 and hd 640×360 for 1 and 2 workers; bytes per 1000 frames for HDF5 vs Zarr; the projected wall
time of the sample-hd preset here and on a 64-core Ray cluster.

Usage:
    .venv/bin/python benchmarks/bench_dataset.py [--repeats 3] [--json out.json]
    .venv/bin/python benchmarks/bench_dataset.py --project DIR   # projection from a bigger run's journal
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

import samplehd  # noqa: F401  (GL backend before mujoco)
from samplehd.bench import dataset


def _project(root: Path, speedup: float) -> None:
    from samplehd.dataset.journal import read_journal

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
    p = dataset.projection(unit, ok, scene_s, speedup)
    print(f"{root}: {len(journal)} path units, mean {unit:.2f} {key}/unit, success {ok:.1%}, "
          f"{statistics.mean(frames):.0f} frames/episode, wall {wall:.0f} s for {info['counts']['scenes']} scenes")
    print(f"sample-hd preset (2000 scenes, 8360 episodes, states only): {p['candidates']:.0f} candidates, "
          f"serial {p['serial'] / 3600:.2f} h, here with 2 workers {p['here_2_workers'] / 3600:.2f} h, "
          f"64-core Ray {p['ray_64_cores'] / 3600:.2f} h (2-worker speedup {speedup:.2f} assumed to hold)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", type=Path, help="write the figures here")
    parser.add_argument("--project", type=Path, help="dataset dir of a bigger states-only run to project from")
    parser.add_argument("--speedup", type=float, default=1.9, help="2-worker speedup for --project")
    args = parser.parse_args()
    if args.project:
        _project(args.project, args.speedup)
        return
    figures = dataset.run(args.repeats)
    for f in figures:
        print(f"{f.name:64s} {f.value:12.3f} {f.unit:5s} ({f.note})")
    if args.json:
        args.json.write_text(json.dumps([f.to_dict() for f in figures], indent=1))


if __name__ == "__main__":
    main()

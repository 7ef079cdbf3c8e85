"""Ground-truth path figures: episode frames/s (state-only and with rendering) and the oracle success
rate on real sampled scenes and generated instructions.

Usage:
    .venv/bin/python benchmarks/bench_paths.py speed [--repeats 3]
    .venv/bin/python benchmarks/bench_paths.py oracle --scenes 70 --seed 5000 --per-scene 5 --workers 2 \
        [--out results.jsonl]
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict

import samplehd  # noqa: F401  (GL backend before mujoco)
from samplehd.bench import paths


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("what", choices=["speed", "oracle", "table"])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--scenes", type=int, default=70)
    parser.add_argument("--seed", type=int, default=5000)
    parser.add_argument("--per-scene", type=int, default=5)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--families", nargs="+", default=None, help="oracle: only these families")
    parser.add_argument("--out", default="", help="JSONL of per-instruction results (oracle: written, table: read)")
    args = parser.parse_args()
    if args.what == "speed":
        for f in paths.run(args.repeats):
            print(f"{f.name:48s} {f.value:10.1f} {f.unit}   ({f.note})")
        return
    if args.what == "oracle":
        families = tuple(args.families) if args.families else None
        results = paths.oracle_success(args.scenes, args.seed, args.per_scene, args.workers, args.out, families)
    else:
        with open(args.out, encoding="utf-8") as f:
            results = [json.loads(line) for line in f]
    print(paths.oracle_table(results))
    frames: dict[str, list[int]] = defaultdict(list)
    for r in results:
        if r.get("success"):
            frames[r["family"]].append(int(r["frames"]))
    print("frames per episode (mean, at 20 Hz):")
    for fam, v in sorted(frames.items()):
        print(f"  {fam:15s} {sum(v) / len(v):7.1f}  (n={len(v)})")


if __name__ == "__main__":
    main()

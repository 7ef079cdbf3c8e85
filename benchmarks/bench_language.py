"""Benchmark instruction generation: instructions/s vs object count and attribute kinds, and the
time to produce a SAMPLE-HD-sized instruction set. Prints medians; pins itself to one core.

Usage: .venv/bin/python benchmarks/bench_language.py [--repeats 5] [--scenes 2000] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import sys


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--scenes", type=int, default=2000, help="scenes for the dataset figure")
    parser.add_argument("--per-count-scenes", type=int, default=40, help="scenes per object count")
    parser.add_argument("--json", help="also write the figures here")
    args = parser.parse_args(argv)
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})

    from samplehd.bench.language import bench_attribute_kinds, bench_dataset, bench_object_counts

    counts = bench_object_counts(scenes=args.per_count_scenes, repeats=args.repeats)
    print("CPU time of this single-threaded process; the last column is the wall-clock rate")
    print("objects  instructions/s  ms/scene (generate)  ms/scene (describe all)  instructions/wall-s")
    for r in counts["rows"]:
        print(
            f"{r['objects']:>7}  {r['instructions_per_s']:>14.0f}  {r['ms_per_scene']:>19.2f}  "
            f"{r['describe_ms_per_scene']:>23.3f}  {r['instructions_per_wall_s']:>19.0f}"
        )
    print(f"log-log slope: generate {counts['slope_ms_per_scene']:.2f}, describe {counts['slope_describe']:.2f}")
    kinds = bench_attribute_kinds(repeats=args.repeats)
    print("\nmodifier kinds (10 objects)  ms/scene (describe all)  relational descriptions")
    for r in kinds["rows"]:
        print(f"{r['kinds']:>27}  {r['describe_ms_per_scene']:>23.3f}  {r['relational_fraction']:>23.2f}")
    data = bench_dataset(n_scenes=args.scenes, repeats=args.repeats)
    print(
        f"\n{data['instructions']} instructions for {data['scenes']} scenes of 3-5 objects in "
        f"{data['seconds']:.2f} s CPU, {data['wall_seconds']:.2f} s wall (median of {args.repeats}; "
        f"{data['instructions_per_s']:.0f}/s CPU; "
        f"≥8360: {data['reaches_8360']})"
    )
    print("per family:", data["families"])
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump({"object_counts": counts, "attribute_kinds": kinds, "dataset": data}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())

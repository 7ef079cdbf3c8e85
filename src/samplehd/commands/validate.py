"""Verify a dataset against its metadata: every file present, sizes and SHA-256 as recorded, episode
files readable with the right fields, shapes and images. Exit 1 and list the problems otherwise."""

from __future__ import annotations

import argparse
from pathlib import Path

from samplehd.commands._options import check_int
from samplehd.dataset.validate import validate_dataset

HELP = "verify every file of a dataset against its metadata (exit 1 on problems)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("dir", type=Path, help="dataset directory")
    parser.add_argument("--deep", action="store_true", help="also decode every image chunk")
    parser.add_argument("--max-problems", type=int, default=50, help="problems to print (all are counted)")


def run(args: argparse.Namespace) -> int:
    check_int("--max-problems", args.max_problems, 0)
    problems, counts = validate_dataset(args.dir, deep=args.deep)
    if problems:
        for line in problems[: args.max_problems]:
            print(line)
        more = len(problems) - args.max_problems
        if more > 0:
            print(f"... and {more} more")
        print(f"samplehd validate: {len(problems)} problem(s) in {args.dir}")
        return 1
    print(f"samplehd validate: OK: {counts['scenes']} scenes, {counts['episodes']} episodes, "
          f"{counts['frames']} frames in {args.dir}")
    return 0

"""Verify a dataset against its metadata: every file present, sizes and SHA-256 as recorded, episode
files readable with the right fields, shapes and images. Exit 1 and list the problems otherwise.

With ``--replay`` also send every episode's recorded actions open loop to the environment from its
stored first state (:mod:`samplehd.envs.replay_check`) and report per family how many replay to the
recorded outcome and the largest TCP and object deviation; exit 1 when any outcome differs."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from samplehd.commands._options import check_int, check_out_file
from samplehd.dataset.outputs import check_outputs
from samplehd.dataset.validate import validate_dataset
from samplehd.envs.replay_check import EpisodeReplay, ReplayReport, replay_dataset
from samplehd.errors import ConfigError
from samplehd.fileio import write_json_atomic
from samplehd.workers import Backend

HELP = "verify every file of a dataset against its metadata (exit 1 on problems); --replay: in the env"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("dir", type=Path, help="dataset directory")
    parser.add_argument("--deep", action="store_true", help="also decode every image chunk")
    parser.add_argument("--max-problems", type=int, default=50, help="problems to print (all are counted)")
    parser.add_argument("--replay", action="store_true",
                        help="also replay the recorded actions in the environment (exit 1 when an outcome differs)")
    parser.add_argument("--episodes", type=int, metavar="N", help="with --replay: only the first N episodes")
    parser.add_argument("--out", type=Path, metavar="REPORT.json",
                        help="with --replay: also write the per-episode report (JSON)")
    parser.add_argument("--workers", type=int, metavar="N",
                        help="with --replay: worker processes that replay episodes (default 1)")


def run(args: argparse.Namespace) -> int:
    check_int("--max-problems", args.max_problems, 0)
    check_int("--episodes", args.episodes, 1)
    if args.episodes is not None and not args.replay:
        raise ConfigError("--episodes: only with --replay")
    if args.out is not None and not args.replay:
        raise ConfigError(f"--out {args.out}: the per-episode report of --replay; only with --replay")
    check_int("--workers", args.workers, 1)
    if args.workers is not None and not args.replay:
        raise ConfigError(f"--workers {args.workers}: the worker processes of --replay; only with --replay")
    check_out_file("--out", args.out, (".json",))
    check_outputs({"--out": args.out}, {"DIR": args.dir})
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
    if not args.replay:
        return 0
    report = replay_dataset(args.dir, args.episodes, on_episode=_show_replayed,
                            backend=Backend("local", args.workers or 1))
    print_replay(report)
    if args.out is not None:
        write_json_atomic(args.out, report.to_dict(), indent=1)
        print(f"wrote {args.out}")
    return 0 if report.agrees else 1


def _show_replayed(done: int, total: int, e: EpisodeReplay) -> None:
    """Progress of --replay on stderr, one line per episode."""
    print(f"replayed {done}/{total}: episode {e.index} ({e.family}) "
          f"{'agrees' if e.agrees else 'differs from the recording'}", file=sys.stderr, flush=True)


def print_replay(report: ReplayReport) -> None:
    """Per family: replayed successes, agreement with the recording, largest deviations."""
    print(f"{'family':<16}{'episodes':>9}{'recorded':>10}{'replayed':>10}{'agree':>8}{'max TCP dev':>13}"
          f"{'max object dev':>16}")
    for f in report.families():
        print(f"{f.family:<16}{f.episodes:>9}{f.recorded_successes:>10}{f.replayed_successes:>10}"
              f"{f.agreeing / f.episodes:>8.0%}{f.tcp_deviation * 1000:>10.1f} mm{f.object_deviation * 1000:>13.1f} mm")
    differ = [e for e in report.episodes if not e.agrees]
    for e in differ:
        print(f"episode {e.index} ({e.family}): recorded {'success' if e.recorded_success else 'failure'}, "
              f"replayed {'success' if e.replayed_success else 'failure'}")
    n = len(report.episodes)
    verdict = "OK" if not differ else f"{len(differ)} of {n} outcome(s) differ"
    print(f"samplehd validate --replay: {verdict}: {n - len(differ)} of {n} episodes replay to the recorded outcome")

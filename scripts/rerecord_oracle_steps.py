"""Re-record a suite's ``oracle_steps`` from an oracle evaluation of it, the episodes otherwise unchanged.

A suite's episodes are drawn by the builder of its day; rebuilding a shipped suite with a later builder
may draw other episodes. When only the oracle changed (it solves the same episodes in other step
counts), this keeps the episodes, takes each one's steps from ``samplehd evaluate --policy oracle
--suite SUITE`` and writes the suite with its new content hash (build and manifest as they were). It
refuses a report of another suite or policy, a partial one, or one with a failed episode.

Usage::

    samplehd evaluate --policy oracle --suite smoke --out smoke_oracle.json
    python scripts/rerecord_oracle_steps.py smoke smoke_oracle.json --out src/samplehd/envs/suites/smoke.json
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

from samplehd.envs.suite_file import content_hash, read_suite
from samplehd.errors import ConfigError, SamplehdError
from samplehd.fileio import read_json


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("suite", help="a shipped suite's name or a suite file")
    parser.add_argument("report", type=Path, help="the JSON report of `samplehd evaluate --policy oracle --suite`")
    parser.add_argument("--out", type=Path, required=True, help="the suite file to write")
    args = parser.parse_args(argv)
    try:
        suite = read_suite(args.suite)
        report = read_json(args.report, ConfigError, str(args.report))
    except SamplehdError as exc:  # an unknown or damaged suite, an unreadable report: one line
        print(exc, file=sys.stderr)
        return 2
    split = report.get("split") or {}
    problems = [f"policy {report.get('policy')!r}, not 'oracle'"] if report.get("policy") != "oracle" else []
    if split.get("content_hash") != suite.content_hash:
        problems.append(f"it evaluated {split.get('content_hash')}, not {suite.name} ({suite.content_hash})")
    records = {r["index"]: r for r in report.get("records", [])}
    if report.get("partial") or sorted(records) != list(range(len(suite.episodes))):
        problems.append(f"it holds {len(records)} of the suite's {len(suite.episodes)} episodes")
    failed = sorted(i for i, r in records.items() if not r["success"])
    if failed:
        problems.append(f"the oracle failed episodes {failed}")
    if problems:
        print(f"{args.report}: " + "; ".join(problems), file=sys.stderr)
        return 1
    episodes = tuple(dataclasses.replace(e, oracle_steps=int(records[i]["steps"]))
                     for i, e in enumerate(suite.episodes))
    changed = sum(e.oracle_steps != old.oracle_steps for e, old in zip(episodes, suite.episodes, strict=True))
    new = dataclasses.replace(suite, episodes=episodes, content_hash=content_hash([e.to_dict() for e in episodes]))
    new.write(args.out)
    print(f"wrote {args.out}: {suite.name}, {changed} of {len(episodes)} episodes' oracle_steps changed, "
          f"{suite.content_hash} -> {new.content_hash}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

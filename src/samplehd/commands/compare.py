"""Compare two evaluation reports of one split episode by episode: per group both success rates with
their 95 % Wilson intervals, the paired difference B − A with its interval, the exact McNemar p-value,
and which differences are significant at 0.05."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from samplehd.benchmark.compare import compare_reports, comparison_markdown
from samplehd.commands._options import check_out_file
from samplehd.dataset.outputs import check_outputs
from samplehd.errors import ConfigError
from samplehd.fileio import read_json

HELP = "compare two evaluate reports of one split: paired differences, intervals, McNemar p-values"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("a", type=Path, metavar="A.json", help="the baseline's report (samplehd evaluate --out)")
    parser.add_argument("b", type=Path, metavar="B.json", help="the other report, of the same split or suite")
    parser.add_argument("--out", type=Path, help="also write the comparison here (.md: the table; .json: the "
                                                 "figures)")


def run(args: argparse.Namespace) -> int:
    check_out_file("--out", args.out, (".md", ".json"))
    check_outputs({"--out": args.out}, {"A.json": args.a, "B.json": args.b})
    a = read_json(args.a, ConfigError, str(args.a))
    b = read_json(args.b, ConfigError, str(args.b))
    rows = compare_reports(a, b, str(args.a), str(args.b))
    name_a, name_b = f"{a.get('policy', '?')} ({args.a.name})", f"{b.get('policy', '?')} ({args.b.name})"
    text = comparison_markdown(rows, name_a, name_b)
    print(text, end="")
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        if args.out.suffix.lower() == ".json":
            args.out.write_text(json.dumps({"a": str(args.a), "b": str(args.b), "policy_a": a.get("policy"),
                                            "policy_b": b.get("policy"), "groups": [g.to_dict() for g in rows]},
                                           indent=1) + "\n", encoding="utf-8")
        else:
            args.out.write_text(f"# {name_b} against {name_a}\n\n{text}", encoding="utf-8")
        print(f"wrote {args.out}")
    return 0

"""Build token-to-index vocabularies (instruction words, flat and node program tokens, families)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from samplehd.commands._options import check_out_file
from samplehd.dataset.outputs import check_outputs
from samplehd.errors import ConfigError, DatasetError
from samplehd.language.instruction_file import read_instructions
from samplehd.language.vocab import build_vocab

HELP = "write vocab.json (token -> index maps) for an instructions.json"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--instructions", required=True, type=Path, help="instructions.json to read")
    parser.add_argument("--out", required=True, type=Path, help="vocab.json to write")
    parser.add_argument("--min-count", type=int, default=1, help="drop words seen fewer times (become <UNK>)")


def run(args: argparse.Namespace) -> int:
    if args.min_count < 1:
        raise ConfigError(f"--min-count {args.min_count}: must be at least 1")
    check_out_file("--out", args.out, (".json",))
    check_outputs({"--out": args.out}, {"--instructions": args.instructions})
    entries = read_instructions(args.instructions)["instructions"]
    vocab = build_vocab(entries, min_count=args.min_count)
    try:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(vocab, indent=1) + "\n", encoding="utf-8")
    except OSError as exc:
        raise DatasetError(f"{args.out}: cannot write: {exc.strerror}") from None
    sizes = ", ".join(f"{k} {len(v)}" for k, v in vocab.items())
    print(f"wrote {args.out} ({sizes})")
    return 0

"""Vocabularies: token -> index maps for instruction words and program tokens (CLEVR's vocab.json).

Layout of ``vocab.json``::

    {"instruction_token_to_idx": {"<NULL>": 0, "<START>": 1, "<END>": 2, "<UNK>": 3, ",": 4, ...},
     "program_token_to_idx":      {... flat tokens "place[left]", "filter_colour[red]", ...},
     "program_node_token_to_idx": {... CLEVR node tokens "filter_color[red]", "unique", ...},
     "family_to_idx":             {"place": 0, ...}}

Tokens after the four special ones are sorted, so the same instructions give the same indices.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

__all__ = [
    "SPECIAL_TOKENS",
    "build_token_to_idx",
    "build_vocab",
    "decode",
    "encode",
    "program_node_tokens",
    "tokenize",
]

SPECIAL_TOKENS: dict[str, int] = {"<NULL>": 0, "<START>": 1, "<END>": 2, "<UNK>": 3}
_PUNCTUATION = re.compile(r"([,.;:?!])")


def tokenize(text: str) -> list[str]:
    """Split an instruction into lower-case words; punctuation becomes its own token."""
    return _PUNCTUATION.sub(r" \1 ", text.lower()).split()


def program_node_tokens(program: Sequence[Mapping[str, Any]]) -> list[str]:
    """CLEVR-style tokens of a node list: ``function`` or ``function[value,...]`` per node."""
    out = []
    for nd in program:
        values = nd.get("value_inputs", [])
        out.append(f"{nd['type']}[{','.join(values)}]" if values else str(nd["type"]))
    return out


def build_token_to_idx(sequences: Iterable[Sequence[str]], min_count: int = 1) -> dict[str, int]:
    """Map tokens seen at least ``min_count`` times to indices after the special tokens."""
    counts: dict[str, int] = {}
    for seq in sequences:
        for token in seq:
            counts[token] = counts.get(token, 0) + 1
    out = dict(SPECIAL_TOKENS)
    for token in sorted(t for t, c in counts.items() if c >= min_count and t not in SPECIAL_TOKENS):
        out[token] = len(out)
    return out


def build_vocab(entries: Sequence[Mapping[str, Any]], min_count: int = 1) -> dict[str, dict[str, int]]:
    """Build all vocabularies from instruction-file entries."""

    def flat(e: Mapping[str, Any]) -> list[str]:
        seq = e["program_sequence"]
        return seq.split() if isinstance(seq, str) else list(seq)

    return {
        "instruction_token_to_idx": build_token_to_idx((tokenize(e["instruction"]) for e in entries), min_count),
        "program_token_to_idx": build_token_to_idx((flat(e) for e in entries), min_count),
        "program_node_token_to_idx": build_token_to_idx((program_node_tokens(e["program"]) for e in entries), 1),
        "family_to_idx": {f: i for i, f in enumerate(sorted({str(e["family"]) for e in entries}))},
    }


def encode(
    tokens: Sequence[str], token_to_idx: Mapping[str, int], add_start_end: bool = True, allow_unk: bool = True
) -> list[int]:
    """Turn tokens into indices (unknown tokens become ``<UNK>`` unless ``allow_unk`` is False)."""
    out = [SPECIAL_TOKENS["<START>"]] if add_start_end else []
    for token in tokens:
        if token in token_to_idx:
            out.append(token_to_idx[token])
        elif allow_unk:
            out.append(SPECIAL_TOKENS["<UNK>"])
        else:
            raise KeyError(f"token {token!r} is not in the vocabulary")
    if add_start_end:
        out.append(SPECIAL_TOKENS["<END>"])
    return out


def decode(indices: Sequence[int], token_to_idx: Mapping[str, int], strip_special: bool = True) -> list[str]:
    """Turn indices back into tokens (dropping special tokens unless ``strip_special`` is False)."""
    idx_to_token = {i: t for t, i in token_to_idx.items()}
    tokens = [idx_to_token.get(i, "<UNK>") for i in indices]
    if strip_special:
        tokens = [t for t in tokens if t not in ("<NULL>", "<START>", "<END>")]
    return tokens

"""Instructions and programs as the parser's token sequences: the encoder reads the instruction's ids
(:func:`encode_source`); the decoder writes the SAMPLE-HD flat program, ``<SEP>``, then the CLEVR node
list, each node as its token (``filter_color[red]``) followed by one ``@k`` token per input node
(:func:`encode_target`, :func:`decode_target`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from samplehd.envs.tokens import SPECIAL_TOKENS, instruction_vocabulary, tokenize
from samplehd.language.vocab import program_node_tokens

__all__ = ["MAX_SOURCE", "MAX_TARGET", "SEP", "ParsedProgram", "decode_target", "encode_source", "encode_target",
           "pad_batch"]

SEP = "<SEP>"
MAX_SOURCE = 48
MAX_TARGET = 96


def encode_target(flat: str | Sequence[str], nodes: Sequence[Mapping[str, Any]]) -> list[str]:
    """The decoder's target tokens for one program in both formats."""
    out = list(flat.split() if isinstance(flat, str) else flat) + [SEP]
    for token, node in zip(program_node_tokens(nodes), nodes, strict=True):
        out.append(token)
        out += [f"@{k}" for k in node.get("inputs", [])]
    return out


@dataclass(frozen=True)
class ParsedProgram:
    """A decoded program: flat tokens and CLEVR nodes (None where the node part does not parse)."""

    flat: tuple[str, ...]
    nodes: tuple[dict[str, Any], ...] | None


def decode_target(tokens: Sequence[str]) -> ParsedProgram:
    """Inverse of :func:`encode_target`."""
    tokens = list(tokens)
    if SEP not in tokens:
        return ParsedProgram(tuple(tokens), None)
    cut = tokens.index(SEP)
    flat, rest = tokens[:cut], tokens[cut + 1:]
    nodes: list[dict[str, Any]] = []
    for t in rest:
        if t.startswith("@"):
            if not nodes or not t[1:].isdigit():
                return ParsedProgram(tuple(flat), None)
            nodes[-1]["inputs"].append(int(t[1:]))
        else:
            name, _, value = t.partition("[")
            values = value[:-1].split(",") if value.endswith("]") else []
            nodes.append({"type": name, "inputs": [], "value_inputs": values})
    return ParsedProgram(tuple(flat), tuple(nodes))


def encode_source(text: str) -> list[int]:
    """The encoder's input: the instruction's token ids between ``<START>`` and ``<END>`` (at most
    :data:`MAX_SOURCE`)."""
    vocab = instruction_vocabulary()
    unk = SPECIAL_TOKENS["<UNK>"]
    ids = [SPECIAL_TOKENS["<START>"], *(vocab.get(w, unk) for w in tokenize(text)), SPECIAL_TOKENS["<END>"]]
    return ids[:MAX_SOURCE]


def pad_batch(seqs: Sequence[Sequence[int]]) -> np.ndarray:
    """Token-id sequences as one zero-padded (batch, longest) int64 array."""
    n = max(len(s) for s in seqs)
    out = np.zeros((len(seqs), n), dtype=np.int64)
    for i, s in enumerate(seqs):
        out[i, : len(s)] = s
    return out

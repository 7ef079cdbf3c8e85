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

from samplehd.language.lexicon import default_lexicon
from samplehd.language.templates import default_synonyms, default_templates
from samplehd.world.layout import TABLE_PARTS
from samplehd.world.relations import RELATIONS

__all__ = [
    "SPECIAL_TOKENS",
    "instruction_words",
    "build_token_to_idx",
    "build_vocab",
    "decode",
    "encode",
    "program_node_tokens",
    "tokenize",
]

SPECIAL_TOKENS: dict[str, int] = {"<NULL>": 0, "<START>": 1, "<END>": 2, "<UNK>": 3}
_PUNCTUATION = re.compile(r"([,.;:?!])")
_MARKUP = re.compile(r"<[^<>]*>|[{}\[\]]")


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


def instruction_words(templates: Sequence[Any] | None = None, lexicon: Any | None = None) -> list[str]:
    """Every word the templates and lexicon can produce, sorted (a fixed vocabulary).

    Attribute values come from the scenes (colours, materials and sizes of the catalogue, imported
    class names), so they are not included unless the lexicon lists them: add them from the
    catalogue.

    Args:
        templates: templates (default: the shipped ones).
        lexicon: lexicon (default: the shipped one).
    """

    lex = lexicon or default_lexicon()
    phrases: list[str] = list(",.;:?!") + list(TABLE_PARTS) + list(RELATIONS)
    for t in templates if templates is not None else default_templates():
        phrases += [_MARKUP.sub(" ", text) for text in t.text]
        phrases += [w for group in t.synonyms.values() for w in group]
    phrases += [w for group in default_synonyms().values() for w in group]
    phrases += [w for pair in (*lex.nouns.values(), lex.generic_noun) for w in pair]
    phrases += [w for words in lex.adjectives.values() for w in words.values()]
    phrases += [*lex.table_part_phrase.values(), *lex.relation_phrase.values()]
    phrases += [*lex.relation_destination_phrase.values(), *lex.set_determiners, lex.relative_pronoun]
    phrases += [w for forms in lex.agreement.values() for w in forms.values()]
    return sorted({w for phrase in phrases for w in tokenize(phrase)})

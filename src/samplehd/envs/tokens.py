"""A fixed instruction vocabulary, so token ids mean the same in every environment and episode.

The vocabulary is every word the shipped templates, synonym groups and lexicon can produce, plus the
catalogue's class, colour, material and size names, sorted after CLEVR's four special tokens. Words
outside it (user templates) become ``<UNK>``. Tokenisation is CLEVR's: lower case, punctuation split
off as its own token.
"""

from __future__ import annotations

import re
from functools import cache

import numpy as np

from samplehd.catalogue import load_catalogue
from samplehd.language.lexicon import default_lexicon
from samplehd.language.templates import default_synonyms, default_templates

__all__ = ["SPECIAL_TOKENS", "encode_instruction", "instruction_vocabulary", "tokenize"]

SPECIAL_TOKENS: dict[str, int] = {"<NULL>": 0, "<START>": 1, "<END>": 2, "<UNK>": 3}
_PUNCTUATION = re.compile(r"([,.;:?!])")
_MARKUP = re.compile(r"<[^<>]*>|[{}\[\]]")


def tokenize(text: str) -> list[str]:
    """Split an instruction into lower-case words; punctuation becomes its own token."""
    return _PUNCTUATION.sub(r" \1 ", text.lower()).split()


def _phrases() -> list[str]:
    out: list[str] = list(",.;:?!")
    for t in default_templates():
        out += [_MARKUP.sub(" ", text) for text in t.text]
        for group in t.synonyms.values():
            out += list(group)
    for group in default_synonyms().values():
        out += list(group)
    lex = default_lexicon()
    for pair in (*lex.nouns.values(), lex.generic_noun):
        out += list(pair)
    for words in lex.adjectives.values():
        out += list(words.values())
    out += list(lex.table_part_phrase.values()) + list(lex.relation_phrase.values())
    out += list(lex.relation_destination_phrase.values()) + list(lex.set_determiners)
    cat = load_catalogue()
    for name in cat.classes:
        out.append(name.replace("_", " "))
        cls = cat.object_class(name)
        for v in cls.variants:
            menu = cls.variant(v).menu
            for colour, material in menu.pairs:
                out += [colour, material]
            out += list(menu.size)
    return out


@cache
def instruction_vocabulary() -> dict[str, int]:
    """Token → id of the fixed vocabulary (special tokens first, then sorted words)."""
    words = sorted({w for phrase in _phrases() for w in tokenize(phrase)} - set(SPECIAL_TOKENS))
    vocab = dict(SPECIAL_TOKENS)
    for w in words:
        vocab[w] = len(vocab)
    return vocab


def encode_instruction(text: str, length: int) -> np.ndarray:
    """Token ids ``<START> words <END>`` padded with ``<NULL>`` (0) or cut to ``length``."""
    vocab = instruction_vocabulary()
    unk = SPECIAL_TOKENS["<UNK>"]
    ids = [SPECIAL_TOKENS["<START>"], *(vocab.get(w, unk) for w in tokenize(text)), SPECIAL_TOKENS["<END>"]]
    out = np.zeros(length, dtype=np.int64)
    ids = ids[:length]
    out[: len(ids)] = ids
    return out

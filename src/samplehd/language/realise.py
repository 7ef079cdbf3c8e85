"""Turning a template text variant and bound parameters into an English sentence."""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence

import numpy as np

__all__ = ["realise_text"]

_OPTIONAL = re.compile(r"\[([^\[\]]*)\]")
_SYNONYM = re.compile(r"\{([A-Za-z0-9_]+)\}")
_PLACEHOLDER = re.compile(r"<([A-Za-z0-9_]+)(?::([a-z]+))?>")
_SPACE_BEFORE_PUNCTUATION = re.compile(r" ([,.;:?!])")


def realise_text(
    text: str,
    phrase: Callable[[str, str | None], str],
    synonyms: Mapping[str, Sequence[str]],
    rng: np.random.Generator,
) -> str:
    """Render one text variant.

    Optional ``[phrases]`` are kept with probability 1/2, each ``{group}`` becomes a synonym drawn
    uniformly, and each ``<NAME>`` / ``<NAME:modifier>`` becomes ``phrase(NAME, modifier)``. The
    result starts with a capital letter and ends with punctuation.

    Args:
        text: the text variant.
        phrase: returns the words for a placeholder.
        synonyms: synonym groups.
        rng: random generator for optional phrases and synonyms.
    """
    # (a variant without brackets or braces skips their pass: no match draws nothing)
    if "[" in text:
        text = _OPTIONAL.sub(lambda m: m.group(1) if rng.random() < 0.5 else "", text)
    if "{" in text:
        text = _SYNONYM.sub(lambda m: str(synonyms[m.group(1)][rng.integers(len(synonyms[m.group(1)]))]), text)
    text = _PLACEHOLDER.sub(lambda m: phrase(m.group(1), m.group(2)), text)
    # whitespace runs become one space (str.split splits on exactly the characters \s matches), then no
    # space before punctuation
    text = " ".join(text.split())
    if " " in text:
        text = _SPACE_BEFORE_PUNCTUATION.sub(r"\1", text)
    if text and text[-1] not in ".?!":
        text += "."
    return text[:1].upper() + text[1:]

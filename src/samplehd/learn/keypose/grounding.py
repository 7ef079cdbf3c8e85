"""Keeping the keypose policy's grasp on the objects the instruction names (generalisation levels L1–L3).

The network decides where to grasp from the view and the instruction together; when it is unsure it
may grasp an object the instruction never mentions (a bowl for "lift the pan"). Its auxiliary maps say
per cell what class and colour the object there is, so the policy can check its own choice: the
instruction's descriptions (:func:`described_objects`: each class noun it says with the colour words
right before it) are compared with each object on the table (:func:`~samplehd.learn.keypose.exclusion.
table_objects`), and the grasp is not sought on an object that fits none of them (:func:`unnamed_cells`).
An object fits a description when the class map gives the description's class at least
:data:`CLASS_FIT` on its cells and its most likely colour is the one named (when one is). The check
leaves the grasp alone where the instruction names no class ("clear the left side of the table"), where
an unheard noun names the object (grounding by exclusion, L4) and where no object fits any description
(the maps then know less than the network's choice). Cells no object covers stay open: a thin object
the height map hardly raises is never kept from the grasp.

This module works on plain arrays (no PyTorch).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from samplehd.envs.tokens import tokenize
from samplehd.language.lexicon import default_lexicon
from samplehd.learn.keypose.configuration import KeyposeVocabulary
from samplehd.learn.keypose.exclusion import SeenObject

__all__ = ["CLASS_FIT", "Description", "described_objects", "fits", "unnamed_cells"]

# An object fits a class the instruction names when the class map gives that class at least this
# probability on its cells (mean): two touching objects make one group of cells, whose classes share it.
CLASS_FIT = 0.25


@dataclass(frozen=True)
class Description:
    """One object as the instruction describes it: its class and the colour said right before the noun
    ("" when none)."""

    name: str
    color: str = ""
    words: tuple[str, ...] = field(default=(), compare=False)


def _nouns(vocabulary: KeyposeVocabulary) -> list[tuple[tuple[str, ...], str]]:
    """(the noun's words, its class) of every known class, singular and plural, longest first ("wine
    glass" before "glass")."""
    nouns = default_lexicon().nouns
    out = [(tuple(tokenize(n)), c) for c in vocabulary.name
           for n in nouns.get(c, (c.replace("_", " "), c.replace("_", " ") + "s"))]
    return sorted(set(out), key=lambda p: (-len(p[0]), p))


def described_objects(instruction: str, vocabulary: KeyposeVocabulary) -> list[Description]:
    """The objects the instruction describes by a known class noun, each with the colour word right
    before it (among the adjectives before the noun). A class noun followed at once by another is an
    adjective ("a glass bowl": material glass, class bowl)."""
    tokens = tokenize(instruction)
    nouns = _nouns(vocabulary)
    colors = {v.replace("_", " "): v for v in vocabulary.color}

    def noun_at(i: int) -> tuple[int, str] | None:
        for words, c in nouns:
            if tuple(tokens[i:i + len(words)]) == words:
                return len(words), c
        return None

    out: list[Description] = []
    i = 0
    while i < len(tokens):
        found = noun_at(i)
        if found is None:
            i += 1
            continue
        n, c = found
        if i + n < len(tokens) and noun_at(i + n) is not None:
            i += n  # a material before the noun ("glass bowl")
            continue
        color = ""
        k = i - 1
        while k >= 0 and tokens[k] not in ("the", "a", "an", ",", "and", "of", "on", "in", "to"):
            color = color or colors.get(tokens[k], "")
            k -= 1
        out.append(Description(c, color, tuple(tokens[k + 1:i + n])))
        i += n
    return out


def fits(obj: SeenObject, description: Description) -> bool:
    """Whether an object on the table fits a description: the class map gives its class at least
    :data:`CLASS_FIT`, and its most likely colour is the one named (when one is)."""
    return obj.classes.get(description.name, 0.0) >= CLASS_FIT and (
        not description.color or obj.color == description.color)


def unnamed_cells(objects: Sequence[SeenObject], descriptions: Sequence[Description]) -> np.ndarray | None:
    """The cells of the network's map the grasp is not sought in: those of the objects that fit none of
    ``descriptions``; None (no restriction) when there is no description, no object or no object that
    fits one."""
    if not descriptions or not objects:
        return None
    fitting = [any(fits(o, d) for d in descriptions) for o in objects]
    if not any(fitting):
        return None
    out = np.zeros_like(objects[0].cells, dtype=bool)
    for o, f in zip(objects, fitting, strict=True):
        if not f:
            out |= o.cells
    return out

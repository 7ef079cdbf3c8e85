"""Grounding a noun the keypose policy never heard, by exclusion (generalisation level L4).

The policy keeps *which object* apart from *how to move*, as 3D-LOTUS++ and ProgramPort do: when an
instruction names a thing with a word outside its training instructions' words, in a noun's place
(after a determiner, an attribute word it knows or another unknown word), the object meant is the one
that no class it knows fits, among the objects whose colour, material and size agree with the
attributes the instruction does name; the grasp is then sought on that object only, with the
class-agnostic grasp head. For each class the instruction names, the object it fits best is the
instruction's other object (a reference, a container) and is left out.

This module holds the rule on plain arrays (no PyTorch): :func:`unknown_nouns` says whether it fires,
:func:`table_objects` finds the objects on the policy's map of the table, and
:func:`exclusion_target` chooses among them from the auxiliary attribute maps' probabilities.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache

import numpy as np
from scipy import ndimage

from samplehd.envs.tokens import tokenize
from samplehd.language.lexicon import default_lexicon
from samplehd.learn.keypose.configuration import KeyposeVocabulary

__all__ = ["DETERMINERS", "MIN_CELLS", "OBJECT_HEIGHT", "SeenObject", "exclusion_target", "named_classes",
           "named_values", "table_objects", "unknown_nouns"]

# words after which a noun phrase starts: an unknown word there is in a noun's place
DETERMINERS = frozenset({"the", "a", "an", "all", "both", "each", "every", "this", "that", "these", "those"})
OBJECT_HEIGHT = 0.004  # a cell of the map higher than this above the table shows an object [m]
MIN_CELLS = 2  # an object covers at least this many cells of the network's map
HEIGHT_CHANNEL = 3  # the grid image's height channel (per :data:`samplehd.learn.topdown.HEIGHT_SCALE`)
SEEN_CHANNEL = 4


@dataclass(frozen=True)
class SeenObject:
    """One object on the policy's map of the table.

    Attributes:
        cells: (rows, cols) bool, the cells of the network's map it covers.
        classes: the probability of each class the policy knows (mean over its cells).
        color: its most likely colour.
        material: its most likely material.
        size: its most likely size.
    """

    cells: np.ndarray
    classes: Mapping[str, float]
    color: str
    material: str
    size: str

    @property
    def fit(self) -> float:
        """How well the best-fitting known class fits it (its probability, 0..1)."""
        return max(self.classes.values(), default=0.0)

    @property
    def best_class(self) -> str:
        return max(self.classes, key=lambda c: self.classes[c]) if self.classes else ""


@cache
def _attribute_words() -> dict[str, dict[str, str]]:
    """attribute -> value -> the word the instructions say it with."""
    adjectives = default_lexicon().adjectives
    return {"color": dict(adjectives.get("colour", {})), "material": dict(adjectives.get("material", {})),
            "size": dict(adjectives.get("size", {}))}


def _says(tokens: Sequence[str], phrase: str) -> bool:
    words = tokenize(phrase)
    return any(list(tokens[i:i + len(words)]) == words for i in range(len(tokens) - len(words) + 1))


def named_values(instruction: str, vocabulary: KeyposeVocabulary) -> dict[str, set[str]]:
    """Per attribute (colour, material, size), the values the instruction names."""
    tokens = tokenize(instruction)
    words = _attribute_words()
    return {a: {v for v in vocabulary.values(a) if _says(tokens, words[a].get(v, v.replace("_", " ")))}
            for a in ("color", "material", "size")}


def named_classes(instruction: str, vocabulary: KeyposeVocabulary) -> set[str]:
    """The known classes whose noun (singular or plural) the instruction says."""
    tokens = tokenize(instruction)
    nouns = default_lexicon().nouns
    return {c for c in vocabulary.name
            if any(_says(tokens, n) for n in nouns.get(c, (c.replace("_", " "), c.replace("_", " ") + "s")))}


def unknown_nouns(instruction: str, vocabulary: KeyposeVocabulary) -> list[str]:
    """The words of ``instruction`` it does not know (neither a training word nor a word of an attribute
    value or class its maps name) that stand in a noun's place: right after a determiner
    (:data:`DETERMINERS`), a known attribute word or another such word, and not right before a
    determiner (a word there is a preposition: "glass" is a material word and a class, so the unheard
    "inside" in "place the glass inside the pan" follows an attribute word). Empty (the rule does not
    fire) for a policy that recorded no training words."""
    if not vocabulary.words:
        return []
    adjectives = {w for a in _attribute_words().values() for w in a.values()} | {
        v for a in ("color", "material", "size") for v in vocabulary.values(a)}
    nouns = default_lexicon().nouns
    # the words of the attribute values and classes its maps name are known even when no training
    # instruction said them (a material, a plural)
    known = set(vocabulary.words) | adjectives | {
        w for c in vocabulary.name for n in nouns.get(c, (c.replace("_", " "),)) for w in tokenize(n)}
    tokens = tokenize(instruction)
    out: list[str] = []
    for i, w in enumerate(tokens):
        if w in known or not w.isalpha() or i == 0:
            continue
        if i + 1 < len(tokens) and tokens[i + 1] in DETERMINERS:
            continue  # a word that opens a noun phrase of its own is a preposition ("the glass inside the pan")
        before = tokens[i - 1]
        if before in DETERMINERS or before in adjectives or (out and out[-1] == before):
            out.append(w)
    return out


def table_objects(grid: np.ndarray, class_logits: np.ndarray, attribute_logits: Mapping[str, np.ndarray],
                  vocabulary: KeyposeVocabulary, factor: int) -> list[SeenObject]:
    """The objects on the table: connected groups of the network's map cells higher than
    :data:`OBJECT_HEIGHT` above the table, each with its mean class probabilities and most likely
    colour, material and size.

    Args:
        grid: the grid image (channels, rows, cols) the policy decided on.
        class_logits: (classes, rows / factor, cols / factor), the class map's logits of the known
            classes (``vocabulary.name``, in that order).
        attribute_logits: colour, material and size -> (values, rows / factor, cols / factor).
        vocabulary: the values the maps name.
        factor: the network's map cells are ``factor`` grid cells wide.
    """
    rows, cols = class_logits.shape[1:]
    height = np.where(grid[SEEN_CHANNEL] > 0, grid[HEIGHT_CHANNEL], 0.0)[:rows * factor, :cols * factor]
    coarse = height.reshape(rows, factor, cols, factor).max(axis=(1, 3)) * 0.1  # HEIGHT_SCALE [m]
    labels, n = ndimage.label(coarse > OBJECT_HEIGHT)
    p = np.exp(class_logits - class_logits.max(0, keepdims=True))
    p /= p.sum(0, keepdims=True)
    out = []
    for k in range(1, n + 1):
        cells = labels == k
        if cells.sum() < MIN_CELLS:
            continue
        mean = p[:, cells].mean(1)
        guess = {a: vocabulary.values(a)[int(np.argmax(attribute_logits[a][:, cells].mean(1)))]
                 if len(vocabulary.values(a)) else "" for a in ("color", "material", "size")}
        out.append(SeenObject(cells, {c: float(mean[i]) for i, c in enumerate(vocabulary.name)}, **guess))
    return out


def exclusion_target(instruction: str, vocabulary: KeyposeVocabulary, objects: Sequence[SeenObject],
                     ) -> int | None:
    """The index of the object an unheard noun means, or None when the rule does not fire (no unknown
    word in a noun's place, :func:`unknown_nouns`) or no object is left to choose.

    The candidates are the objects whose colour, material and size agree with every value of those the
    instruction names, less, for each class the instruction names, the object that class fits best
    (the instruction's other object: a reference, a container); among them, the one the best-fitting
    known class fits least.
    """
    if not unknown_nouns(instruction, vocabulary):
        return None
    named = named_values(instruction, vocabulary)
    others = {max(range(len(objects)), key=lambda i: objects[i].classes.get(c, 0.0))
              for c in named_classes(instruction, vocabulary) if objects}
    free = [i for i in range(len(objects)) if i not in others]
    agree = [i for i in free if all(not want or getattr(objects[i], a) in want for a, want in named.items())]
    pool = agree or free
    if not pool:
        return None
    return min(pool, key=lambda i: objects[i].fit)


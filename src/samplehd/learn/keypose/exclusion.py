"""Grounding a noun the keypose policy never heard, by exclusion (generalisation level L4).

The policy keeps *which object* apart from *how to move*, as 3D-LOTUS++ and ProgramPort do: when an
instruction names a thing with a word outside its training instructions' words, in a noun's place
(after a determiner, an attribute word it knows or another unknown word), the object meant is the one
that no class it knows fits, among the objects whose colour, material and size agree with the
attributes the instruction does name. A class fits an object as well as the class map says, and not
at all when the object's height, length and width on the map lie outside the sizes the class was seen
with in training (:class:`~samplehd.learn.keypose.configuration.ShapeRange`): the class map alone
calls a squat box a chopping board, and a knife, whose few cells it is unsure of, fits nothing. The
grasp is then sought on that object only, with the class-agnostic grasp head. For each class the
instruction names, the object it fits best is the instruction's other object (a reference, a
container) and is left out.

This module holds the rule on plain arrays (no PyTorch): :func:`unknown_nouns` says whether it fires,
:func:`table_objects` finds the objects on the policy's map of the table, and
:func:`exclusion_target` chooses among them from the auxiliary attribute maps' probabilities and the
objects' sizes; :func:`shape_ranges` measures the sizes each class was seen with, for the trainer.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache

import numpy as np
from scipy import ndimage

from samplehd.envs.tokens import tokenize
from samplehd.language.lexicon import default_lexicon
from samplehd.learn.keypose.configuration import KEYPOSE_ATTRIBUTES, KeyposeVocabulary, ShapeRange
from samplehd.learn.topdown import HEIGHT_SCALE, TopDownGrid

__all__ = ["DETERMINERS", "MIN_CELLS", "OBJECT_HEIGHT", "RELATION_WORDS", "SHAPE_MARGIN", "SeenObject",
           "exclusion_target", "moves_unheard", "named_classes", "named_values", "object_shape", "shape_ranges",
           "table_objects", "unknown_nouns"]

# words after which a noun phrase starts: an unknown word there is in a noun's place
DETERMINERS = frozenset({"the", "a", "an", "all", "both", "each", "every", "this", "that", "these", "those"})
OBJECT_HEIGHT = 0.004  # a cell of the map higher than this above the table shows an object [m]
MIN_CELLS = 2  # an object covers at least this many cells of the network's map
HEIGHT_CHANNEL = 3  # the grid image's height channel (per :data:`samplehd.learn.topdown.HEIGHT_SCALE`)
SEEN_CHANNEL = 4
# words that open the phrase naming where things go: an unheard noun after one names a reference or a
# container, not an object to move ("move the mug behind the food box")
RELATION_WORDS = frozenset({"on", "onto", "in", "into", "inside", "to", "behind", "beside", "next", "near", "at",
                            "from", "off", "under", "over", "above", "below", "with", "then"})
# A size seen in training counts as this much wider (height, length, width) [m]: a few millimetres of
# a height map's noise, a map cell of a footprint's.
SHAPE_MARGIN = (0.005, 0.016, 0.016)
# the sizes of a class kept from training: a fragment, an odd view or merged objects left out (chosen on
# the L4 episodes of a training dataset's test split, never on a benchmark suite)
SHAPE_PERCENTILES = (10.0, 90.0)


@dataclass(frozen=True)
class SeenObject:
    """One object on the policy's map of the table.

    Attributes:
        cells: (rows, cols) bool, the cells of the network's map it covers.
        classes: the probability of each class the policy knows (mean over its cells).
        color: its most likely colour.
        material: its most likely material.
        size: its most likely size.
        shape: its (height, length, width) on the map [m] (:func:`object_shape`).
    """

    cells: np.ndarray
    classes: Mapping[str, float]
    color: str
    material: str
    size: str
    shape: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def fit(self) -> float:
        """How well the best-fitting known class fits it (its probability, 0..1)."""
        return max(self.classes.values(), default=0.0)

    def fit_among(self, shapes: Sequence[ShapeRange]) -> float:
        """How well the best-fitting known class fits it, counting only the classes whose sizes seen in
        training (``shapes``, widened by :data:`SHAPE_MARGIN`) hold its own; a class without a range fits
        any size."""
        ranges = {r.name: r for r in shapes}

        def holds(c: str) -> bool:
            r = ranges.get(c)
            return r is None or all(lo - m <= v <= hi + m
                                    for v, lo, hi, m in zip(self.shape, r.low, r.high, SHAPE_MARGIN, strict=True))

        return max((p for c, p in self.classes.items() if holds(c)), default=0.0)

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


def moves_unheard(instruction: str, vocabulary: KeyposeVocabulary) -> bool:
    """Whether the instruction's first unheard noun (:func:`unknown_nouns`) names an object to move: it
    stands before every word of :data:`RELATION_WORDS` ("put the food box in the bowl"), not in the
    phrase saying where things go ("put the mug next to the food box")."""
    unheard = unknown_nouns(instruction, vocabulary)
    if not unheard:
        return False
    tokens = tokenize(instruction)
    first = tokens.index(unheard[0], 1)
    return not any(w in RELATION_WORDS for w in tokens[1:first])


def table_objects(grid: np.ndarray, class_logits: np.ndarray, attribute_logits: Mapping[str, np.ndarray],
                  vocabulary: KeyposeVocabulary, factor: int, grid_cell: float = TopDownGrid.cell) -> list[SeenObject]:
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
        grid_cell: a grid cell's width [m].
    """
    heights, groups = _raised_groups(grid, *class_logits.shape[1:], factor)
    p = np.exp(class_logits - class_logits.max(0, keepdims=True))
    p /= p.sum(0, keepdims=True)
    out = []
    for cells in groups:
        mean = p[:, cells].mean(1)
        guess = {a: vocabulary.values(a)[int(np.argmax(attribute_logits[a][:, cells].mean(1)))]
                 if len(vocabulary.values(a)) else "" for a in ("color", "material", "size")}
        out.append(SeenObject(cells, {c: float(mean[i]) for i, c in enumerate(vocabulary.name)}, **guess,
                              shape=object_shape(cells, heights, grid_cell * factor)))
    return out


def _raised_groups(grid: np.ndarray, rows: int, cols: int, factor: int) -> tuple[np.ndarray, list[np.ndarray]]:
    """(height of each of the network's map cells [m], the connected groups of at least
    :data:`MIN_CELLS` cells higher than :data:`OBJECT_HEIGHT`, each a bool mask)."""
    height = np.where(grid[SEEN_CHANNEL] > 0, grid[HEIGHT_CHANNEL], 0.0)[:rows * factor, :cols * factor]
    coarse = height.reshape(rows, factor, cols, factor).max(axis=(1, 3)).astype(np.float64) * HEIGHT_SCALE
    labels, n = ndimage.label(coarse > OBJECT_HEIGHT)
    groups = [labels == k for k in range(1, n + 1)]
    return coarse, [g for g in groups if g.sum() >= MIN_CELLS]


def object_shape(cells: np.ndarray, heights: np.ndarray, cell: float) -> tuple[float, float, float]:
    """(height, length, width) [m] of an object on a map of ``cell``-wide cells: its highest cell's height
    and its extents along its cells' principal axes (a cell's width included). Elementwise arithmetic
    only (no linear-algebra library), so that the figure is the same on any machine."""
    rc = np.argwhere(cells).astype(np.float64)
    d = rc - rc.mean(0)
    srr, scc, src = (d[:, 0] ** 2).sum(), (d[:, 1] ** 2).sum(), (d[:, 0] * d[:, 1]).sum()
    angle = 0.5 * np.arctan2(2.0 * src, srr - scc)  # the principal axis of a 2 × 2 covariance
    along = d[:, 0] * np.cos(angle) + d[:, 1] * np.sin(angle)
    across = -d[:, 0] * np.sin(angle) + d[:, 1] * np.cos(angle)
    extents = sorted((float(np.ptp(along)) + 1.0, float(np.ptp(across)) + 1.0), reverse=True)
    return float(heights[cells].max()), extents[0] * cell, extents[1] * cell


def shape_ranges(grids: np.ndarray, attributes: np.ndarray, classes: Sequence[str], factor: int,
                 grid_cell: float) -> tuple[ShapeRange, ...]:
    """The sizes each class was seen with in training views: per class of ``classes``, the
    :data:`SHAPE_PERCENTILES` of the :func:`object_shape` of every raised group of cells
    (:func:`table_objects`) that the attribute maps give that one class (90 % of its labelled cells, at
    least :data:`MIN_CELLS` of them; a group's edge cells, pooled from their neighbours, and the cells
    a low-resolution image leaves unseen carry no label).

    Args:
        grids: (samples, channels, rows, cols) grid images.
        attributes: (samples, attributes, rows / factor, cols / factor) their attribute maps (the class's
            index in ``classes`` per cell, -1 where none).
        classes: the class names, in the order of the maps' indices.
        factor: the maps' cells are ``factor`` grid cells wide.
        grid_cell: a grid cell's width [m].
    """
    name = KEYPOSE_ATTRIBUTES.index("name")
    seen: dict[int, list[tuple[float, float, float]]] = {}
    for grid, maps in zip(grids, attributes, strict=True):
        heights, groups = _raised_groups(grid, *maps.shape[1:], factor)
        for cells in groups:
            labels = maps[name][cells]
            labels = labels[labels >= 0]
            values, counts = np.unique(labels, return_counts=True)
            if len(labels) >= MIN_CELLS and counts.max() >= 0.9 * len(labels):
                shape = object_shape(cells, heights, grid_cell * factor)
                seen.setdefault(int(values[np.argmax(counts)]), []).append(shape)
    out = []
    for k in sorted(seen):
        sizes = np.array(seen[k])
        lo, hi = np.percentile(sizes, SHAPE_PERCENTILES, axis=0)
        out.append(ShapeRange(classes[k], tuple(round(float(v), 4) for v in lo), tuple(round(float(v), 4) for v in hi)))
    return tuple(out)


def exclusion_target(instruction: str, vocabulary: KeyposeVocabulary, objects: Sequence[SeenObject],
                     ) -> int | None:
    """The index of the object an unheard noun means, or None when the rule does not fire (no unknown
    word in a noun's place, :func:`unknown_nouns`) or no object is left to choose.

    The candidates are the objects whose colour, material and size agree with every value of those the
    instruction names, less, for each class the instruction names, the object that class fits best
    (the instruction's other object: a reference, a container); among them, the one the best-fitting
    known class of a size that holds its own (:meth:`SeenObject.fit_among`) fits least.
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
    return min(pool, key=lambda i: objects[i].fit_among(vocabulary.shapes))


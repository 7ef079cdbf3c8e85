"""Grounding a noun the keypose policy knows: the grasp is sought on an object the instruction names.

The network decides where to grasp from the image and the words together, and on held-out episodes
it lifts another object than the one named about as often as it misses a grasp ("Pick up the
scissors." lifting the chopping board). Its auxiliary class map, trained on every object's cells,
tells the objects apart better than the grasp map's choice does. So *which object* is taken from the
class map and *how to grasp it* from the grasp map, as for an unheard noun
(:mod:`samplehd.learn.keypose.exclusion`): when the phrase naming what to move (the words before the
first word of :data:`~samplehd.learn.keypose.exclusion.RELATION_WORDS`) names a class the policy knows,
the grasp is sought only on the objects of the table that class fits (:func:`named_cells`); among
them, the grasp map chooses as before, so a grasp already on such an object is unchanged.

Plain arrays only (no PyTorch), as the exclusion rule.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import ndimage

from samplehd.envs.tokens import tokenize
from samplehd.language.lexicon import default_lexicon
from samplehd.learn.keypose.configuration import KeyposeVocabulary
from samplehd.learn.keypose.exclusion import RELATION_WORDS, SeenObject, named_classes, named_values, unknown_nouns
from samplehd.learn.topdown import TopDownGrid
from samplehd.world.layout import table_parts_of

__all__ = ["BOTTOM_UP", "MIDDLE", "NAMED_FIT", "PART_FOLLOWERS", "moved_phrase", "named_cells", "table_part"]

# An object is one the instruction names when a named class is the class map's best for it or, where
# no object has a named class as its best, when the class map gives a named class at least this
# probability (mean over its cells).
NAMED_FIT = 0.25
# words that may follow a table part phrase that places the object to move (not a destination's noun)
PART_FOLLOWERS = RELATION_WORDS | {".", ",", "and", "down", "up", "away"}
# where a tower's first object moved is said: "in the middle", or second in a list "from the bottom up"
MIDDLE = ("in", "the", "middle")
BOTTOM_UP = ("from", "the", "bottom", "up")


def table_part(instruction: str) -> str | None:
    """The table part the phrase of what to move places its object in, said right after it ("the
    chopping board at the back off the table", "the mugs that are on the left in the bowl"): a table
    part phrase of the lexicon followed by the instruction's end or a word that is no noun ("on the
    left side of the table" is a destination, not a table part). None where it says none."""
    tokens = tokenize(instruction)
    start = _moved_span(tokens)[1]
    if tokens[start:start + 1] == ["that"]:
        start += 2  # "that is", "that are"
    for part, phrase in default_lexicon().table_part_phrase.items():
        words = tokenize(phrase)
        end = start + len(words)
        if tokens[start:end] == words and (end == len(tokens) or tokens[end] in PART_FOLLOWERS):
            return part
    return None


def moved_phrase(instruction: str) -> str:
    """The words of ``instruction`` that name what to move first: those before the first word of
    :data:`~samplehd.learn.keypose.exclusion.RELATION_WORDS` after the verb ("lift the bowl" of "Lift
    the bowl off the table.", "put the mug" of "Put the mug in the bowl."); in a tower, the first one
    set on another: the object "in the middle" ("the plate" of "Build a tower with the board at the
    bottom, the plate in the middle and the glass on top.") or the second of a list "from the bottom up"
    ("the plate" of "Make a stack of the board, the plate and the bowl, from the bottom up.")."""
    tokens = tokenize(instruction)
    start, end = _moved_span(tokens)
    return " ".join(tokens[start:end])


def _moved_span(tokens: Sequence[str]) -> tuple[int, int]:
    """(first, past last) index of :func:`moved_phrase`'s words in ``tokens``."""
    start, stop = 0, len(tokens)
    middle = _find(tokens, MIDDLE)
    bottom_up = _find(tokens, BOTTOM_UP)
    if middle is not None:  # "..., the plate in the middle and ..."
        start = max((j + 1 for j in range(middle) if tokens[j] in (",", "with")), default=0)
        stop = middle
    elif bottom_up is not None and "of" in tokens[:bottom_up]:  # "a stack of A, B and C, from the bottom up"
        first = tokens.index("of") + 1
        breaks = [j for j in range(first, bottom_up) if tokens[j] in (",", "and")]
        if breaks:
            start = breaks[0] + 1
            stop = next((j for j in breaks[1:]), bottom_up)
    end = next((i for i in range(start + 1, stop) if tokens[i] in RELATION_WORDS), stop)
    return start, end


def _find(tokens: Sequence[str], words: tuple[str, ...]) -> int | None:
    return next((i for i in range(len(tokens)) if tuple(tokens[i:i + len(words)]) == words), None)


def named_cells(instruction: str, vocabulary: KeyposeVocabulary, objects: Sequence[SeenObject],
                coarse: TopDownGrid) -> np.ndarray | None:
    """The cells of the network's map (bool, rows × cols) the grasp is sought in: those of the objects
    of the table (:func:`~samplehd.learn.keypose.exclusion.table_objects`) that a class named in the
    phrase of what to move (:func:`moved_phrase`) fits, widened by one cell (a grasp at an object's rim
    may lie just outside its raised cells). Of those objects, the ones whose colour, material and size
    agree with the values the phrase names, where any do, and of those, the ones whose centre lies in
    the table part it names (:func:`table_part`), where any does. ``coarse``: the network's map
    (:meth:`TopDownGrid.coarse`). None (the grasp map alone decides) when the
    instruction names no known class to move, holds a word the policy never heard (the exclusion rule's
    case), or no object fits."""
    if not objects or unknown_nouns(instruction, vocabulary):
        return None
    phrase = moved_phrase(instruction)
    classes = named_classes(phrase, vocabulary)
    if not classes:
        return None
    fitting = [o for o in objects if o.best_class in classes]
    if not fitting:
        fitting = [o for o in objects if max(o.classes.get(c, 0.0) for c in classes) >= NAMED_FIT]
    if not fitting:
        return None
    named = named_values(phrase, vocabulary)
    chosen = [o for o in fitting if all(not want or getattr(o, a) in want for a, want in named.items())] or fitting
    part = table_part(instruction)
    if part is not None:
        chosen = [o for o in chosen if part in table_parts_of(coarse.world(*np.argwhere(o.cells).mean(0)))] or chosen
    cells = np.logical_or.reduce([o.cells for o in chosen])
    return ndimage.binary_dilation(cells)

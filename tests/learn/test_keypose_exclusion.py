"""Grounding by exclusion (L4): the rule fires on a noun in a noun's place that training never said, and
only then; it picks the object no known class fits among those of the named attributes; the grasp is
then sought on that object alone."""

from __future__ import annotations

import numpy as np
import pytest

from samplehd.errors import ConfigError
from samplehd.learn.keypose.configuration import KeyposeConfig, KeyposeVocabulary
from samplehd.learn.keypose.exclusion import SeenObject, exclusion_target, table_objects, unknown_nouns

VOCABULARY = KeyposeVocabulary(
    words=("pick", "up", "the", "red", "blue", "small", "large", "mug", "bowl", "put", "in", "on", "left", "side",
           "of", "table", ".", "place", "metal", "wooden"),
    name=("bowl", "mug", "plate"), color=("blue", "red"), material=("metal", "wooden"), size=("large", "small"))


def _object(fit: dict[str, float], color: str = "red", material: str = "wooden", size: str = "small") -> SeenObject:
    return SeenObject(np.zeros((4, 4), bool), fit, color, material, size)


def test_the_rule_fires_only_on_an_unheard_word_in_a_nouns_place() -> None:
    assert unknown_nouns("Pick up the food box.", VOCABULARY) == ["food", "box"]
    assert unknown_nouns("Pick up the small red food box.", VOCABULARY) == ["food", "box"]
    assert unknown_nouns("Pick up the red mug.", VOCABULARY) == []  # every word heard
    assert unknown_nouns("Grab the red mug.", VOCABULARY) == []  # an unheard verb is no noun
    assert unknown_nouns("Put the mug onto the bowl.", VOCABULARY) == []  # nor a preposition after a noun
    # nor one after a word that is a material and a class (glass): it opens a noun phrase of its own
    assert unknown_nouns("Place the metal inside the bowl.", VOCABULARY) == []
    assert unknown_nouns("Put the metal food box in the bowl.", VOCABULARY) == ["food", "box"]
    # the words of values and classes its maps name are known though no instruction said them
    assert unknown_nouns("Pick up the plates.", VOCABULARY) == []
    assert unknown_nouns("Pick up the medium-sized mug.", VOCABULARY) == []
    assert unknown_nouns("Pick up the food box.", KeyposeVocabulary()) == []  # a policy that recorded no words


def test_the_object_no_known_class_fits_is_chosen_among_the_named_attributes() -> None:
    objects = [_object({"bowl": 0.05, "mug": 0.9, "plate": 0.05}),
               _object({"bowl": 0.4, "mug": 0.3, "plate": 0.3}),  # fits nothing well, red
               _object({"bowl": 0.35, "mug": 0.35, "plate": 0.3}, color="blue"),  # fits least, but blue
               _object({"bowl": 0.9, "mug": 0.05, "plate": 0.05})]
    assert exclusion_target("Pick up the food box.", VOCABULARY, objects) == 2
    assert exclusion_target("Pick up the red food box.", VOCABULARY, objects) == 1
    # a class the instruction names is another object of it (here the container), never the unheard one
    objects[1] = _object({"bowl": 0.45, "mug": 0.3, "plate": 0.25})
    assert exclusion_target("Put the red food box in the bowl.", VOCABULARY, objects) == 1
    assert exclusion_target("Put the red thing box in the mug.", VOCABULARY, objects[:1]) is None  # none left
    assert exclusion_target("Pick up the red mug.", VOCABULARY, objects) is None  # no unheard noun: no rule


def test_objects_are_the_raised_cells_of_the_map() -> None:
    grid = np.zeros((7, 16, 16), np.float32)
    grid[4] = 1.0  # seen everywhere
    grid[3, 2:6, 2:6] = 0.5  # 5 cm high: one object
    grid[3, 10:14, 8:12] = 0.02  # 2 mm: the table's texture, no object
    grid[3, 10:12, 12:16] = 1.0  # another object
    logits = np.zeros((3, 8, 8))
    logits[1, 1:3, 1:3] = 5.0  # the first is a mug
    attributes = {"color": np.zeros((2, 8, 8)), "material": np.zeros((2, 8, 8)), "size": np.zeros((2, 8, 8))}
    attributes["color"][1, 5, 6:8] = 3.0
    found = table_objects(grid, logits, attributes, VOCABULARY, factor=2)
    assert len(found) == 2
    assert found[0].best_class == "mug" and found[0].fit > 0.9 and found[0].cells.sum() == 4
    assert found[1].fit == pytest.approx(1 / 3) and found[1].color == "red"


def test_a_vocabulary_that_is_not_lists_of_words_is_one_line_naming_it() -> None:
    config = KeyposeConfig(vocabulary=VOCABULARY)
    assert KeyposeConfig.from_dict(config.to_dict()).vocabulary == VOCABULARY
    with pytest.raises(ConfigError, match="vocabulary.words"):
        KeyposeConfig.from_dict({**config.to_dict(), "vocabulary": {"words": "pick up"}})
    with pytest.raises(ConfigError, match=r"vocabulary: unknown option.*nouns.*valid: words"):
        KeyposeConfig.from_dict({**config.to_dict(), "vocabulary": {"nouns": ["mug"]}})

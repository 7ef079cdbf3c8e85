"""Grounding by exclusion (L4): the rule fires on a noun in a noun's place that training never said, and
only then; it picks the object no known class fits among those of the named attributes; the grasp is
then sought on that object alone."""

from __future__ import annotations

import numpy as np
import pytest

from samplehd.errors import ConfigError
from samplehd.learn.keypose.configuration import KeyposeConfig, KeyposeVocabulary, ShapeRange
from samplehd.learn.keypose.exclusion import (
    SeenObject,
    exclusion_target,
    moves_unheard,
    object_shape,
    shape_ranges,
    table_objects,
    unknown_nouns,
)

VOCABULARY = KeyposeVocabulary(
    words=("pick", "up", "the", "red", "blue", "small", "large", "mug", "bowl", "put", "in", "on", "left", "side",
           "of", "table", ".", "place", "metal", "wooden"),
    name=("bowl", "mug", "plate"), color=("blue", "red"), material=("metal", "wooden"), size=("large", "small"))


def _object(fit: dict[str, float], color: str = "red", material: str = "wooden", size: str = "small",
            shape: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> SeenObject:
    return SeenObject(np.zeros((4, 4), bool), fit, color, material, size, shape)


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


def test_an_unheard_noun_names_an_object_to_move_only_before_the_phrase_of_where_it_goes() -> None:
    assert moves_unheard("Put the red food box in the bowl.", VOCABULARY)
    assert moves_unheard("Pick up the food box.", VOCABULARY)
    assert moves_unheard("Put the mug and the food box on the left side of the table.", VOCABULARY)
    assert not moves_unheard("Put the mug in the food box.", VOCABULARY)  # the container
    assert not moves_unheard("Place the mug to the left of the food box.", VOCABULARY)  # the reference
    assert not moves_unheard("Pick up the red mug.", VOCABULARY)  # nothing unheard


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


def test_a_class_fits_no_object_of_a_size_it_was_never_seen_with() -> None:
    # the class map calls a squat box a plate, and is unsure of a thin knife-like mug handle; the sizes
    # say the box is no plate (plates were seen 1-3 cm high, 20-30 cm across)
    shapes = (ShapeRange("plate", (0.01, 0.20, 0.20), (0.03, 0.30, 0.30)),
              ShapeRange("mug", (0.08, 0.08, 0.06), (0.12, 0.14, 0.10)))
    vocabulary = KeyposeVocabulary(words=VOCABULARY.words, name=VOCABULARY.name, color=VOCABULARY.color,
                                   material=VOCABULARY.material, size=VOCABULARY.size, shapes=shapes)
    box = _object({"bowl": 0.1, "mug": 0.1, "plate": 0.8}, shape=(0.045, 0.09, 0.08))
    mug = _object({"bowl": 0.3, "mug": 0.4, "plate": 0.3}, shape=(0.10, 0.12, 0.09))
    assert box.fit_among(shapes) == pytest.approx(0.1)  # only the bowl, seen at no size, may fit it
    assert mug.fit_among(shapes) == pytest.approx(0.4)
    assert exclusion_target("Pick up the food box.", VOCABULARY, [mug, box]) == 0  # the class map alone: the mug
    assert exclusion_target("Pick up the food box.", vocabulary, [mug, box]) == 1
    # a size within the margin of a range still fits: 2 mm above the highest plate
    assert _object({"plate": 1.0}, shape=(0.032, 0.25, 0.25)).fit_among(shapes) == 1.0
    assert KeyposeConfig.from_dict(KeyposeConfig(vocabulary=vocabulary).to_dict()).vocabulary == vocabulary


def test_an_objects_size_is_its_height_and_extents_along_its_own_axes() -> None:
    heights = np.zeros((12, 12))
    cells = np.zeros((12, 12), bool)
    cells[2:4, 1:9] = True  # 8 cells long, 2 wide
    heights[cells] = 0.03
    heights[3, 4] = 0.05
    assert object_shape(cells, heights, 0.016) == pytest.approx((0.05, 8 * 0.016, 2 * 0.016))
    diagonal = np.eye(12, dtype=bool) | np.eye(12, k=1, dtype=bool)  # a thin thing lying at 45 degrees
    height, length, width = object_shape(diagonal, heights + 0.01, 0.016)
    assert length == pytest.approx((11 * 2 ** 0.5 + 1) * 0.016) and width < 2 * 0.016


def test_the_sizes_a_class_was_seen_with_come_from_the_labelled_training_views() -> None:
    grids = np.zeros((2, 5, 16, 16), np.float32)
    grids[:, 4] = 1.0
    attributes = np.full((2, 4, 8, 8), -1, np.int8)
    for k, (rows, height) in enumerate(((slice(2, 6), 0.5), (slice(2, 8), 0.7))):
        grids[k, 3, rows, 2:6] = height  # a mug 5 and 7 cm high, 4 and 6 grid cells long
        attributes[k, 0, rows.start // 2:rows.stop // 2, 1:3] = 1
    grids[0, 3, 10:14, 10:14] = 0.2  # an object of no class the maps name (held out)
    (mug,) = shape_ranges(grids, attributes, VOCABULARY.name, factor=2, grid_cell=0.008)
    assert mug.name == "mug"
    assert mug.low[0] == pytest.approx(0.052, abs=1e-4) and mug.high[0] == pytest.approx(0.068, abs=1e-4)
    assert mug.high[1] <= 0.048 + 1e-9 and mug.low[2] == pytest.approx(0.032)


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


def test_the_grasp_of_a_grounded_object_opens_wide_and_stays_near_its_top() -> None:
    pytest.importorskip("torch")
    from samplehd.learn.keypose.inference import GROUNDED_GRASP_OVER_TOP, grounded_grasp
    from samplehd.learn.keypose.processing import Decision
    from samplehd.robot.constants import GRIPPER_STROKE
    from samplehd.world.layout import LAYOUT

    box = _object({"plate": 0.2}, shape=(0.045, 0.09, 0.08))
    table = LAYOUT.table_height
    high = Decision((0.1, 0.2, table + 0.08, 0.3), 0.04, table + 0.2, (0.0, 0.1, table + 0.1, 0.0), False, True)
    capped = grounded_grasp(high, box)
    assert capped.grasp == pytest.approx((0.1, 0.2, table + 0.045 + GROUNDED_GRASP_OVER_TOP, 0.3))
    assert capped.opening == GRIPPER_STROKE and capped.goal == high.goal and capped.lift == high.lift
    low = Decision((0.1, 0.2, table + 0.03, 0.3), 0.04, table + 0.2, (0.0, 0.1, table + 0.1, 0.0), False, True)
    assert grounded_grasp(low, box).grasp[2] == table + 0.03  # a lower grasp stays

"""Keeping the keypose policy's grasp on the objects the instruction names: the instruction's
descriptions (class noun, colour), which objects on the map fit them, and the cells the grasp is kept
off."""

from __future__ import annotations

import numpy as np

from samplehd.learn.keypose.configuration import KeyposeVocabulary
from samplehd.learn.keypose.exclusion import SeenObject
from samplehd.learn.keypose.grounding import CLASS_FIT, Description, described_objects, fits, unnamed_cells

VOCABULARY = KeyposeVocabulary(
    words=("pick", "up", "the", "mug"), name=("bowl", "glass", "mug", "plate", "soda_can", "wine_glass"),
    color=("blue", "red", "white"), material=("glass", "metal"), size=("large", "small"))


def _object(classes: dict[str, float], color: str, cells: tuple[slice, slice]) -> SeenObject:
    mask = np.zeros((6, 6), bool)
    mask[cells] = True
    return SeenObject(mask, classes, color, "metal", "small")


def test_an_instruction_describes_each_object_by_its_class_noun_and_the_colour_before_it() -> None:
    said = described_objects("Put the medium-sized red glass bowl on the blue wine glass, then move the soda cans.",
                             VOCABULARY)
    assert said == [Description("bowl", "red"), Description("wine_glass", "blue"), Description("soda_can")]
    assert described_objects("Grab the white mug and hold it up.", VOCABULARY) == [Description("mug", "white")]
    # a colour belongs to the noun it stands before, not to the next one
    assert described_objects("Stack the red mug on the plate.", VOCABULARY) == [
        Description("mug", "red"), Description("plate")]
    assert described_objects("Clear the left side of the table.", VOCABULARY) == []
    assert described_objects("Pick up the glass.", VOCABULARY) == [Description("glass")]
    assert described_objects("Pick up the food box.", VOCABULARY) == []  # a class the policy does not know


def test_an_object_fits_a_description_by_its_class_and_named_colour() -> None:
    mug = _object({"mug": 0.8, "bowl": 0.2}, "red", (slice(0, 2), slice(0, 2)))
    assert fits(mug, Description("mug")) and fits(mug, Description("mug", "red"))
    assert not fits(mug, Description("mug", "blue")) and not fits(mug, Description("plate"))
    # two touching objects share one group of cells: each class keeps a share of it
    pair = _object({"mug": 0.5, "plate": CLASS_FIT, "bowl": 0.25 - 1e-6}, "red", (slice(0, 2), slice(0, 2)))
    assert fits(pair, Description("plate")) and not fits(pair, Description("bowl"))


def test_the_grasp_is_kept_off_the_objects_no_description_fits() -> None:
    mug = _object({"mug": 0.9, "bowl": 0.1}, "red", (slice(0, 2), slice(0, 2)))
    bowl = _object({"mug": 0.1, "bowl": 0.9}, "white", (slice(3, 5), slice(3, 5)))
    blue_mug = _object({"mug": 0.9, "bowl": 0.1}, "blue", (slice(0, 2), slice(4, 6)))
    kept_off = unnamed_cells([mug, bowl, blue_mug], [Description("mug", "red")])
    assert kept_off is not None
    assert (kept_off == (bowl.cells | blue_mug.cells)).all()
    assert not kept_off[5, 0]  # a cell no object covers stays open (a thin object the map hardly raises)
    # nothing kept off: no description, no object, or no object fitting any description (the maps know less
    # than the network's choice)
    assert unnamed_cells([mug, bowl], []) is None
    assert unnamed_cells([], [Description("mug")]) is None
    assert unnamed_cells([mug, bowl], [Description("plate")]) is None

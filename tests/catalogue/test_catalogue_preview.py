"""Preview rendering: objects are in the picture, in their colour."""

from __future__ import annotations

import numpy as np
import pytest

from samplehd.catalogue import ObjectInstance
from samplehd.catalogue.preview import catalogue_table, render_instances


@pytest.mark.render
def test_preview_shows_the_objects_in_colour() -> None:
    img = render_instances(
        [
            ObjectInstance("bowl", "round", "blue", "plastic", "medium"),
            ObjectInstance("mug", "straight", "red", "ceramic", "medium"),
        ],
        200,
        150,
    )
    assert img.shape == (150, 200, 3) and img.dtype == np.uint8
    blue = (img[..., 2] > 120) & (img[..., 0] < 60)
    red = (img[..., 0] > 120) & (img[..., 1] < 60) & (img[..., 2] < 60)
    assert blue.sum() > 300 and red.sum() > 300
    # blue bowl left of the red mug: objects are laid out left to right
    assert np.nonzero(blue)[1].mean() < np.nonzero(red)[1].mean()


@pytest.mark.render
def test_preview_is_deterministic() -> None:
    inst = [ObjectInstance("chopping_board", "paddle", "brown", "wooden", "small")]
    np.testing.assert_array_equal(render_instances(inst, 96, 64), render_instances(inst, 96, 64))


@pytest.mark.render
@pytest.mark.slow
def test_catalogue_table_covers_every_class() -> None:
    sheet = catalogue_table(cell=(64, 48), classes=["mug", "knife"])
    assert sheet.size == (110 + 6 * 64, 22 + 2 * 48)

"""One image request: ImageSpec checks what the renderer would refuse, before any GL context is made."""

from __future__ import annotations

import pytest

from samplehd.dataset.render import RENDER_MODES, RenderConfig
from samplehd.errors import RenderError
from samplehd.render.image_spec import PRESET_NAMES, ImageSpec
from samplehd.render.renderer import PRESETS


def test_the_preset_names_are_one_list() -> None:
    assert PRESET_NAMES == tuple(PRESETS) == ("fast", "hd", "photo")
    assert RENDER_MODES == ("none", *PRESET_NAMES)


def test_an_image_request_is_normalised_and_knows_its_shapes() -> None:
    spec = ImageSpec(64, 48, "hd", ["operator", "wrist"], ["rgb", "depth"])
    assert spec.cameras == ("operator", "wrist") and spec.modalities == ("rgb", "depth")
    assert spec.shape("rgb") == (48, 64, 3) and spec.shape("depth") == (48, 64)
    assert hash(spec) == hash(ImageSpec(64, 48, "hd", ("operator", "wrist"), ("rgb", "depth")))


@pytest.mark.parametrize("kwargs, message", [
    ({"preset": "ultra"}, "unknown render preset 'ultra'; valid: fast, hd, photo"),
    ({"width": 4}, "resolution 4x180 is invalid"),
    ({"modalities": ("rgb", "normals")}, "unknown modalities ['normals']"),
    ({"cameras": "scene"}, "cameras 'scene': must be a list of names"),
])
def test_a_bad_request_is_the_renderers_one_line_error(kwargs: dict, message: str) -> None:
    with pytest.raises(RenderError) as err:
        ImageSpec(**kwargs)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_a_render_config_makes_its_request() -> None:
    cfg = RenderConfig("fast", 128, 72, ("scene",), ("rgb", "segmentation"))
    assert cfg.image == ImageSpec(128, 72, "fast", ("scene",), ("rgb", "segmentation"))
    with pytest.raises(ValueError, match="requests no images"):
        RenderConfig("none").image  # noqa: B018 - the property raises


@pytest.mark.render
def test_a_request_renders_every_camera_in_every_modality(world) -> None:
    model, data = world
    spec = ImageSpec(48, 32, "fast", ("operator", "wrist"), ("rgb", "depth"))
    images = spec.render(model, data)
    assert list(images) == ["operator", "wrist"]
    for camera in spec.cameras:
        assert list(images[camera]) == ["rgb", "depth"]
        for modality in spec.modalities:
            assert images[camera][modality].shape == spec.shape(modality)
    assert images["operator"]["rgb"].std() > 0  # a picture, not a blank buffer

"""Scene parsing: CLEVR-layout scenes read, malformed ones fail naming file, scene and field."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest

from samplehd.errors import SceneError
from samplehd.language.instruction_file import generate_instruction_file
from samplehd.language.scene import Scene, load_scenes, parse_scene
from samplehd.language.synthetic import synthetic_scene


@pytest.fixture()
def scene_dict() -> dict:
    return synthetic_scene(np.random.default_rng(3), 4, image_index=9)


def test_parse_and_round_trip(scene_dict: dict) -> None:
    scene = parse_scene(scene_dict)
    assert len(scene) == 4 and scene.image_index == 9
    again = Scene.from_dict(scene.to_dict())
    assert again == scene


def test_footprint_rectangle_fields_round_trip(scene_dict: dict) -> None:
    obj = scene_dict["objects"][0]
    x, y, z = obj["3d_coords"]
    obj["bbox"].update(min=[x - 0.04, y - 0.03, z], max=[x + 0.06, y + 0.03, z + 0.1])
    obj["footprint_half_extents"] = [0.05, 0.03]
    scene = parse_scene(scene_dict)
    parsed = scene.objects[0]
    assert parsed.rotation == obj["rotation"]
    assert parsed.yaw == pytest.approx(np.radians(obj["rotation"]))
    assert parsed.footprint_centre == pytest.approx((x + 0.01, y))
    assert parsed.footprint_half == (0.05, 0.03)
    assert Scene.from_dict(scene.to_dict()) == scene
    assert scene.objects[1].footprint_half_extents is None  # optional: older files lack it


def test_missing_relationships_are_computed(scene_dict: dict) -> None:
    without = {k: v for k, v in scene_dict.items() if k != "relationships"}
    assert parse_scene(without).relationships == parse_scene(scene_dict).relationships


@pytest.mark.parametrize(
    ("edit", "field"),
    [
        (lambda s: s["objects"][1].pop("name") and s["objects"][1].pop("shape"), "objects[1]: name"),
        (lambda s: s["objects"][2].update(table_part=["middle"]), "objects[2]: table_part"),
        (lambda s: s["objects"][0].update({"3d_coords": [0, "x", 1]}), "objects[0]: 3d_coords"),
        (lambda s: s["objects"][3]["affordances"].update(graspable="yes"), "objects[3]: affordances.graspable"),
        (lambda s: s["objects"][0].pop("bbox"), "objects[0]: bbox.extents"),
        (lambda s: s["relationships"]["left"].pop(), "relationships.left"),
        (lambda s: s["relationships"]["front"][0].append(0), "relationships.front[0]"),
        (lambda s: s.update(objects=None), "objects"),
        (lambda s: s["objects"][0].update(rotation="north"), "objects[0]: rotation"),
        (lambda s: s["objects"][0].update(rotation=True), "objects[0]: rotation"),
        (lambda s: s["objects"][0].update(rotation=float("inf")), "objects[0]: rotation"),
        (lambda s: s["objects"][1]["bbox"].update(min=[0, 0, 0]), "objects[1]: bbox.max"),
        (lambda s: s["objects"][1]["bbox"].update(min=[0, "a", 0], max=[1, 1, 1]), "objects[1]: bbox.min"),
        (lambda s: s["objects"][1]["bbox"].update(min=[0, 0.2, 0], max=[1, 0.1, 1]), "objects[1]: bbox.min"),
        (lambda s: s["objects"][2].update(footprint_half_extents=[0.05]), "objects[2]: footprint_half_extents"),
        (lambda s: s["objects"][2].update(footprint_half_extents=[0.05, 0.0]), "objects[2]: footprint_half_extents"),
        (lambda s: s["objects"][2].update(footprint_half_extents="wide"), "objects[2]: footprint_half_extents"),
    ],
)
def test_malformed_scene_names_file_scene_and_field(tmp_path: Path, scene_dict: dict, edit, field: str) -> None:
    good = copy.deepcopy(scene_dict)
    bad = copy.deepcopy(scene_dict)
    edit(bad)
    path = tmp_path / "scenes.json"
    path.write_text(json.dumps({"info": {"version": "x"}, "scenes": [good, bad]}))
    info, scenes = load_scenes(tmp_path)
    assert info == {"version": "x"}
    with pytest.raises(SceneError) as err:
        generate_instruction_file(scenes, source=str(path))
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: scene 1: {field}")


def test_load_scenes_errors(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match="no such file"):
        load_scenes(tmp_path / "nope.json")
    with pytest.raises(SceneError, match="no scenes.json"):
        load_scenes(tmp_path)
    (tmp_path / "broken.json").write_text("[1, 2")
    with pytest.raises(SceneError, match="invalid JSON at line"):
        load_scenes(tmp_path)


def test_folder_of_single_scene_files(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    for i in range(3):
        (tmp_path / f"scene_{i}.json").write_text(json.dumps(synthetic_scene(rng, 3, image_index=i)))
    _, scenes = load_scenes(tmp_path)
    assert [s["image_index"] for s in scenes] == [0, 1, 2]

"""ObjectInstance: validation and JSON round trip; object facts."""

from __future__ import annotations

import json

import numpy as np
import pytest

from samplehd.catalogue import GRIPPER_STROKE, ObjectInstance, object_facts
from samplehd.errors import AssetError


def test_round_trip() -> None:
    inst = ObjectInstance("mug", "tapered", "red", "ceramic", "large")
    d = json.loads(json.dumps(inst.to_dict()))
    assert d == {"class_name": "mug", "variant": "tapered", "colour": "red", "material": "ceramic", "size": "large"}
    assert ObjectInstance.from_dict(d) == inst
    assert hash(ObjectInstance.from_dict(d)) == hash(inst)


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        ({"class_name": "mugg", "variant": "x", "colour": "red", "material": "ceramic", "size": "small"},
         "unknown object class 'mugg'; valid classes are baking_tray"),
        ({"class_name": "mug", "variant": "round", "colour": "red", "material": "ceramic", "size": "small"},
         "unknown variant 'round' of class 'mug'; valid variants are shopvrb1"),  # the default catalogue's
        ({"class_name": "mug", "variant": "straight", "colour": "pink", "material": "ceramic", "size": "small"},
         "unknown colour 'pink'"),
        ({"class_name": "mug", "variant": "straight", "colour": "red", "material": "stone", "size": "small"},
         "unknown material 'stone'"),
        ({"class_name": "mug", "variant": "straight", "colour": "red", "material": "ceramic", "size": "huge"},
         "unknown size 'huge'; valid sizes are small, medium, large"),
        ({"class_name": "mug", "variant": "straight", "colour": "transparent", "material": "ceramic", "size": "small"},
         "colour 'transparent' cannot be combined with material 'ceramic'"),
        ({"class_name": "mug", "variant": "straight", "colour": "red", "material": "ceramic"},
         "missing key 'size'"),
        ({"class_name": "mug", "variant": "straight", "colour": "red", "material": "ceramic", "size": "small",
          "shape": "x"}, "unknown key 'shape'"),
        ({"class_name": "mug", "variant": "straight", "colour": 3, "material": "ceramic", "size": "small"},
         "ObjectInstance.colour: expected a non-empty string"),
    ],
)  # fmt: skip
def test_from_dict_errors(data: dict, expected: str) -> None:
    with pytest.raises(AssetError) as info:
        ObjectInstance.from_dict(data)
    assert expected in str(info.value)
    assert "\n" not in str(info.value)


def test_facts_of_a_mug() -> None:
    f = object_facts(ObjectInstance("mug", "straight", "white", "ceramic", "medium"))
    assert f.affordances.container and f.affordances.handle_pickable
    assert f.grasps[0].name == "handle" and f.grasps[0].position[0] > 0.04  # handle on +x
    assert f.grasps[0] in f.graspable_sites and f.grasps[0].width < GRIPPER_STROKE
    assert 0.03 < f.opening.radius < 0.04 and 0.08 < f.opening.depth < 0.095
    assert f.weight == "medium" and 0.2 < f.mass < 0.4
    assert f.height == pytest.approx(0.095, abs=1e-4)
    d = f.to_dict()
    json.dumps(d)
    assert d["instance"]["class_name"] == "mug"


def test_facts_of_flat_objects() -> None:
    board = object_facts(ObjectInstance("chopping_board", "rectangular", "brown", "wooden", "medium"))
    assert board.top.flat and board.affordances.stackable_on
    assert board.top.height == pytest.approx(board.height)
    plate = object_facts(ObjectInstance("plate", "dinner", "white", "ceramic", "medium"))
    assert plate.top.flat and plate.top.round and plate.top.height < 0.01
    fork = object_facts(ObjectInstance("fork", "dinner", "metallic", "metal", "medium"))
    assert not fork.top.flat and fork.opening is None


def test_package_docstring_example_runs() -> None:
    import samplehd.catalogue as catalogue

    lines = []
    for line in catalogue.__doc__.split("::", 1)[1].splitlines()[1:]:
        if line.strip() and not line.startswith("    "):
            break
        lines.append(line[4:])
    namespace: dict = {}
    exec(compile("\n".join(lines), "catalogue-doc", "exec"), namespace)
    assert namespace["model"].nbody == 2 and namespace["facts"].mass > 0


def test_footprint_at_rotates_and_translates() -> None:
    f = object_facts(ObjectInstance("knife", "chef", "metallic", "metal", "medium"))
    poly = f.footprint_at(0.1, -0.2, np.pi / 2)  # blade along +x becomes along +y
    assert poly[:, 1].max() - poly[:, 1].min() == pytest.approx(f.extents[0], abs=1e-6)
    assert poly[:, 0].max() - poly[:, 0].min() == pytest.approx(f.extents[1], abs=1e-6)
    assert poly.mean(axis=0)[0] == pytest.approx(0.1 - np.mean(np.asarray(f.footprint_polygon)[:, 1]), abs=1e-6)

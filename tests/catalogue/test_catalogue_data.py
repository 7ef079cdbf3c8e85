"""The data files: vocabulary, classes, variants, menus, and one-line errors for malformed files."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from samplehd.catalogue import load_catalogue, read_catalogue
from samplehd.catalogue.loader import DATA_DIR
from samplehd.catalogue.menu import apply_menu_overrides
from samplehd.errors import AssetError, SamplehdError

CLASSES = [
    "baking_tray", "bowl", "chopping_board", "food_box", "fork", "glass", "knife", "mug",
    "pan", "plate", "scissors", "soda_can", "spoon", "thermos", "wine_glass",
]  # fmt: skip
COLOURS = ["black", "blue", "brown", "cyan", "green", "metallic", "purple", "red", "transparent", "white", "yellow"]
MATERIALS = ["ceramic", "glass", "metal", "plastic", "rubber", "wooden"]
# These tests hold the procedural catalogue's own data (its variants and menus); shop-vrb's are in
# test_shop_vrb.py.
PROCEDURAL = "procedural"


def test_vocabulary_matches_sample_hd() -> None:
    cat = load_catalogue(name=PROCEDURAL)
    assert sorted(cat.classes) == CLASSES
    assert sorted(cat.colours) == COLOURS
    assert sorted(cat.materials) == MATERIALS
    assert list(cat.sizes) == ["small", "medium", "large"]
    assert [w.name for w in cat.weights] == ["light", "medium", "heavy"]
    assert cat.sizes["small"].scale < cat.sizes["medium"].scale == 1.0 < cat.sizes["large"].scale


def test_every_class_has_two_variants_and_a_usable_menu() -> None:
    cat = load_catalogue(name=PROCEDURAL)
    for cls in cat.classes.values():
        assert len(cls.variants) >= 2, cls.name
        for v in cls.variants.values():
            assert v.menu.pairs, (cls.name, v.name)
            for c, m in v.menu.pairs:
                assert cat.compatible(c, m)


def test_menu_rules() -> None:
    cat = load_catalogue(name=PROCEDURAL)
    assert cat.classes["knife"].variants["chef"].menu.material == ("metal",)
    for cls in cat.classes.values():
        for v in cls.variants.values():
            for c, m in v.menu.pairs:
                if c == "transparent":
                    assert m == "glass"
                if c == "metallic":
                    assert m == "metal"
    assert not cat.compatible("transparent", "ceramic")
    assert cat.compatible("transparent", "glass")
    # every material appears in at least one menu, so the contact sheet shows all of them
    used = {m for cls in cat.classes.values() for v in cls.variants.values() for m in v.menu.material}
    assert used == set(MATERIALS)


def test_materials_have_look_and_physics() -> None:
    cat = load_catalogue(name=PROCEDURAL)
    assert cat.materials["glass"].alpha < 1.0
    assert cat.materials["wooden"].texture == "wood_grain"
    assert cat.materials["metal"].density > cat.materials["ceramic"].density > cat.materials["wooden"].density
    assert cat.materials["rubber"].friction[0] > cat.materials["metal"].friction[0]


def test_weight_classes() -> None:
    cat = load_catalogue(name=PROCEDURAL)
    assert cat.weight_class(0.05) == "light"
    assert cat.weight_class(0.3) == "medium"
    assert cat.weight_class(2.0) == "heavy"


# ----- malformed files: one line naming the file and the field
def _copy_data(tmp_path: Path) -> Path:
    d = tmp_path / "data"
    shutil.copytree(DATA_DIR, d)
    return d


def _edit(path: Path, fn) -> None:  # noqa: ANN001
    doc = json.loads(path.read_text())
    fn(doc)
    path.write_text(json.dumps(doc))


@pytest.mark.parametrize(
    ("file", "edit", "expected"),
    [
        ("colours.json", lambda d: d["colours"]["red"].update(rgba=[1, 0]), "colours.red.rgba"),
        ("colours.json", lambda d: d["colours"]["red"].update(rgba=[1, 0, 0, 2]), "colours.red.rgba[3]"),
        ("colours.json", lambda d: d["colours"]["red"].update(shade=1), "colours.red.shade: unknown key"),
        ("colours.json", lambda d: d.update(format=7), "format: unsupported format"),
        ("materials.json", lambda d: d["materials"]["metal"]["physics"].update(density=-1), "physics.density"),
        ("materials.json", lambda d: d["materials"]["glass"]["look"].update(texture="marble"), "valid values are"),
        ("materials.json", lambda d: d["materials"]["glass"].pop("physics"), "materials.glass.physics: missing"),
        ("sizes.json", lambda d: d["sizes"]["large"].update(scale="big"), "sizes.large.scale"),
        ("sizes.json", lambda d: d["weights"]["heavy"].update(max_mass=0.1), "weights.heavy.max_mass"),
        ("classes.json", lambda d: d["classes"]["mug"]["menu"].update(colour=["pink"]), "mug.menu.colour[0]"),
        ("classes.json", lambda d: d["classes"]["mug"]["menu"].update(material=["stone"]), "valid values are ceramic"),
        ("classes.json", lambda d: d["classes"]["knife"]["menu"].update(colour=["transparent"]), "fits none"),
        ("classes.json", lambda d: d["classes"]["mug"].update(colour="red"), "classes.mug.colour: unknown key"),
        ("classes.json", lambda d: d["classes"]["mug"]["affordances"].pop("container"), "affordances.container"),
        (
            "classes.json",
            lambda d: d["classes"]["mug"]["variants"]["straight"]["geometry"].update(kind="blob"),
            "variants.straight.geometry.kind: unknown value 'blob'",
        ),
        (
            "classes.json",
            lambda d: d["classes"]["glass"]["variants"]["tall"]["geometry"]["profile"][1].__setitem__(2, 0.5),
            "profile[1]: r_inner",
        ),
        (
            "classes.json",
            lambda d: d["classes"]["plate"]["variants"]["dinner"]["geometry"].update(radius=0.1),
            "geometry.radius: unknown key",
        ),
        ("classes.json", lambda d: d["classes"].update({"Bad Name": d["classes"]["mug"]}), "invalid name"),
    ],
)
def test_malformed_files_give_one_line_errors(tmp_path: Path, file: str, edit, expected: str) -> None:  # noqa: ANN001
    data = _copy_data(tmp_path)
    _edit(data / file, edit)
    with pytest.raises(AssetError) as info:
        read_catalogue(data, name=PROCEDURAL)
    msg = str(info.value)
    assert "\n" not in msg
    assert file in msg
    assert expected in msg, msg


def test_invalid_json_and_missing_file(tmp_path: Path) -> None:
    data = _copy_data(tmp_path)
    (data / "sizes.json").write_text("{ not json")
    with pytest.raises(AssetError, match=r"sizes.json: invalid JSON at line 1"):
        read_catalogue(data, name=PROCEDURAL)
    (data / "sizes.json").unlink()
    with pytest.raises(SamplehdError, match=r"sizes.json: cannot read"):
        read_catalogue(data, name=PROCEDURAL)


# ----- per-run menu overrides
def test_menu_overrides_apply_from_general_to_specific() -> None:
    cat = apply_menu_overrides(
        {"*": {"size": ["medium"]}, "mug": {"colour": ["red", "transparent"]}, "mug.tapered": {"material": ["glass"]}},
        load_catalogue(name=PROCEDURAL),
    )
    tapered = cat.classes["mug"].variants["tapered"].menu
    straight = cat.classes["mug"].variants["straight"].menu
    assert tapered.size == ("medium",) and tapered.material == ("glass",)
    assert set(tapered.pairs) == {("red", "glass"), ("transparent", "glass")}
    assert straight.colour == ("red", "transparent") and "ceramic" in straight.material
    assert cat.classes["bowl"].variants["round"].menu.size == ("medium",)
    original = load_catalogue(name=PROCEDURAL).classes["bowl"].variants["round"].menu
    assert original.size != ("medium",)  # the catalogue itself is untouched
    assert randomised_props(tapered) == ("colour",)


def randomised_props(menu) -> tuple[str, ...]:  # noqa: ANN001
    return menu.randomised()


@pytest.mark.parametrize(
    ("overrides", "expected"),
    [
        ({"mugg": {"size": ["small"]}}, "mugg: unknown class 'mugg'"),
        (
            {"mug.handled": {"size": ["small"]}},
            "unknown variant 'handled' of mug; valid variants are straight, tapered",
        ),
        ({"mug": {"color": ["red"]}}, "mug.color: unknown key; valid keys are colour, material, size"),
        ({"mug": {"size": ["huge"]}}, "mug.size[0]: unknown value 'huge'; valid values are small, medium, large"),
        ({"mug": {}}, "mug: empty override"),
        ({"knife": {"colour": ["transparent"]}}, "colour 'transparent' fits none of the materials ['metal']"),
        ({"mug": {"size": []}}, "mug.size: expected a list of 1..any elements"),
    ],
)
def test_malformed_menu_overrides(overrides: dict, expected: str) -> None:
    with pytest.raises(AssetError) as info:
        apply_menu_overrides(overrides, load_catalogue(name=PROCEDURAL), source="run.json")
    assert "\n" not in str(info.value)
    assert str(info.value).startswith("run.json: ")
    assert expected in str(info.value)

"""Referring expressions: unique, minimal, natural word order, plurals, no silly repetitions."""

from __future__ import annotations

from itertools import combinations, product

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from samplehd.language.descriptions import Description, SceneDescriber, render_description
from samplehd.language.lexicon import default_lexicon
from samplehd.language.scene import Scene, parse_scene
from samplehd.language.synthetic import synthetic_scene


def _obj(name: str, colour: str, material: str, size: str, xy: tuple[float, float], parts: list[str]) -> dict:
    return {
        "name": name,
        "colour": colour,
        "material": material,
        "size": size,
        "table_part": parts,
        "3d_coords": [xy[0], xy[1], 0.8],
        "bbox": {"extents": [0.1, 0.1, 0.1]},
    }


def _scene(*objects: dict) -> Scene:
    return parse_scene({"objects": list(objects)})


def _shorter_unique_exists(describer: SceneDescriber, index: int, modifiers: int) -> bool:
    """Brute force: is there an allowed attribute description with fewer modifiers?"""
    obj = describer.scene.objects[index]
    options = describer.modifier_options(index)
    for size in range(modifiers):
        for kinds in combinations(options, size):
            for values in product(*(options[k] for k in kinds)):
                filters = tuple(zip(kinds, values, strict=True))
                if not describer._allowed(filters):
                    continue
                d = Description.of((*filters, ("name", obj.name)))
                if describer.matches(d) == (index,):
                    return True
    return False


def _check_scene(scene: Scene) -> None:
    describer = SceneDescriber(scene)
    for i in range(len(scene.objects)):
        found = describer.unique_descriptions(i)
        for d in found:
            assert describer.matches(d) == (i,), render_description(d)
            assert d.value("name") == scene.objects[i].name
            if d.anchor is None:
                assert not _shorter_unique_exists(describer, i, d.modifier_count), render_description(d)
            else:
                # a relation is used only when attributes cannot single the object out
                assert not describer.attribute_descriptions(i)
                assert describer.matches(d.anchor) != (i,)
        if not found:
            assert not describer.attribute_descriptions(i)
    for d in describer.set_descriptions():
        assert len(describer.matches(d)) >= 2


def test_every_description_is_unique_and_minimal(scenes: list[Scene]) -> None:
    for scene in scenes:
        _check_scene(scene)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 14))
def test_unique_and_minimal_property(seed: int, n: int) -> None:
    _check_scene(parse_scene(synthetic_scene(np.random.default_rng(seed), n)))


def test_single_class_is_named_alone() -> None:
    scene = _scene(
        _obj("mug", "red", "ceramic", "small", (0, -0.2), ["left"]),
        _obj("bowl", "blue", "ceramic", "small", (0, 0.2), ["right"]),
    )
    d = SceneDescriber(scene).unique_descriptions(0)
    assert [render_description(x) for x in d] == ["the mug"]


def test_shortest_modifier_and_word_order() -> None:
    scene = _scene(
        _obj("mug", "red", "ceramic", "small", (0, -0.2), ["left"]),
        _obj("mug", "red", "ceramic", "large", (0, 0.2), ["right"]),
        _obj("mug", "red", "plastic", "small", (0.1, 0.2), ["right", "front"]),
        _obj("mug", "blue", "ceramic", "small", (0.1, 0.0), ["front"]),
    )
    describer = SceneDescriber(scene)
    texts = [render_description(d) for d in describer.unique_descriptions(0)]
    # one modifier never suffices; two do: size+colour+material order, table part after the noun
    assert "the small red ceramic mug" not in texts
    assert "the mug on the left" in texts
    assert (
        render_description(
            Description.of([("name", "mug"), ("material", "ceramic"), ("colour", "red"), ("size", "small")])
        )
        == "the small red ceramic mug"
    )


def test_relation_when_attributes_cannot_tell_apart() -> None:
    twin = ("mug", "white", "ceramic", "medium")
    scene = _scene(
        _obj(*twin, (0.0, -0.10), []),
        _obj(*twin, (0.0, 0.10), []),
        _obj("bowl", "blue", "glass", "large", (0.0, 0.0), []),
    )
    describer = SceneDescriber(scene)
    assert describer.attribute_descriptions(0) == ()
    texts = [render_description(d) for d in describer.unique_descriptions(0)]
    assert "the mug that is left of the bowl" in texts
    assert all(describer.matches(d) == (0,) for d in describer.unique_descriptions(0))


def test_indistinguishable_objects_get_no_description() -> None:
    twin = ("fork", "metallic", "metal", "small")
    scene = _scene(_obj(*twin, (0.0, 0.0), []), _obj(*twin, (0.0, 0.0), []))
    assert SceneDescriber(scene).unique_descriptions(0) == ()


def test_no_glass_glass_and_no_metallic_metal() -> None:
    scene = _scene(
        _obj("glass", "transparent", "glass", "small", (0, -0.2), ["left"]),
        _obj("glass", "transparent", "plastic", "small", (0, 0.2), ["right"]),
        _obj("fork", "metallic", "metal", "small", (0.1, -0.2), ["left"]),
        _obj("fork", "metallic", "plastic", "small", (0.1, 0.2), ["right"]),
        _obj("fork", "red", "metal", "small", (0.1, 0.0), []),
    )
    describer = SceneDescriber(scene)
    all_text = [render_description(d) for i in range(5) for d in describer.unique_descriptions(i)]
    all_text += [render_description(d, plural=True) for d in describer.set_descriptions()]
    assert all_text
    assert not any("glass glass" in t for t in all_text)
    assert not any("metallic metal" in t for t in all_text)
    assert "the plastic glass" in [render_description(d) for d in describer.unique_descriptions(1)]


@pytest.mark.parametrize(
    ("name", "singular", "plural"),
    [
        ("glass", "glass", "glasses"),
        ("knife", "knife", "knives"),
        ("scissors", "scissors", "scissors"),
        ("wine_glass", "wine glass", "wine glasses"),
        ("baking_tray", "baking tray", "baking trays"),
        ("food_box", "food box", "food boxes"),
        ("soda_can", "soda can", "soda cans"),
        ("chopping_board", "chopping board", "chopping boards"),
        ("thermos", "thermos", "thermoses"),
        ("teapot", "teapot", "teapots"),
        ("coffee_press", "coffee press", "coffee presses"),
        ("cherry", "cherry", "cherries"),
    ],
)
def test_nouns_and_plurals(name: str, singular: str, plural: str) -> None:
    lex = default_lexicon()
    assert lex.noun(name) == singular
    assert lex.noun(name, plural=True) == plural


def test_set_descriptions_render_plural() -> None:
    scene = _scene(
        _obj("knife", "red", "metal", "small", (0, -0.2), ["left"]),
        _obj("knife", "red", "metal", "large", (0, 0.2), ["right"]),
        _obj("scissors", "red", "plastic", "small", (0.1, 0.2), ["right"]),
        _obj("scissors", "blue", "plastic", "small", (0.1, -0.2), ["left"]),
    )
    sets = {render_description(d, plural=True, determiner="all the") for d in SceneDescriber(scene).set_descriptions()}
    assert "all the knives" in sets
    assert "all the scissors" in sets
    assert "all the red objects" in sets
    assert "all the objects that are on the right" in sets


def test_scissors_take_plural_agreement_in_relative_clause() -> None:
    twin = ("scissors", "red", "metal", "small")
    scene = _scene(
        _obj(*twin, (0.0, -0.1), []),
        _obj(*twin, (0.0, 0.1), []),
        _obj("plate", "white", "ceramic", "large", (0.0, 0.0), []),
    )
    texts = [render_description(d) for d in SceneDescriber(scene).unique_descriptions(0)]
    assert "the scissors that are left of the plate" in texts


def test_description_round_trip() -> None:
    d = Description.of([("name", "mug"), ("colour", "red")], "left", Description.of([("name", "bowl")]))
    assert Description.from_dict(d.to_dict()) == d


def test_matching_combinations_are_those_of_itertools_that_share_two_objects() -> None:
    from samplehd.language.descriptions import _matching_combinations

    rng = np.random.default_rng(5)
    for _ in range(200):
        n, full = int(rng.integers(0, 10)), 0b111111
        keys = [("colour", str(i)) for i in range(n)]
        masks = [int(m) for m in rng.integers(0, 64, n)]
        for size in (1, 2, 3):
            expected = []
            for combo in combinations(range(n), size):
                m = full
                for i in combo:
                    m &= masks[i]
                if m.bit_count() >= 2:
                    expected.append((tuple(keys[i] for i in combo), m))
            assert list(_matching_combinations(keys, masks, size, full)) == expected

"""Generalisation levels: which episodes training for each level leaves out (samplehd.language.levels)."""

from __future__ import annotations

import pytest

from samplehd.errors import ConfigError
from samplehd.language.levels import LEVELS, episode_level, held_out_for, held_out_instruction, text_variants


def _pick_up(text: str) -> dict:
    return {"instruction": text, "template_filename": "pick_up.json", "template_index": 0, "targets": [0]}


SEEN, PARAPHRASE = "Pick up the blue mug.", "Take hold of the blue mug and lift it up."
MUG, RED_MUG, FOOD_BOX = ({"objects": [{"name": n, "colour": c}]}
                          for n, c in (("mug", "blue"), ("mug", "red"), ("food_box", "blue")))


@pytest.mark.parametrize(("text", "scene", "left_out_by"), [
    (SEEN, MUG, set()),
    (SEEN, RED_MUG, {"L1", "L2"}),  # a held-out colour–class combination
    (PARAPHRASE, MUG, {"L1", "L3"}),  # the template's held-out text variant
    (SEEN, FOOD_BOX, {"L1", "L4"}),  # a held-out class
    (PARAPHRASE, FOOD_BOX, {"L1", "L3", "L4"}),
])
def test_training_for_a_level_leaves_out_what_it_holds_out(text: str, scene: dict, left_out_by: set) -> None:
    ins = _pick_up(text)
    assert {level for level in LEVELS if held_out_for(level, ins, scene)} == left_out_by
    # L1 trains on L1 episodes only; an episode of level Lk is left out of training for Lk.
    assert held_out_for("L1", ins, scene) == (episode_level(ins, scene) != "L1")
    assert held_out_for(episode_level(ins, scene), ins, scene) == bool(left_out_by)
    assert held_out_instruction(ins) == ("L3" in left_out_by)


def test_an_unknown_level_is_refused() -> None:
    with pytest.raises(ConfigError, match=r"level='L5': valid: L1, L2, L3, L4"):
        held_out_for("L5", _pick_up(SEEN), MUG)


@pytest.mark.parametrize(("filename", "text", "variants"), [
    ("put.json", "Put the mug in the bowl.", [0]),
    ("put.json", "Put the mug into the bowl.", [1]),
    ("put.json", "Place the mug inside the bowl.", [3]),  # "in" is not the start of "inside"
    ("stack.json", "Put the mug on top of the plate.", [0]),
    ("stack.json", "Place the mug on top of the plate.", [0, 1]),
    ("stack.json", "Stack the mug onto the plate.", [3]),  # "on" is not the start of "onto"
])
def test_a_template_word_matches_whole_words_only(filename: str, text: str, variants: list[int]) -> None:
    ins = {"instruction": text, "template_filename": filename, "template_index": 0, "targets": [0]}
    assert text_variants(ins) == variants
    assert held_out_instruction(ins) == (variants == [3])
    assert episode_level(ins, MUG) == ("L3" if variants == [3] else "L1")

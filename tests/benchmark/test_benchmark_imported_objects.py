"""The imported_objects axis: the task's objects first become objects of the shipped pack of imported
meshes, the instruction names them, and the oracle proves the variant through the env."""

from __future__ import annotations

import json
from pathlib import Path

from axis_variants import first_variant

from samplehd.benchmark.axes import AXES, AXIS_FIELDS, PHYSICAL_AXES, changed_fields, check_instruction_fits
from samplehd.benchmark.suite import SuiteBuildConfig, build_suite
from samplehd.catalogue.loader import pack_classes
from samplehd.envs.suite_file import SUITE_SPEC_DIR, read_suite
from samplehd.language.lexicon import default_lexicon

# Twelve oracle-proven episodes of an earlier build of smoke, which the tests of the axes are written on
TWINS = Path(__file__).parent / "data" / "twins.json"


def test_imported_objects_replace_the_task_objects_first_by_pack_classes_and_keep_the_others() -> None:
    twin = read_suite(TWINS).episodes[4].to_dict()  # "Please pick up the mug." among three objects
    objects = twin["scene"]["objects"]
    pack = set(pack_classes())
    for strength in (1, 3, 5):
        variant = first_variant(twin, "imported_objects", strength)
        # a function of the seed, twin, strength and attempt
        assert variant == first_variant(twin, "imported_objects", strength)
        replaced = min(strength, len(objects))
        new = variant["scene"]["objects"]
        assert len(new) == len(objects)
        kept = [o for i, o in enumerate(objects) if i not in twin["targets"]][:len(objects) - replaced]
        assert new[:len(kept)] == kept  # the others keep their poses, in their order
        assert {o["instance"]["class_name"] for o in new[len(kept):]} <= pack
        [target] = [new[t]["instance"]["class_name"] for t in variant["targets"]]
        assert target in pack and variant["family"] == twin["family"] and variant["level"] == twin["level"]
        assert f"the {default_lexicon().noun(target)}" in variant["instruction"].lower()
        check_instruction_fits(variant)  # the env's own check: the text's program picks the targets
        assert changed_fields(twin, variant) - {"axis", "strength", "twin", "id"} <= set(
            AXIS_FIELDS["imported_objects"])
    assert "imported_objects" in PHYSICAL_AXES and list(AXES)[-1] == "imported_objects"


def test_plus_lists_imported_objects_last_so_earlier_variants_keep_their_ids() -> None:
    axes = json.loads((SUITE_SPEC_DIR / "plus.json").read_text())["axes"]
    assert axes == list(AXES) and axes[-1] == "imported_objects"


def test_the_oracle_proves_an_imported_objects_variant_through_the_env() -> None:
    """The pick-up twin of a procedural scene at strength 3: the variant is proven by the oracle through
    the env (or left out after its attempts, counted), and a second build gives the same bytes."""
    config = SuiteBuildConfig(base=str(TWINS), base_per_cell=1, base_families=("pick_up",),
                              base_catalogues=("procedural",), axes=("imported_objects",), strengths=(3,))
    suite = build_suite("imported", config)
    [twin, variant] = suite.episodes
    assert variant.axis == "imported_objects" and variant.twin == twin.id and variant.oracle_steps > 0
    held = [o["instance"]["class_name"] for o in variant.to_dict()["scene"]["objects"]]
    assert set(held[len(held) - 3:]) <= set(pack_classes())
    assert json.dumps(build_suite("imported", config).to_dict()) == json.dumps(suite.to_dict())

"""The textures axis and the language axes split by part of speech (verbs, nouns, unseen synonyms)."""

from __future__ import annotations

import re
from pathlib import Path

import mujoco
import numpy as np
import pytest
from axis_variants import first_variant

from samplehd.benchmark.axes import AXES, AXIS_FIELDS, PHYSICAL_AXES, check_instruction_fits, language_words, perturb
from samplehd.envs.suite_file import SuiteEpisode, read_suite
from samplehd.envs.tabletop import TabletopEnv
from samplehd.envs.tokens import SPECIAL_TOKENS, instruction_vocabulary, tokenize
from samplehd.language.templates import default_synonyms
from samplehd.render.renderer import SceneRenderer
from samplehd.scene.spec import SceneSpec, compile_scene
from samplehd.scene.textures import recolour

# Twelve oracle-proven episodes of an earlier build of smoke, which the tests of the axes are written on
TWINS = Path(__file__).parent / "data" / "twins.json"


def _texture(model: mujoco.MjModel, name: str) -> np.ndarray:
    tex = model.texture(name)
    w, h, c = int(tex.width[0]), int(tex.height[0]), int(tex.nchannel[0])
    return np.asarray(model.tex_data[int(tex.adr[0]):int(tex.adr[0]) + w * h * c]).reshape(-1, c)


def test_recolour_turns_hue_and_scales_saturation_and_value() -> None:
    img = np.array([[[200, 100, 50], [10, 10, 10], [255, 255, 255]]], dtype=np.uint8)
    assert np.array_equal(recolour(img), img)
    assert np.array_equal(recolour(img, 360.0), img)
    turned = recolour(img, 120.0)
    assert turned[0, 0].tolist() == [50, 200, 100]  # red-orange → green: the channels rotate
    assert turned[0, 1].tolist() == [10, 10, 10]  # greys have no hue
    grey = recolour(img, 0.0, saturation=0.0)
    assert grey[0, 0].tolist() == [200, 200, 200]
    assert recolour(img, 0.0, value=0.5)[0, 0].tolist() == [100, 50, 25]


def test_textures_change_the_table_and_wall_textures_by_the_documented_amounts_and_not_the_physics() -> None:
    twin = read_suite(TWINS).episodes[0].to_dict()
    clean_model, clean_data = compile_scene(SceneSpec.from_dict(twin["scene"]))
    assert "surfaces" not in SceneSpec.from_dict(twin["scene"]).to_dict()
    for strength in (1, 5):
        surfaces = perturb(twin, "textures", strength, seed=0)["scene"]["surfaces"]
        for part in ("table", "wall"):
            assert abs(surfaces[f"{part}_hue"]) == pytest.approx(30.0 * strength)
            factor = 1.0 + 0.4 * strength
            assert surfaces[f"{part}_saturation"] == pytest.approx(factor) or \
                surfaces[f"{part}_saturation"] == pytest.approx(1.0 / factor)
            assert abs(surfaces[f"{part}_value"] - 1.0) == pytest.approx(0.1 * strength)
    scene = SceneSpec.from_dict(perturb(twin, "textures", 5, seed=0)["scene"])
    assert scene.to_dict()["surfaces"] == surfaces
    model, data = compile_scene(scene)
    for name in ("wood", "plaster", "tiles"):
        clean, changed = _texture(clean_model, name), _texture(model, name)
        assert clean.shape == changed.shape and not np.array_equal(clean, changed), name
    assert np.array_equal(_texture(clean_model, "floor_tiles"), _texture(model, "floor_tiles"))
    np.testing.assert_array_equal(model.light_diffuse, clean_model.light_diffuse)
    for m, d in ((clean_model, clean_data), (model, data)):  # the same physics, bit for bit
        for _ in range(200):
            mujoco.mj_step(m, d)
    assert np.array_equal(clean_data.qpos, data.qpos) and np.array_equal(clean_data.qvel, data.qvel)


def _group_words(groups: tuple[str, ...]) -> set[str]:
    return {w for name in groups for w in default_synonyms()[name]}


def _swapped(a: str, b: str) -> tuple[set[str], set[str]]:
    """The words of ``a`` that ``b`` no longer has and the new words of ``b`` (lower case)."""
    wa, wb = (set(re.findall(r"[a-z]+", t.lower())) for t in (a, b))
    return wa - wb, wb - wa


def test_every_synonym_group_is_a_verb_or_a_noun_group() -> None:
    seen = language_words()["seen_groups"]
    assert set(seen["verbs"]) | set(seen["nouns"]) == set(default_synonyms())
    assert not set(seen["verbs"]) & set(seen["nouns"])


def test_verbs_and_nouns_vary_only_their_own_words() -> None:
    seen = language_words()["seen_groups"]
    verbs, nouns = (_group_words(seen[pos]) for pos in ("verbs", "nouns"))
    verb_words = {part for w in verbs for part in w.split()}
    changed = {"verbs": 0, "nouns": 0}
    for ep in read_suite(TWINS).episodes:
        twin = ep.to_dict()
        for axis, own, other in (("verbs", verb_words, nouns), ("nouns", nouns, verb_words)):
            for strength in (1, 5):
                text = perturb(twin, axis, strength, seed=0)["instruction"]
                gone, new = _swapped(twin["instruction"], text)
                assert gone <= own and new <= own and not (gone | new) & (other - own), (axis, text)
                changed[axis] += text != twin["instruction"]
    assert changed["verbs"] > 0 and changed["nouns"] > 0


def test_unseen_synonyms_are_words_the_generator_never_says() -> None:
    vocab = set(instruction_vocabulary()) - set(SPECIAL_TOKENS)
    unseen = language_words()["unseen"]
    for pos in ("verbs", "nouns"):
        for word, others in unseen[pos].items():
            assert set(tokenize(word)) <= vocab, word  # a word the generator says ...
            for other in others:
                assert not set(tokenize(other)) & vocab, (word, other)  # ... becomes words it never says


def test_unseen_synonyms_at_strength_5_leave_no_replaceable_word_and_the_env_reads_them_as_unknown() -> None:
    unseen = language_words()["unseen"]
    keys = {**unseen["verbs"], **unseen["nouns"]}
    pattern = re.compile(r"\b(" + "|".join(sorted(map(re.escape, keys), key=len, reverse=True)) + r")\b", re.I)
    suite = read_suite(TWINS)
    for ep in suite.episodes:
        text = perturb(ep.to_dict(), "unseen_synonyms", 5, seed=0)["instruction"]
        assert not pattern.search(text), text
    variant = SuiteEpisode.from_dict({"id": 1, **perturb(suite.episodes[4].to_dict(), "unseen_synonyms", 5, seed=0)})
    env = TabletopEnv(obs_mode="state")
    try:
        obs, info = env.reset(options=variant.reset_options())
        assert info["instruction"] == variant.instruction and info["task"] == suite.episodes[4].task
        assert SPECIAL_TOKENS["<UNK>"] in obs["instruction_tokens"].tolist()
    finally:
        env.close()


def test_the_new_axes_are_registered() -> None:
    assert {"textures", "verbs", "nouns", "unseen_synonyms"} <= set(AXES)


@pytest.mark.render
@pytest.mark.parametrize("preset", ["fast", pytest.param("photo", marks=pytest.mark.slow)])  # photo: minutes
def test_every_evaluation_renderer_shows_the_lighting_and_textures_axes(preset: str) -> None:
    if preset == "photo":
        pytest.importorskip("mitsuba", reason="the photo preset needs samplehd[photo]")
    twin = read_suite(TWINS).episodes[0].to_dict()
    lit, textured = (perturb(twin, axis, 5, seed=0) for axis in ("lighting", "textures"))
    assert lit["scene"]["lighting"]["intensity"] == pytest.approx(0.4)  # this draw dims every light
    frames = []
    for ep in (twin, lit, textured):
        model, data = compile_scene(SceneSpec.from_dict(ep["scene"]))
        with SceneRenderer(model, 96, 54, preset) as renderer:
            frames.append(renderer.render(data, "scene", ("rgb",))["rgb"].astype(float))
    clean, dim, recoloured = frames
    assert dim.mean() < 0.7 * clean.mean()
    table = (slice(30, 54), slice(10, 86))  # the table top fills the lower middle of the scene camera's view
    assert np.abs(recoloured[table] - clean[table]).mean() > 20.0


def test_unseen_objects_replace_the_task_objects_first_by_a_held_out_class_and_keep_the_others() -> None:
    twin = read_suite(TWINS).episodes[4].to_dict()  # "Please pick up the mug." among three objects
    objects = twin["scene"]["objects"]
    for strength in (1, 5):
        variant = first_variant(twin, "unseen_objects", strength)
        replaced = min(strength, len(objects))
        new = variant["scene"]["objects"]
        assert len(new) == len(objects)
        kept = [o for i, o in enumerate(objects) if i not in twin["targets"]][:len(objects) - replaced]
        assert new[:len(kept)] == kept  # the others keep their poses, in their order
        assert [o["instance"]["class_name"] for o in new[len(kept):]] == ["food_box"] * replaced
        assert [new[t]["instance"]["class_name"] for t in variant["targets"]] == ["food_box"]
        assert variant["family"] == twin["family"] and "food box" in variant["instruction"]
        check_instruction_fits(variant)  # the env's own check: the text's program picks the targets
        changed = {k for k in set(twin) | set(variant) if twin.get(k) != variant.get(k)}
        scene_changed = {f"scene.{k}" for k in twin["scene"] if twin["scene"][k] != variant["scene"][k]}
        assert (changed - {"scene", "axis", "strength", "twin", "id"}) | scene_changed <= set(
            AXIS_FIELDS["unseen_objects"])
    assert "unseen_objects" in PHYSICAL_AXES  # its variants are proven again by the oracle

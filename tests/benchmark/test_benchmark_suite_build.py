"""Building suites: a level's episode drawn from a scene's instructions, the candidate scenes shared by
a column of cells, and the shipped ``core`` specification and the suite built from it."""

from __future__ import annotations

import argparse
import json
from collections import Counter

import pytest

from samplehd.benchmark.evaluation import EpisodeRunner, EvalConfig, _with_slots_for
from samplehd.benchmark.levels import HELD_OUT_CLASSES, LEVELS, episode_level, instruction_at_level
from samplehd.benchmark.suite import Candidate, SuiteBuildConfig, _to_try, build_suite, scene_seeds
from samplehd.commands.suite import resolve_config
from samplehd.envs.episodes import SceneCache
from samplehd.envs.suite_file import SUITE_SPEC_DIR, read_suite
from samplehd.errors import ConfigError
from samplehd.scene.config import SceneConfig
from samplehd.tasks.task import family_names


@pytest.fixture(scope="module")
def cache() -> SceneCache:
    return SceneCache(SceneConfig(catalogue="procedural"), size=8, grasp_welds=True, gl_free=True)


def test_an_episode_of_a_level_is_drawn_from_the_scenes_instructions(cache: SceneCache) -> None:
    seeds = scene_seeds(0, 0, 4)
    scene, entry, seed = instruction_at_level(cache, seeds, "pick_up", "L1")
    assert entry["family"] == "pick_up" and seed in seeds and scene is cache.scene(seed)
    assert episode_level(entry, cache.annotation(scene)) == "L1"
    assert instruction_at_level(cache, seeds, "pick_up", "L1") == (scene, entry, seed)  # same seeds, same episode
    scene, held_out, seed = instruction_at_level(cache, seeds, "pick_up", "L3")
    assert episode_level(held_out, cache.annotation(scene)) == "L3" and held_out["family"] == "pick_up"
    without = [s for s in seeds if all(o.instance.class_name not in HELD_OUT_CLASSES for o in cache.scene(s).objects)]
    with pytest.raises(ConfigError, match=f"no pick_up episode of this level on {len(without)} scenes"):
        instruction_at_level(cache, without, "pick_up", "L4")


def test_the_shipped_core_specification_is_every_family_level_and_catalogue() -> None:
    args = argparse.Namespace(name="core", config=None, episodes_per_cell=None, seed=None, families=None, levels=None,
                              catalogues=None, axes=None)
    config = resolve_config(args)
    assert args.config == SUITE_SPEC_DIR / "core.json"
    assert config == SuiteBuildConfig.from_dict(json.loads((SUITE_SPEC_DIR / "core.json").read_text()))
    assert set(config.families) == set(family_names()) and config.levels == LEVELS
    assert set(config.catalogues) == {"procedural", "shop-vrb"}
    assert len(config.cells()) * config.episodes_per_cell >= 1400 and config.axes == ()


def test_put_and_stack_have_l3_episodes(cache: SceneCache) -> None:
    """The held-out phrasings "Place X inside Y" and "Stack X onto Y" are L3: a seen variant's "in" or
    "on" does not match the start of "inside" or "onto". A scene with one stack task says its
    held-out phrasing only in a later round of draws."""
    seeds = scene_seeds(0, 0, 4)
    for family, word in (("put", " inside "), ("stack", " onto ")):
        scene, entry, _ = instruction_at_level(cache, seeds, family, "L3")
        assert word in entry["instruction"] and episode_level(entry, cache.annotation(scene)) == "L3"
    with pytest.raises(ConfigError, match="no stack episode of this level on 1 scenes"):
        instruction_at_level(cache, seeds[3:], "stack", "L3")
    scene, entry, seed = instruction_at_level(cache, seeds[3:], "stack", "L3", rounds=4)
    assert seed == seeds[3] and entry["instruction"].startswith("Stack ") and " onto " in entry["instruction"]


def test_stack_three_cells_draw_from_scenes_of_their_own(cache: SceneCache) -> None:
    """core samples stack_three's scenes with 5–7 objects (three that stack are rare among 3–5): the
    scene seed of candidate 9's first scene then holds an L1 and an L3 episode,
    where the 3–5-object scene of that seed holds none; other families keep the env's scenes."""
    config = SuiteBuildConfig.from_dict(json.loads((SUITE_SPEC_DIR / "core.json").read_text()))
    own = config.scene_for("procedural", "stack_three")
    assert (own.min_objects, own.max_objects, own.catalogue) == (5, 7, "procedural")
    assert config.scene_for("procedural", "stack") == SceneConfig(catalogue="procedural")
    seed = scene_seeds(0, 9, 1)
    with pytest.raises(ConfigError, match="no stack_three episode of this level on 1 scenes"):
        instruction_at_level(cache, seed, "stack_three", "L1")
    rich = SceneCache(own, size=2, grasp_welds=True, gl_free=True)
    for level in ("L1", "L3"):
        scene, entry, _ = instruction_at_level(rich, seed, "stack_three", level, rounds=config.instruction_rounds)
        assert len(scene.objects) >= 5 and episode_level(entry, rich.annotation(scene)) == level


def test_a_family_scene_option_is_checked() -> None:
    with pytest.raises(ConfigError, match=r"suite.family_scene.stak: unknown family 'stak'"):
        SuiteBuildConfig(family_scene={"stak": {"min_objects": 5}})
    with pytest.raises(ConfigError, match=r"suite.family_scene.stack_three: unknown option\(s\) \['objects'\]"):
        SuiteBuildConfig(family_scene={"stack_three": {"objects": 5}})
    with pytest.raises(ConfigError, match=r"suite.family_scene.stack_three: scene.max_objects=5: must be ≥"):
        SuiteBuildConfig(family_scene={"stack_three": {"min_objects": 6}})
    with pytest.raises(ConfigError, match=r"other than 'catalogue'"):
        SuiteBuildConfig(family_scene={"stack_three": {"catalogue": "procedural"}})


def test_a_family_scene_budget_is_checked() -> None:
    with pytest.raises(ConfigError, match=r"suite.family_max_scenes.stak: unknown family 'stak'"):
        SuiteBuildConfig(family_max_scenes={"stak": 100})
    with pytest.raises(ConfigError, match=r"suite.family_max_scenes.stack_three=0: must be an integer ≥ 1"):
        SuiteBuildConfig(family_max_scenes={"stack_three": 0})
    config = SuiteBuildConfig.from_dict(json.loads((SUITE_SPEC_DIR / "core.json").read_text()))
    assert config.max_scenes("stack_three") > config.max_scenes("stack") == config.max_scenes_per_candidate


def test_a_stack_three_cell_finds_its_episode_within_its_own_scene_budget() -> None:
    """Seed 7, candidate 0: of its 5–7-object scenes the first holds no stack_three L4 episode and the
    second does. With one scene per candidate the cell stays short; with two for stack_three alone
    (``family_max_scenes``) it gets its episode, proven by the oracle, and other families keep one."""
    spec = {"seed": 7, "families": ["stack_three"], "levels": ["L4"], "catalogues": ["procedural"],
            "episodes_per_cell": 1, "max_candidates_per_cell": 1, "max_scenes_per_candidate": 1,
            "instruction_rounds": 4, "env": {"obs_mode": "state"},
            "family_scene": {"stack_three": {"min_objects": 5, "max_objects": 7}}}
    short = build_suite("short", SuiteBuildConfig.from_dict(spec))
    assert short.manifest["rejected"] == {"draw: no L4 episode in 1 scenes": 1}
    # a candidate the draw found no episode for was tried, but never given to the oracle
    assert short.manifest["candidates_solved"]["by_catalogue_family"] == {
        "procedural stack_three": {"tried": 1, "drawn": 0, "solved": 0}}
    config = SuiteBuildConfig.from_dict({**spec, "family_max_scenes": {"stack_three": 2}})
    assert config.max_scenes("stack") == 1
    suite = build_suite("filled", config)
    assert suite.manifest["short_cells"] == [] and suite.manifest["rejected"] == {}
    assert suite.manifest["candidates_solved"]["by_family"] == {"stack_three": {"tried": 1, "drawn": 1, "solved": 1}}
    (episode,) = suite.episodes
    assert (episode.family, episode.level) == ("stack_three", "L4")
    assert episode.scene_seed == scene_seeds(7, 0, 2)[1]


def _cell(outcomes: str) -> dict[int, Candidate]:
    """A cell's candidates so far: ``s`` solved, ``d`` no episode drawn, ``f`` the oracle failed."""
    reasons = {"s": "", "d": "draw: no L2 episode in 160 scenes", "f": "grasp_missed"}
    return {k: Candidate(0, k, o == "s", reasons[o]) for k, o in enumerate(outcomes)}


def test_a_cell_whose_draws_often_fail_tries_more_candidates_after_its_second_round() -> None:
    """Two candidates in the first round; in the second as many as the cell lacks; from the third on
    as many divided by the cell's share solved so far (at most twice), never beyond its room."""
    assert _to_try({}, 0, 25, 60, first=True) == 2
    assert _to_try({}, 0, 1, 60, first=True) == 1
    assert _to_try(_cell("sd"), 2, 25, 58, first=False) == 24  # second round: what it lacks
    # third round: 15 of 25 solved (draws failed on the others): 10 lacking, tried at 25/15 of that
    assert _to_try(_cell("s" * 15 + "d" * 10), 25, 25, 35, first=False) == 17
    assert _to_try(_cell("s" * 24 + "f"), 25, 25, 35, first=False) == 1  # a cell the oracle nearly always solves
    assert _to_try(_cell("s" * 10 + "d" * 15), 25, 25, 35, first=False) == 30  # at most twice what it lacks
    assert _to_try(_cell("s" * 2 + "d" * 23), 25, 25, 35, first=False) == 35  # within its room
    assert _to_try(_cell("s" * 3 + "d" * 3), 6, 25, 54, first=False) == 44
    assert _to_try(_cell("s" * 25 + "d"), 26, 25, 34, first=False) == 0  # full


def test_a_cell_whose_first_candidates_find_no_episode_is_given_up() -> None:
    """stack_three L1 has no episode on the first 3–5-object scene of candidates 0 and 1: the first
    round's two candidates find none, and the build tries no third one but names the cell and why."""
    config = SuiteBuildConfig(families=("stack_three",), levels=("L1",), catalogues=("procedural",),
                              episodes_per_cell=3, max_scenes_per_candidate=1, env={"obs_mode": "state"})
    suite = build_suite("empty", config)
    assert suite.episodes == () and suite.manifest["candidates"] == 2
    assert suite.manifest["rejected"] == {"draw: no L1 episode in 1 scenes": 2}
    assert suite.manifest["short_cells"] == [{
        "catalogue": "procedural", "family": "stack_three", "level": "L1", "episodes": 0, "candidates": 2,
        "reason": "no episode of the family and level on the 2 scenes of its first candidates"}]


@pytest.mark.slow
def test_the_once_empty_core_cells_fill_with_oracle_proven_episodes() -> None:
    """put L3, stack L3 and stack_three L1 on procedural, drawn as core draws them (its rounds and its
    stack_three scenes): each cell gets its episode, of its level, and the oracle solved it."""
    spec = json.loads((SUITE_SPEC_DIR / "core.json").read_text())
    config = SuiteBuildConfig.from_dict({**spec, "families": ["put", "stack", "stack_three"], "levels": ["L1", "L3"],
                                         "catalogues": ["procedural"], "episodes_per_cell": 1})
    suite = build_suite("filled", config)
    assert suite.manifest["short_cells"] == []
    cells = {(e.family, e.level) for e in suite.episodes}
    assert cells == {(f, lv) for f in ("put", "stack", "stack_three") for lv in ("L1", "L3")}
    assert all(len(e.scene["objects"]) >= 5 for e in suite.episodes if e.family == "stack_three")


def test_the_shipped_core_suite_is_its_specification_built_whole() -> None:
    """``core`` ships built: from its shipped specification, every cell full, every episode clean and
    proven by the oracle, and the manifest's candidate counts add up to its episodes and rejections."""
    suite = read_suite("core")
    spec = SuiteBuildConfig.from_dict(json.loads((SUITE_SPEC_DIR / "core.json").read_text()))
    given = {k: v for k, v in spec.to_dict().items() if not k.startswith("base")}  # no base: not recorded
    assert suite.build == json.loads(json.dumps({"name": "core", **given}))
    cells = Counter((e.catalogue, e.family, e.level) for e in suite.episodes)
    assert set(cells) == set(spec.cells()) and set(cells.values()) == {spec.episodes_per_cell}
    assert len(suite.episodes) == 1400 and suite.manifest["short_cells"] == []
    assert all(e.axis == "none" and e.strength == 0 and e.oracle_steps > 0 for e in suite.episodes)
    m = suite.manifest
    assert m["oracle_success_on_suite"] == 1.0
    groups = m["candidates_solved"]["by_catalogue_family"]
    assert sum(g["tried"] for g in groups.values()) == m["candidates"]
    assert sum(g["solved"] for g in groups.values()) == len(suite.episodes) + m["spare"]
    assert m["candidates"] - len(suite.episodes) - m["spare"] == sum(m["rejected"].values())
    draws = sum(n for reason, n in m["rejected"].items() if reason.startswith("draw:"))
    assert sum(g["tried"] - g["drawn"] for g in groups.values()) == draws


@pytest.mark.slow
def test_the_shipped_smoke_suite_is_its_specification_built_again() -> None:
    """``samplehd suite build smoke`` (a shipped name picks its shipped specification) draws, proves and
    writes exactly the shipped file: its episodes, their hash and its manifest."""
    spec = SuiteBuildConfig.from_dict(json.loads((SUITE_SPEC_DIR / "smoke.json").read_text()))
    built, shipped = build_suite("smoke", spec), read_suite("smoke")
    assert built.content_hash == shipped.content_hash
    assert (built.build, built.manifest) == (shipped.build, shipped.manifest)


@pytest.mark.slow
def test_the_oracle_solves_shipped_core_episodes_in_their_recorded_steps() -> None:
    """Three of ``core``'s episodes (its first, a procedural stack_three L4 one and its last, a shop-vrb
    stack_three L4 one), reset from the shipped file as ``evaluate --suite core`` resets them: the oracle
    solves each in exactly the control steps the build recorded."""
    suite = read_suite("core")
    picks = [suite.episodes[0], next(e for e in suite.episodes if (e.catalogue, e.family, e.level)
                                      == ("procedural", "stack_three", "L4")), suite.episodes[-1]]
    config = EvalConfig(policy="oracle", episodes=len(suite.episodes), suite="core", env={"obs_mode": "state"})
    runner = EpisodeRunner(_with_slots_for(config, suite))
    try:
        for e in picks:
            record = runner.run((e.id, e.reset_seed, e.family))
            assert (record.success, record.steps, record.family) == (True, e.oracle_steps, e.family), e.id
    finally:
        runner.close()

"""Benchmark suites: the file format and its refusals, the env's ``suite`` reset option, evaluation on a
suite, and (slow) a build whose every episode the oracle solves, evaluated twice to the same report."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from samplehd.benchmark.axes import (
    AXES,
    AXIS_FIELDS,
    BLANK_INSTRUCTION,
    STRENGTHS,
    changed_fields,
    check_instruction_fits,
    perturb,
)
from samplehd.benchmark.evaluation import EvalConfig, evaluate
from samplehd.benchmark.lerobot_tabletop import LeRobotTabletop
from samplehd.benchmark.suite import SuiteBuildConfig, build_suite
from samplehd.envs.suite_file import Suite, SuiteEpisode, content_hash, read_suite, shipped_suites, suite_path
from samplehd.envs.tabletop import TabletopEnv
from samplehd.envs.tokens import instruction_vocabulary
from samplehd.errors import ConfigError, SceneError
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import add_objects
from samplehd.scene.spec import SceneSpec, compile_scene
from samplehd.workers import Backend

SHIPPED = "smoke"
# Twelve oracle-proven episodes of an earlier build of smoke, which the tests of the axes are written on
TWINS = Path(__file__).parent / "data" / "twins.json"


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "samplehd", *args], capture_output=True, text=True, timeout=300)


def test_the_shipped_smoke_suite_reads_and_covers_both_catalogues() -> None:
    assert SHIPPED in shipped_suites()
    suite = read_suite(SHIPPED)
    raw = json.loads(suite_path(SHIPPED).read_text())
    assert suite.content_hash == content_hash(raw["episodes"])
    assert set(suite.manifest["by_catalogue"]) == {"procedural", "shop-vrb"}
    assert suite.manifest["episodes"] == len(suite.episodes)
    assert all(e.oracle_steps > 0 and e.axis == "none" and e.strength == 0 for e in suite.episodes)


def test_env_resets_to_a_suite_episode_and_refuses_an_index_outside(tmp_path: Path) -> None:
    suite = read_suite(SHIPPED)
    ep = suite.episodes[-1]
    env = TabletopEnv()
    try:
        _, info = env.reset(options={"suite": SHIPPED, "episode": np.int64(ep.id)})
        assert info["instruction"] == ep.instruction and info["task"] == ep.task
        assert env.episode.scene.to_dict() == ep.scene
        for bad in (len(suite.episodes), -1, "0", True):
            with pytest.raises(ConfigError, match="has episodes 0.."):
                env.reset(options={"suite": SHIPPED, "episode": bad})
        with pytest.raises(ConfigError, match="needs 'episode'"):
            env.reset(options={"suite": SHIPPED})
        with pytest.raises(ConfigError, match="leave out"):
            env.reset(options={"suite": SHIPPED, "episode": 0, "family": "place"})
    finally:
        env.close()


def _damaged(tmp_path: Path) -> dict[str, Path]:
    raw = json.loads(suite_path(SHIPPED).read_text())
    edited = json.loads(json.dumps(raw))
    edited["episodes"][0]["instruction"] = "Pick up the thing."
    foreign = {"format": "lerobot", "episodes": []}
    old = {**raw, "format_version": 99}
    files = {"edited": edited, "foreign": foreign, "version": old}
    out = {}
    for name, obj in files.items():
        out[name] = tmp_path / f"{name}.json"
        out[name].write_text(json.dumps(obj))
    out["truncated"] = tmp_path / "truncated.json"
    out["truncated"].write_text(suite_path(SHIPPED).read_text()[:500])
    return out


def test_a_damaged_or_foreign_suite_file_is_refused_in_one_line(tmp_path: Path) -> None:
    expected = {"edited": "do not match content_hash", "foreign": "not a samplehd suite file",
                "version": "format_version 99", "truncated": "invalid JSON"}
    for name, path in _damaged(tmp_path).items():
        with pytest.raises(ConfigError, match=expected[name]):
            read_suite(path)
        if name not in ("edited", "foreign"):  # the command line's handling is the same for every refusal
            continue
        out = tmp_path / f"report_{name}.json"
        r = _cli("evaluate", "--policy", "random", "--suite", str(path), "--out", str(out))
        assert r.returncode == 2, r.stderr
        assert len(r.stderr.strip().splitlines()) == 1 and str(path) in r.stderr, r.stderr
        assert expected[name] in r.stderr
        assert not out.exists()
    r = _cli("evaluate", "--policy", "random", "--suite", "no-such-suite")
    assert r.returncode == 2 and "shipped: " in r.stderr and SHIPPED in r.stderr


def test_evaluate_refuses_split_flags_with_a_suite() -> None:
    r = _cli("evaluate", "--policy", "random", "--suite", SHIPPED, "--level", "L2")
    assert r.returncode == 2 and "a suite fixes its episodes" in r.stderr, r.stderr


def test_suite_list_and_show_describe_the_shipped_suite() -> None:
    suite = read_suite(SHIPPED)
    r = _cli("suite", "list")
    assert r.returncode == 0 and SHIPPED in r.stdout and suite.content_hash in r.stdout
    r = _cli("suite", "show", SHIPPED)
    assert r.returncode == 0 and f"{len(suite.episodes)} episodes" in r.stdout and "by family" in r.stdout


def test_a_summary_names_a_few_short_variants_and_counts_the_rest() -> None:
    """A `plus` axis can leave hundreds of twin x strength pairs short; `suite build` and `suite show`
    name five and say how many more the manifest lists, on one line."""
    from dataclasses import replace

    from samplehd.commands.suite import describe

    suite = read_suite(SHIPPED)
    short = [{"axis": "task_swap", "strength": 1 + i % 5, "twin": i} for i in range(400)]
    text = describe(replace(suite, manifest={**suite.manifest, "short_variants": short}))
    line = next(x for x in text.splitlines() if "short variants" in x)
    assert line.startswith("  short variants (400): ") and line.endswith(", and 395 more in the manifest")
    assert line.count('"twin"') == 5 and len(line) < 400
    assert "short variants" not in describe(suite)


def test_a_random_policy_on_a_suite_names_the_suite_in_its_report(tmp_path: Path) -> None:
    suite = read_suite(SHIPPED)
    report = evaluate(EvalConfig(policy="random", suite=SHIPPED, env={"max_episode_steps": 3}),
                      tmp_path / "r.json").to_dict()
    assert report["split"]["suite"] == SHIPPED and report["split"]["content_hash"] == suite.content_hash
    assert [r["instruction"] for r in report["records"]] == [e.instruction for e in suite.episodes]
    assert set(report["by_axis"]) == {"none"} and set(report["by_level"]) <= {"L1", "L2", "L3", "L4"}


@pytest.mark.slow
def test_a_built_suite_is_solved_by_the_oracle_and_evaluates_identically_twice(tmp_path: Path) -> None:
    config = SuiteBuildConfig(families=("pick_up",), catalogues=("procedural",), episodes_per_cell=1,
                              axes=("object_shift", "robot_start", "distractors"), strengths=(5,),
                              max_attempts_per_variant=8)  # five distractors beside "Pick up the spoon.": often a spoon
    suite = build_suite("t", config)
    assert [(e.axis, e.strength, e.twin) for e in suite.episodes] == [
        ("none", 0, None), ("object_shift", 5, 0), ("robot_start", 5, 0), ("distractors", 5, 0)]
    # the same bytes whatever the number of workers
    assert build_suite("t", config, Backend(workers=2)).to_dict() == suite.to_dict()
    path = tmp_path / "t.json"
    suite.write(path)
    reports = [evaluate(EvalConfig(policy="oracle", suite=str(path))).to_dict() for _ in range(2)]
    assert reports[0]["success_rate"] == 1.0
    assert [r["steps"] for r in reports[0]["records"]] == [e.oracle_steps for e in suite.episodes]
    assert set(reports[0]["by_axis"]) == {"none", "object_shift", "robot_start", "distractors"}
    for r in reports:
        r.pop("wall_s")
        for rec in r["records"]:
            rec.pop("wall_s")
    assert reports[0] == reports[1]


def test_a_variant_differs_from_its_clean_twin_only_in_its_axis() -> None:
    twins = [e.to_dict() for e in read_suite(TWINS).episodes[::6]]  # one per catalogue
    for twin in twins:
        # (distractors, task_swap, unseen_objects and imported_objects have their own tests: they may reject)
        for axis in sorted(set(AXES) - {"distractors", "task_swap", "unseen_objects", "imported_objects"}):
            for strength in (1, 5):
                variant = perturb(twin, axis, strength, seed=0)
                assert variant == perturb(twin, axis, strength, seed=0)  # a function of the seed
                assert variant["twin"] == twin["id"] and variant["strength"] == strength and variant["axis"] == axis
                changed = changed_fields(twin, variant) - {"id", "axis", "strength", "twin"}
                assert changed == set(AXIS_FIELDS[axis]), (axis, strength, changed)


def test_axis_strengths_are_the_documented_physical_amounts() -> None:
    twin = read_suite(TWINS).episodes[0].to_dict()
    for strength in STRENGTHS:
        cam = perturb(twin, "camera", strength, seed=3)["scene"]["camera"]
        target = np.asarray(cam["target"])
        a, b = (np.asarray(c["pos"]) - target for c in (twin["scene"]["camera"], cam))
        turn = abs(np.degrees(np.arctan2(b[1], b[0]) - np.arctan2(a[1], a[0])))
        assert turn == pytest.approx(6.0 * strength) and a[2] == b[2]
        shifted = perturb(twin, "object_shift", strength, seed=3)["scene"]["objects"]
        moves = {tuple(np.round(np.subtract(s["pos"], o["pos"]), 9))
                 for s, o in zip(shifted, twin["scene"]["objects"], strict=True)}
        assert len(moves) == 1 and np.hypot(*next(iter(moves))[:2]) == pytest.approx(0.015 * strength)
        start = perturb(twin, "robot_start", strength, seed=3)["start_state"]["qpos"]
        home = perturb(twin, "robot_start", 0, seed=3)["start_state"]["qpos"]
        assert np.abs(np.subtract(start, home))[:6] == pytest.approx([0.05 * strength] * 6)
        assert start[6:] == home[6:]
        words = perturb(twin, "shuffled", strength, seed=3)["instruction"].rstrip(".").split()
        assert sorted(words) == sorted(twin["instruction"].rstrip(".").split())
        clean = twin["instruction"].rstrip(".").split()
        kept = perturb(twin, "blank", strength, seed=3)["instruction"].rstrip(".").split()
        assert len(clean) - len(kept) == min(len(clean), max(1, round(0.2 * strength * len(clean))))
        rest = iter(clean)
        assert all(w in rest for w in kept)  # the kept words in their order
    assert perturb(twin, "blank", 5, seed=3)["instruction"] == BLANK_INSTRUCTION


def test_the_robot_start_axis_moves_only_the_arm_from_the_twins_start() -> None:
    twin = read_suite(TWINS).episodes[0].to_dict()
    env = TabletopEnv(obs_mode="state")
    try:
        states = []
        for ep in (twin, perturb(twin, "robot_start", 0, seed=3), perturb(twin, "robot_start", 5, seed=3)):
            env.reset(options=SuiteEpisode.from_dict({"id": 1, **ep}).reset_options())
            states.append(env.physics.data.qpos.copy())
    finally:
        env.close()
    twin_start, zero, five = states
    assert zero.tolist() == twin_start.tolist()  # the gripper open, the arm at home, objects as the twin's
    assert five[6:].tolist() == twin_start[6:].tolist()
    assert np.abs(five[:6] - twin_start[:6]) == pytest.approx([0.25] * 6)


def test_the_env_resets_to_a_blanked_instruction() -> None:
    twin = read_suite(TWINS).episodes[0].to_dict()
    blank = SuiteEpisode.from_dict({"id": 1, **perturb(twin, "blank", 5, seed=0)})
    env = TabletopEnv(obs_mode="state")
    try:
        obs, info = env.reset(options=blank.reset_options())
        assert obs["instruction"] == info["instruction"] == BLANK_INSTRUCTION and info["task"] == twin["task"]
        tokens = [t for t in obs["instruction_tokens"].tolist() if t]
        assert tokens == [1, instruction_vocabulary()["."], 2]  # <START> . <END>: no word
    finally:
        env.close()


def test_the_lerobot_env_serves_a_suites_episodes_of_its_family() -> None:
    suite = read_suite(SHIPPED)
    picks = [e for e in suite.episodes if e.family == "pick_up"]
    env = LeRobotTabletop("pick_up", {"obs_mode": "rgb", "width": 32, "height": 32}, suite=SHIPPED)
    try:
        _, info = env.reset(seed=len(picks) - 1)
        assert env.task_description == picks[-1].instruction and info["suite_episode"] == picks[-1].id
        with pytest.raises(ConfigError, match=f"has {len(picks)} pick_up episodes"):
            env.reset(seed=len(picks))
    finally:
        env.close()


def test_the_lerobot_env_has_a_slot_for_every_object_of_its_suites_scenes(tmp_path: Path) -> None:
    """A suite scene with more objects than the env samples (core's stack_three: up to 7) resets: the env
    is made with room for the family's fullest scene, as `evaluate --suite` makes its env."""
    twin = read_suite(TWINS).episodes[4].to_dict()  # "Please pick up the mug."
    crowded = next(v for v in (_attempt(twin, 3, a) for a in range(4)) if v is not None)  # 3 objects + 3
    crowded = {**crowded, "id": 0, "axis": "none", "strength": 0, "twin": None}
    assert len(crowded["scene"]["objects"]) > SceneConfig().max_objects
    path = tmp_path / "crowded.json"
    Suite(name="crowded", path=None, content_hash=content_hash([crowded]), build={}, manifest={}, package_version="",
          episodes=(SuiteEpisode.from_dict(crowded),)).write(path)
    env = LeRobotTabletop("pick_up", {"obs_mode": "rgb", "width": 32, "height": 32}, suite=str(path))
    try:
        _, info = env.reset(seed=0)
        assert info["suite_episode"] == 0 and env.task_description == twin["instruction"]
    finally:
        env.close()


def test_suite_build_refuses_a_bad_option_in_one_line_and_writes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "x.json"
    r = _cli("suite", "build", "x", "--families", "pick_up", "nope", "--out", str(out))
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "--families" in r.stderr and "valid: place" in r.stderr and not out.exists()


def test_lighting_changes_the_lights_by_the_documented_amounts_and_not_the_physics() -> None:
    twin = read_suite(TWINS).episodes[0].to_dict()
    clean_model, clean_data = compile_scene(SceneSpec.from_dict(twin["scene"]))
    key = clean_model.light("key_light").id
    for strength in (1, 5):
        lit = perturb(twin, "lighting", strength, seed=0)["scene"]["lighting"]
        assert abs(lit["intensity"] - 1.0) == pytest.approx(0.12 * strength)
        assert abs(lit["turn"]) == pytest.approx(15.0 * strength)
        assert lit["tint"][1] == 1.0 and abs(lit["tint"][0] - 1.0) == abs(lit["tint"][2] - 1.0) == pytest.approx(
            0.06 * strength)
    scene = SceneSpec.from_dict(perturb(twin, "lighting", 5, seed=0)["scene"])
    assert scene.to_dict()["lighting"] == lit and "lighting" not in SceneSpec.from_dict(twin["scene"]).to_dict()
    model, data = compile_scene(scene)
    factor = lit["intensity"] * np.asarray(lit["tint"])
    np.testing.assert_allclose(model.light_diffuse, clean_model.light_diffuse * factor, rtol=1e-6)
    np.testing.assert_allclose(model.vis.headlight.ambient, clean_model.vis.headlight.ambient * factor, rtol=1e-6)
    turned = np.degrees(np.arctan2(model.light_dir[key, 1], model.light_dir[key, 0])
                        - np.arctan2(clean_model.light_dir[key, 1], clean_model.light_dir[key, 0]))
    assert (turned - lit["turn"] + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-6)
    for m, d in ((clean_model, clean_data), (model, data)):  # the same physics, bit for bit
        for _ in range(200):
            mujoco.mj_step(m, d)
    assert np.array_equal(clean_data.qpos, data.qpos) and np.array_equal(clean_data.qvel, data.qvel)


def test_distractors_add_objects_after_the_scenes_own_and_keep_the_instruction_unambiguous() -> None:
    twin = read_suite(TWINS).episodes[6].to_dict()  # "Put the chopping board and the scissors on the front half..."
    own = twin["scene"]["objects"]
    for strength in (1, 2):
        variant = next(v for v in (_attempt(twin, strength, a) for a in range(4)) if v is not None)
        objects = variant["scene"]["objects"]
        assert len(objects) == len(own) + strength and objects[:len(own)] == own  # own poses kept exactly
        assert changed_fields(twin, variant) - {"id", "axis", "strength", "twin"} == {"scene.objects"}
        if strength == 2:  # every second one is of a class already on the table
            assert objects[-1]["instance"]["class_name"] in {o["instance"]["class_name"] for o in own}
        corners = np.array([o["pos"][:2] for o in objects])
        gaps = np.linalg.norm(corners[:, None] - corners[None], axis=-1) + np.eye(len(objects))
        assert gaps.min() > 0.03  # in free spots
    # a second pair of scissors makes "the scissors" ambiguous: such a variant is rejected
    scene = SceneSpec.from_dict(twin["scene"])
    doubled = add_objects(scene, [["scissors"]], np.random.default_rng(0), SceneConfig(catalogue=twin["catalogue"]))
    with pytest.raises(SceneError, match="no longer picks only its own objects"):
        check_instruction_fits({**twin, "scene": doubled.to_dict()})


def _attempt(twin: dict, strength: int, attempt: int) -> dict | None:
    try:
        return perturb(twin, "distractors", strength, seed=0, attempt=attempt)
    except SceneError:
        return None


def test_task_swap_names_other_objects_of_the_same_family_on_the_same_scene() -> None:
    twin = read_suite(TWINS).episodes[4].to_dict()  # "Please pick up the mug."
    near, far = (perturb(twin, "task_swap", s, seed=0) for s in (1, 5))
    for variant in (near, far):
        assert changed_fields(twin, variant) - {"id", "axis", "strength", "twin"} <= set(AXIS_FIELDS["task_swap"])
        assert sorted(variant["targets"]) != sorted(twin["targets"]) and variant["family"] == twin["family"]
        check_instruction_fits(variant)  # the program picks the new task's objects on the twin's scene
        assert variant["task"]["objects"] == [t for t in variant["targets"] if t in variant["task"]["objects"]]

    def distance(v: dict) -> float:
        a, b = ({w.strip(".").lower() for w in e["instruction"].split()} for e in (twin, v))
        return 1.0 - len(a & b) / len(a | b)

    assert 0.0 < distance(near) <= distance(far)

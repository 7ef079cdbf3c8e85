"""Suites built from a base suite: the base's clean episodes taken as they are, the axes' variants made
from them (a few axes at a time, as ``plus`` is built), and the refusals of a base that cannot be used."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from samplehd.benchmark.axes import AXES, AXIS_FIELDS, PHYSICAL_AXES, STRENGTHS, changed_fields, perturb
from samplehd.benchmark.suite import SuiteBuildConfig, _prove_variant, build_suite, read_base
from samplehd.commands.suite import resolve_config
from samplehd.envs.config import EnvConfig
from samplehd.envs.suite_file import SUITE_SPEC_DIR, Suite, SuiteEpisode, content_hash, read_suite
from samplehd.errors import ConfigError

BASE = "smoke"


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "samplehd", *args], capture_output=True, text=True, timeout=300)


def _bytes(suite: Suite) -> str:
    return json.dumps(suite.to_dict())


def _write(tmp_path: Path, name: str, episodes: list[dict], build: dict) -> Path:
    episodes = [{**e, "id": i} for i, e in enumerate(episodes)]
    path = tmp_path / f"{name}.json"
    Suite(name=name, path=None, content_hash=content_hash(episodes), build=build, manifest={}, package_version="",
          episodes=tuple(SuiteEpisode.from_dict(e) for e in episodes)).write(path)
    return path


def test_a_suite_from_a_base_copies_its_clean_episodes_and_varies_them_on_its_axes(tmp_path: Path) -> None:
    """No oracle runs for axes that cannot change physics: the twins are the base's episodes to the
    byte, each variant differs from its twin only in its axis' fields, and a second build is the same."""
    base = read_suite(BASE)
    config = SuiteBuildConfig(base=BASE, base_per_cell=1, axes=("camera", "shuffled"), strengths=(1, 5))
    suite = build_suite("derived", config)
    twins = [e for e in suite.episodes if e.axis == "none"]
    assert [json.dumps(e.to_dict()) for e in twins] == [json.dumps(e.to_dict()) for e in base.episodes]
    variants = suite.episodes[len(twins):]
    assert {(e.axis, e.strength) for e in variants} == {(a, s) for a in config.axes for s in config.strengths}
    for ep in variants:
        twin = twins[ep.twin].to_dict()
        assert ep.to_dict() == {**perturb(twin, ep.axis, ep.strength, seed=0), "id": ep.id}
        assert changed_fields(twin, ep.to_dict()) - {"id", "axis", "strength", "twin"} == set(AXIS_FIELDS[ep.axis])
        assert ep.oracle_steps == twin["oracle_steps"]  # the twin's rollout: its proof stands
    m = suite.manifest
    assert m["base"] == {"name": base.name, "content_hash": base.content_hash, "episodes": list(range(12))}
    assert m["axes"] == ["camera", "shuffled"] and m["strengths"] == [1, 5] and m["candidates"] == 0
    assert m["episodes"] == len(suite.episodes) == 12 + len(variants) and m["by_axis"]["none"] == 12
    assert suite.build == {"name": "derived", "seed": 0, "axes": ["camera", "shuffled"], "strengths": [1, 5],
                           "max_attempts_per_variant": 4, "base": BASE, "base_per_cell": 1}
    assert _bytes(build_suite("derived", config)) == _bytes(suite)
    suite.write(tmp_path / "derived.json")
    assert read_suite(tmp_path / "derived.json").episodes == suite.episodes


def test_a_base_per_cell_takes_each_cells_first_clean_episodes_in_suite_order(tmp_path: Path) -> None:
    """A base with two clean episodes per cell and variants of its own: one per cell takes each cell's
    first; three per cell takes both and names the cells that have fewer."""
    smoke = read_suite(BASE)
    first = [e.to_dict() for e in smoke.episodes]
    second = [{**e, "reset_seed": e["reset_seed"] + 1} for e in first]
    variant = {**perturb({**first[0], "id": 0}, "camera", 5, seed=0)}
    path = _write(tmp_path, "two", [*first, *second, variant], smoke.build)
    one = build_suite("one", SuiteBuildConfig(base=str(path), base_per_cell=1))
    assert one.manifest["base"]["episodes"] == list(range(12)) and one.manifest["short_cells"] == []
    assert [e.reset_seed for e in one.episodes] == [e["reset_seed"] for e in first]
    three = build_suite("three", SuiteBuildConfig(base=str(path), base_per_cell=3))
    assert three.manifest["base"]["episodes"] == list(range(24)) and len(three.episodes) == 24
    assert len(three.manifest["short_cells"]) == 12
    assert three.manifest["short_cells"][0] == {"catalogue": "procedural", "family": "place", "level": "L1",
                                                "episodes": 2, "reason": "the base has 2 clean episodes of the cell"}
    every = build_suite("every", SuiteBuildConfig(base=str(path)))  # no base_per_cell: all of them
    assert [e.to_dict() for e in every.episodes] == [e.to_dict() for e in three.episodes]
    assert every.manifest["short_cells"] == []


def test_a_base_skip_takes_the_episodes_a_suite_of_the_first_ones_leaves(tmp_path: Path) -> None:
    """A validation suite and a test suite of one base share no episode: skipping the first of each
    cell's two takes the second; skipping both leaves every cell short, and says why."""
    smoke = read_suite(BASE)
    first = [e.to_dict() for e in smoke.episodes]
    second = [{**e, "reset_seed": e["reset_seed"] + 1} for e in first]
    path = _write(tmp_path, "two", [*first, *second], smoke.build)
    test = build_suite("test", SuiteBuildConfig(base=str(path), base_per_cell=1))
    val = build_suite("val", SuiteBuildConfig(base=str(path), base_per_cell=1, base_skip=1))
    assert val.manifest["base"]["episodes"] == list(range(12, 24)) and val.manifest["short_cells"] == []
    assert [e.reset_seed for e in val.episodes] == [e["reset_seed"] for e in second]
    assert not {e.reset_seed for e in val.episodes} & {e.reset_seed for e in test.episodes}
    assert val.build["base_skip"] == 1 and "base_skip" not in test.build
    none = build_suite("none", SuiteBuildConfig(base=str(path), base_per_cell=1, base_skip=2))
    assert none.episodes == () and len(none.manifest["short_cells"]) == 12
    assert none.manifest["short_cells"][0]["reason"] == ("the base has 2 clean episodes of the cell, of which the "
                                                         "first 2 are passed over")
    with pytest.raises(ConfigError, match=r"^suite.base_skip=1: counts the clean episodes passed over per cell "
                                          r"of suite.base; name the base"):
        SuiteBuildConfig(base_skip=1)
    with pytest.raises(ConfigError, match=r"^suite.base_skip=-1: must be an integer ≥ 0"):
        SuiteBuildConfig(base=BASE, base_skip=-1)


@pytest.mark.slow
def test_a_suite_from_a_base_proves_its_physical_variants_through_the_env() -> None:
    """One non-physical and one physical axis at strength 5 on smoke's twelve episodes: the robot start
    variants are proven by the oracle (each one, or left out after its attempts), and a second build
    gives the same bytes."""
    base = read_suite(BASE)
    config = SuiteBuildConfig(base=BASE, base_per_cell=1, axes=("lighting", "robot_start"), strengths=(5,))
    suite = build_suite("physical", config)
    twins = suite.episodes[:12]
    assert [json.dumps(e.to_dict()) for e in twins] == [json.dumps(e.to_dict()) for e in base.episodes]
    made = {(e.axis, e.twin) for e in suite.episodes[12:]}
    left = {(v["axis"], v["twin"]) for v in suite.manifest["short_variants"]}
    assert made | left == {(a, t) for a in config.axes for t in range(12)} and not made & left
    assert len(made) > 12  # most robot starts are solved
    for ep in suite.episodes[12:]:
        twin = twins[ep.twin].to_dict()
        changed = changed_fields(twin, ep.to_dict()) - {"id", "axis", "strength", "twin", "oracle_steps"}
        assert changed == set(AXIS_FIELDS[ep.axis]) and ep.oracle_steps > 0
    assert _bytes(build_suite("physical", config)) == _bytes(suite)


def test_a_build_of_some_axes_holds_the_same_variants_as_a_build_of_more() -> None:
    """``plus`` is built lazily: an axis built alone gives the variants a build of several axes gives."""
    both = build_suite("both", SuiteBuildConfig(base=BASE, axes=("camera", "lighting")))
    alone = build_suite("alone", SuiteBuildConfig(base=BASE, axes=("lighting",)))

    def lighting(suite: Suite) -> list[dict]:
        return [{k: v for k, v in e.to_dict().items() if k != "id"} for e in suite.episodes if e.axis == "lighting"]

    assert lighting(alone) == lighting(both) and len(lighting(alone)) == 12 * len(STRENGTHS)
    assert alone.manifest["axes"] == ["lighting"]


def test_a_base_goes_without_the_options_it_replaces() -> None:
    with pytest.raises(ConfigError, match=r"^suite.base_per_cell=2: counts the clean episodes taken per cell from "
                                          r"suite.base; name the base"):
        SuiteBuildConfig(base_per_cell=2)
    with pytest.raises(ConfigError, match=r"^suite.base_per_cell=0: must be an integer ≥ 1"):
        SuiteBuildConfig(base=BASE, base_per_cell=0)
    with pytest.raises(ConfigError, match=r"^suite.families=\[\"pick_up\"\]: a suite built from a base "
                                          r"\(suite.base='smoke'\) has its base's; leave it out$"):
        SuiteBuildConfig(base=BASE, families=("pick_up",))
    with pytest.raises(ConfigError, match=r"^suite.env=\{.*\.\.\.: a suite built from a base"):
        SuiteBuildConfig(base=BASE, env=EnvConfig(max_episode_steps=100))
    with pytest.raises(ConfigError, match=r"^suite.episodes_per_cell=3: "):
        SuiteBuildConfig.from_dict({"base": BASE, "episodes_per_cell": 3})
    with pytest.raises(ConfigError, match=r"^suite.base='': must be a built suite's name or file$"):
        SuiteBuildConfig(base="")
    with pytest.raises(ConfigError, match=r"^suite.strengths\[0\]=7: must be an integer in \[1, 5\]"):
        SuiteBuildConfig(strengths=(7,))


def test_a_base_that_cannot_be_used_is_refused_in_one_line(tmp_path: Path) -> None:
    smoke = read_suite(BASE)
    twin = smoke.episodes[0].to_dict()
    only_variants = _write(tmp_path, "variants", [perturb(twin, "camera", 1, seed=0)], smoke.build)
    derived = _write(tmp_path, "derived", [twin], {"name": "derived", "base": BASE})
    damaged = tmp_path / "damaged.json"
    damaged.write_text(json.dumps({**smoke.to_dict(), "content_hash": "sha256:0"}))
    expected = {"nope": r"^suite.base='nope': no such shipped suite; shipped: .*smoke",
                str(only_variants): r"has no clean episode \(axis 'none'\) to make variants of$",
                str(derived): r"is itself built from the base 'smoke'; name that one$",
                str(damaged): r"the episodes do not match content_hash",
                str(tmp_path / "missing.json"): r"cannot read"}
    for base, message in expected.items():
        with pytest.raises(ConfigError, match=message) as info:
            read_base(SuiteBuildConfig(base=base))
        assert "\n" not in str(info.value) and str(info.value).startswith(f"suite.base={base!r}: ")
        with pytest.raises(ConfigError, match=message):
            build_suite("x", SuiteBuildConfig(base=base, axes=("camera",)))


def test_suite_build_refuses_a_bad_base_with_exit_2_and_writes_nothing(tmp_path: Path) -> None:
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"base": "no-such-suite", "base_per_cell": 1, "axes": ["camera"]}))
    out = tmp_path / "x.json"
    r = _cli("suite", "build", "x", "--config", str(spec), "--out", str(out))
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "suite.base='no-such-suite': no such shipped suite" in r.stderr and not out.exists()
    r = _cli("suite", "build", "x", "--base", BASE, "--families", "pick_up", "nope", "--out", str(out))
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "--families ['pick_up', 'nope']: unknown 'nope'; valid: " in r.stderr and not out.exists()
    r = _cli("suite", "build", "x", "--base", BASE, "--episodes-per-cell", "3", "--out", str(out))
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "--episodes-per-cell 3" in r.stderr and "has its base's" in r.stderr and not out.exists()


def test_a_suite_from_a_base_may_take_only_some_of_its_cells(tmp_path: Path) -> None:
    """``--catalogues``, ``--families`` and ``--levels`` beside ``--base`` select the base's cells: the
    suite holds the selected cells' episodes of the whole base, in its order, and its build says so."""
    every = build_suite("every", SuiteBuildConfig(base=BASE))
    some = build_suite("some", SuiteBuildConfig(base=BASE, base_catalogues=("shop-vrb",),
                                                base_families=("pick_up", "put"), base_levels=("L1",)))
    expected = [{**e.to_dict(), "id": None} for e in every.episodes
                if e.catalogue == "shop-vrb" and e.family in ("pick_up", "put")]
    assert [{**e.to_dict(), "id": None} for e in some.episodes] == expected and len(expected) == 2
    assert some.build["base_families"] == ["pick_up", "put"] and "base_families" not in every.build
    assert build_suite("none", SuiteBuildConfig(base=BASE, base_levels=("L2",))).episodes == ()
    out = tmp_path / "cli.json"
    r = _cli("suite", "build", "cli", "--base", BASE, "--catalogues", "shop-vrb", "--families", "pick_up", "put",
             "--levels", "L1", "--out", str(out), "--quiet")
    assert r.returncode == 0, r.stderr
    assert [e.to_dict() for e in read_suite(out).episodes] == [e.to_dict() for e in some.episodes]
    with pytest.raises(ConfigError, match=r'^suite.base_families=\["pick_up"\]: selects cells of suite.base; '):
        SuiteBuildConfig(base_families=("pick_up",))
    with pytest.raises(ConfigError, match=r"^suite.base_levels=\['L9'\]: unknown 'L9'; valid: L1, L2, L3, L4$"):
        SuiteBuildConfig(base=BASE, base_levels=("L9",))


def test_suite_build_makes_only_the_named_axes_of_a_specification(tmp_path: Path) -> None:
    """``samplehd suite build NAME --config SPEC --axes ...``: the spec's other axes are not built, and the
    file's manifest says which axes it holds."""
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"base": BASE, "base_per_cell": 1, "axes": ["lighting", "robot_start", "textures"]}))
    out = tmp_path / "part.json"
    r = _cli("suite", "build", "part", "--config", str(spec), "--axes", "textures", "--out", str(out), "--quiet")
    assert r.returncode == 0, r.stderr
    assert "0 physical variant attempts" in r.stdout and "from base smoke" in r.stdout
    suite = read_suite(out)
    assert suite.manifest["axes"] == ["textures"] and set(suite.manifest["by_axis"]) == {"none", "textures"}
    assert suite.manifest["by_axis"]["textures"] == 12 * len(STRENGTHS)


def test_the_shipped_plus_specification_derives_every_axis_from_core() -> None:
    """plus takes core's first four episodes of each of its 56 cells: every axis at strengths 1–5 then
    makes up to 56 × 4 × 75 variants; even with every physical variant and every nouns one left out,
    the other nine axes (which change nearly every instruction) would give over 10,000."""
    spec = json.loads((SUITE_SPEC_DIR / "plus.json").read_text())
    config = SuiteBuildConfig.from_dict(spec)
    args = argparse.Namespace(name="plus", config=None, episodes_per_cell=None, seed=None, families=None,
                              levels=None, catalogues=None, axes=["camera", "lighting"])
    assert resolve_config(args) == replace(config, axes=("camera", "lighting"))  # a part of plus: two axes
    core = SuiteBuildConfig.from_dict(json.loads((SUITE_SPEC_DIR / "core.json").read_text()))
    assert config.base == "core" and set(config.axes) == set(AXES) and config.strengths == STRENGTHS
    twins = len(core.cells()) * (config.base_per_cell or 0)
    assert config.base_per_cell is not None and config.base_per_cell <= core.episodes_per_cell
    others = set(AXES) - set(PHYSICAL_AXES) - {"nouns"}
    assert twins * (1 + len(others) * len(STRENGTHS)) >= 10_000


def test_a_variant_the_env_refuses_is_rejected_with_the_envs_reason() -> None:
    """core's 'Clear the front part of the table.' (shop-vrb remove L1) as twin 9, its objects shifted
    7.5 cm toward the back: the env refuses the reset (the program picks other objects); the rejection
    names why, not the error's class."""
    twin = {**read_suite("core").episodes[1101].to_dict(), "id": 9}
    assert twin["instruction"] == "Clear the front part of the table."
    result = _prove_variant((SuiteBuildConfig(base="core"), twin, "object_shift", 5, 0))
    assert not result.solved
    assert result.reason.startswith("object_shift: reset: the instruction's task names objects [N], but its "
                                    "program picks other objects"), result.reason

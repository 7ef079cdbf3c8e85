"""`samplehd evaluate` writes its statistics beside the report, and `samplehd compare` pairs two real
reports episode by episode (oracle against random on one tiny split) and refuses what it cannot pair."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from samplehd.benchmark.statistics import wilson_interval
from samplehd.cli import main

FAST = {"scene": {"min_objects": 3, "max_objects": 3}, "num_scenes": 2, "scene_seed": 7}


@pytest.fixture(scope="module")
def reports(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Reports of the oracle and the random policy on the same two pick_up episodes."""
    root = tmp_path_factory.mktemp("reports")
    (root / "fast.json").write_text(json.dumps(FAST))
    out = {}
    for policy, steps in (("oracle", 200), ("random", 1)):
        out[policy] = root / f"{policy}.json"
        assert main(["evaluate", "--policy", policy, "--episodes", "2", "--families", "pick_up", "--seed", "5",
                     "--max-episode-steps", str(steps), "--env-options", str(root / "fast.json"),
                     "--out", str(out[policy])]) == 0
    return out


def test_evaluate_writes_intervals_and_tables_beside_the_report(reports: dict[str, Path]) -> None:
    report = json.loads(reports["oracle"].read_text())
    stats = report["statistics"]
    assert list(report)[-1] == "records" and stats["overall"]["n"] == 2
    k = stats["overall"]["successes"]
    assert k == report["successes"] and k >= 1  # the oracle solves pick_up
    assert (stats["overall"]["low"], stats["overall"]["high"]) == pytest.approx(wilson_interval(k, 2))
    assert stats["by_family"]["pick_up"] == stats["overall"]
    page = reports["oracle"].with_suffix(".md").read_text()
    assert page.startswith("# Evaluation: oracle on seed 5, 2 episodes (pick_up)")
    assert f"| pick_up | {k}/2 " in page and "Wilson" in page
    assert not reports["oracle"].with_name("oracle.robustness.png").exists()  # no axes, no curves


def test_compare_prints_paired_differences_of_two_real_reports(reports: dict[str, Path], tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    capsys.readouterr()
    out = tmp_path / "cmp.json"
    assert main(["compare", str(reports["random"]), str(reports["oracle"]), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "| all | 2 | 0/2 0.0 % [0.0, 65.8] |" in printed and "family pick_up" in printed
    assert "McNemar" in printed and "Significant: none." in printed  # 2 episodes cannot reach p < 0.05
    groups = json.loads(out.read_text())["groups"]
    every = groups[0]
    oracle = json.loads(reports["oracle"].read_text())["successes"]
    assert every["group"] == "all" and every["first_only"] == 0 and every["second_only"] == oracle
    assert every["difference"] == pytest.approx(oracle / 2) and every["p_value"] == (0.5 if oracle == 2 else 1.0)
    assert main(["compare", str(reports["random"]), str(reports["oracle"]), "--out", str(tmp_path / "c.md")]) == 0
    assert (tmp_path / "c.md").read_text().startswith("# oracle (oracle.json) against random (random.json)")


def _refused(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


def test_compare_refuses_what_it_cannot_pair_in_one_line(reports: dict[str, Path], tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    good = json.loads(reports["random"].read_text())
    cases = {
        "damaged": ('{"records": [', "invalid JSON at line 1"),
        "other_split": (json.dumps({**good, "split": {**good["split"], "seed": 6}}), "different split"),
        "other_suite": (json.dumps({**good, "suite": {"name": "core", "sha256": "0" * 64}}), "suite/split"),
        "fewer": (json.dumps({**good, "records": good["records"][:1]}), "different episodes (2 vs 1"),
        "other_episode": (json.dumps({**good, "records": [{**good["records"][0], "instruction": "Lift the cup."},
                                                          good["records"][1]]}), "differs in instruction"),
        "partial": (json.dumps({**good, "partial": True}), "partial report"),
        "not_a_report": ("[1, 2]", "not a samplehd evaluation report"),
        "bad_record": (json.dumps({**good, "records": [{"index": 0}]}), "records[0]: expected an object"),
        "bad_strength": (json.dumps({**good, "records": [{**good["records"][0], "axis": "camera", "strength": "high"},
                                                         good["records"][1]]}), "strength 'high' is not"),
        "bad_twin": (json.dumps({**good, "records": [good["records"][0], {**good["records"][1], "twin": [0]}]}),
                     "twin [0] is not an episode id"),
    }
    for name, (text, expected) in cases.items():
        path = tmp_path / f"{name}.json"
        path.write_text(text)
        err = _refused(["compare", str(reports["oracle"]), str(path)], capsys)
        assert expected in err and str(path) in err, (name, err)
    assert not list(tmp_path.glob("*.md"))
    err = _refused(["compare", str(reports["oracle"]), str(tmp_path / "missing.json")], capsys)
    assert "cannot read" in err
    err = _refused(["compare", str(reports["oracle"]), str(reports["random"]), "--out", str(tmp_path / "x.txt")],
                   capsys)
    assert "--out" in err and ".md or .json" in err

"""A real small dataset with disturbances: episodes drawn undisturbed are the bytes of the dataset without the
section, disturbed ones carry their labels, the dataset counts them by kind and outcome and validates, and
the recorded actions replay to the recorded outcomes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from dataset_helpers import MICRO, micro_config

# micro's four candidates at probability 0.5: scene 0 slot 0 undisturbed, the others nudge,
# wrong_object, nudge (each draw comes from the episode's own seed)
DISTURBED = {"disturbances": {"probability": 0.5}}


@pytest.fixture(scope="module")
def disturbed_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from samplehd.dataset.config import GenerateConfig
    from samplehd.dataset.generate import generate_dataset

    out = tmp_path_factory.mktemp("disturbed") / "ds"
    generate_dataset(out, GenerateConfig.from_dict(DISTURBED, base=micro_config()))
    return out


def _info(root: Path) -> dict:
    return json.loads((root / "info.json").read_text())


def test_undisturbed_episodes_are_the_bytes_without_the_section(disturbed_dataset: Path, micro_dataset: Path):
    plain = {e["file"]: e["sha256"] for e in _info(micro_dataset)["episodes"]}
    eps = _info(disturbed_dataset)["episodes"]
    undisturbed = [e for e in eps if "disturbance" not in e]
    assert undisturbed and len(undisturbed) < len(eps)
    for e in undisturbed:
        assert e["sha256"] == plain[e["file"]]
    assert "disturbances" not in _info(micro_dataset)["config"]
    assert _info(disturbed_dataset)["config"]["disturbances"]["probability"] == 0.5


def test_disturbed_episodes_are_labelled_counted_and_valid(disturbed_dataset: Path):
    from samplehd.dataset.container import read_episode
    from samplehd.dataset.validate import validate_dataset

    problems, _ = validate_dataset(disturbed_dataset)
    assert problems == []
    info = _info(disturbed_dataset)
    disturbed = [e for e in info["episodes"] if "disturbance" in e]
    counts = info["counts"]["disturbances"]
    assert sum(sum(v.values()) for v in counts.values()) == len(disturbed)
    assert info["counts"]["failed_recoveries"] == sum(not e["success"] for e in disturbed)
    for e in disturbed:
        ep = read_episode(disturbed_dataset / e["file"], images="none")
        lab = ep.info["disturbance"]
        assert lab["kind"] == e["disturbance"] and lab["outcome"] == e["outcome"] and ep.success == e["success"]
        assert ep.frames["disturbance_active"][lab["frame"]] == 1
        span = lab["recovery_last"] - lab["recovery_first"] + 1 if lab["recovery_first"] >= 0 else 0
        assert int(ep.frames["recovery"].sum()) == span  # -1, -1: nothing to recover from (absorbed)


def test_validate_catches_labels_that_disagree(disturbed_dataset: Path, tmp_path: Path):
    import shutil

    import h5py

    from samplehd.dataset.validate import validate_episode_file

    e = next(e for e in _info(disturbed_dataset)["episodes"] if e.get("outcome") == "recovered")
    path = tmp_path / "ep.h5"
    shutil.copy(disturbed_dataset / e["file"], path)
    with h5py.File(path, "r+") as f:
        flags = f["frames/recovery"][()]
        flags[:] = 0
        f["frames/recovery"][...] = flags
    problems = validate_episode_file(path, {}, None)
    assert any("frames/recovery does not span" in p for p in problems), problems


def test_bad_disturbance_flags_are_one_line_errors(tmp_path: Path):
    config = tmp_path / "micro.json"
    config.write_text(json.dumps(MICRO))
    for flags, words in ((["--disturb", "1.5"], ("--disturb", "probability", "1.5", "[0, 1]")),
                         (["--disturb-kinds", "juggle"], ("--disturb-kinds", "kinds", "juggle", "missed_grasp"))):
        out = tmp_path / "out"
        proc = subprocess.run([sys.executable, "-m", "samplehd", "generate", "--config", str(config), "--out",
                               str(out), "--quiet", *flags], capture_output=True, text=True, timeout=120)
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and all(w in lines[0] for w in words), lines
        assert not out.exists()


def test_config_file_section_round_trips(tmp_path: Path):
    from samplehd.dataset.config import GenerateConfig
    from samplehd.errors import ConfigError

    c = GenerateConfig.from_dict({"disturbances": {"probability": 0.2, "kinds": ["slip", "nudge"]}})
    assert GenerateConfig.from_dict(c.to_dict()) == c
    assert "disturbances" not in GenerateConfig().to_dict()
    with pytest.raises(ConfigError, match="disturbances.*wobble"):
        GenerateConfig.from_dict({"disturbances": {"wobble": 1}})


@pytest.mark.slow
def test_recorded_actions_replay_to_the_recorded_outcome(disturbed_dataset: Path):
    from samplehd.envs.replay_check import replay_dataset

    report = replay_dataset(disturbed_dataset)
    assert report.agrees, report
    assert max(e.tcp_deviation for e in report.episodes) < 0.01  # the replay follows the recording


def test_stats_count_disturbances_by_kind_and_outcome(disturbed_dataset: Path, micro_dataset: Path, tmp_path: Path):
    from samplehd.dataset.stats import dataset_stats, write_plots

    stats = dataset_stats(disturbed_dataset)
    counts = _info(disturbed_dataset)["counts"]["disturbances"]
    assert stats["disturbances"] == {k: v for k, v in counts.items() if v}
    assert sum(stats["disturbance_outcomes"].values()) == sum(sum(v.values()) for v in counts.values()) > 0
    assert (tmp_path / "disturbance_outcomes.png") in write_plots(stats, tmp_path)
    assert "disturbances" not in dataset_stats(micro_dataset)


def test_lerobot_export_carries_the_labels(disturbed_dataset: Path, micro_dataset: Path, tmp_path: Path):
    import pyarrow.parquet as pq

    from samplehd.dataset.container import read_episode
    from samplehd.export.lerobot import export_lerobot

    out = tmp_path / "lr"
    export_lerobot(disturbed_dataset, out, "samplehd/test")
    info = json.loads((out / "meta/info.json").read_text())
    assert info["features"]["recovery"]["dtype"] == "int64"
    data = pq.read_table(out / "data/chunk-000/file-000.parquet").to_pydict()
    rows = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    reader_order = {e["file"]: e for e in _info(disturbed_dataset)["episodes"]}
    seen = 0
    for row in rows:
        a, b = row["dataset_from_index"], row["dataset_to_index"]
        entry = _info(disturbed_dataset)["episodes"][row["samplehd/instruction_index"]]
        assert entry["file"] in reader_order
        ep = read_episode(disturbed_dataset / entry["file"], images="none")
        lab = ep.info.get("disturbance")
        assert data["recovery"][a:b] == ep.frames.get("recovery", np.zeros(b - a)).tolist()
        assert data["disturbance_active"][a:b] == ep.frames.get("disturbance_active", np.zeros(b - a)).tolist()
        assert row["samplehd/disturbance.kind"] == (lab["kind"] if lab else "")
        assert row["samplehd/disturbance.frame"] == (lab["frame"] if lab else -1)
        assert row["samplehd/disturbance.success"] == ep.success
        seen += lab is not None
    assert seen > 0
    assert "disturbances" in json.loads((out / "meta/samplehd.json").read_text())
    plain = tmp_path / "plain"
    export_lerobot(micro_dataset, plain, "samplehd/test")
    assert "recovery" not in json.loads((plain / "meta/info.json").read_text())["features"]


def test_viewer_timeline_bands_follow_the_labels(disturbed_dataset: Path):
    from samplehd.dataset.container import read_episode
    from samplehd.viewer.episodes import disturbance_bands

    for e in _info(disturbed_dataset)["episodes"]:
        ep = read_episode(disturbed_dataset / e["file"], images="none")
        bands = {b["kind"]: b for b in disturbance_bands(ep.info)}
        if "disturbance" not in e:
            assert bands == {}
            continue
        lab = ep.info["disturbance"]
        active = np.flatnonzero(ep.frames["disturbance_active"])
        assert (bands["disturbance"]["start"], bands["disturbance"]["end"]) == (active[0], active[-1] + 1)
        assert bands["disturbance"]["name"].startswith(lab["kind"])
        recovery = np.flatnonzero(ep.frames["recovery"])
        if len(recovery):
            assert (bands["recovery"]["start"], bands["recovery"]["end"]) == (recovery[0], recovery[-1] + 1)


def test_sample_hd_export_carries_the_labels(disturbed_dataset: Path, tmp_path: Path):
    from samplehd.dataset.container import read_episode
    from samplehd.export.sample_hd import export_samplehd

    out = tmp_path / "shd"
    export_samplehd(disturbed_dataset, out, images=False)
    labelled = 0
    for data in sorted(out.glob("sequences/*/data.json")):
        doc = json.loads(data.read_text())
        entry = _info(disturbed_dataset)["episodes"][doc["instruction_idx"]]
        ep = read_episode(disturbed_dataset / entry["file"], images="none")
        if "disturbance" not in ep.info:
            assert "disturbance" not in doc and "recovery" not in doc["sequence"][0]
            continue
        labelled += 1
        assert doc["disturbance"] == ep.info["disturbance"]
        flags = [fr["recovery"] for fr in doc["sequence"][:ep.num_frames]]
        assert flags == ep.frames["recovery"].astype(bool).tolist()
    assert labelled > 0


def test_a_disturbance_that_never_comes_leaves_the_plain_bytes(micro_dataset: Path, tmp_path: Path):
    """A short release drawn for a pick_up has no transport to cut short: the unit makes the episode
    again undisturbed, the file a dataset without disturbances writes (a disturbed rollout steps its
    recorded vectors, an undisturbed one its joint targets: their bytes would differ)."""
    from samplehd.dataset.reader import DatasetReader
    from samplehd.dataset.work import EpisodeUnit, run_episode_unit
    from samplehd.record.disturbances import DisturbanceConfig
    from samplehd.scene.spec import SceneSpec
    from samplehd.tasks.task import parse_task

    config = micro_config()
    scene = DatasetReader(micro_dataset).scenes[0]
    results = {}
    for name, disturbances in {"plain": None, "drawn": DisturbanceConfig(1.0, ("short_release",))}.items():
        (tmp_path / name / "episodes").mkdir(parents=True)
        unit = EpisodeUnit(out=str(tmp_path / name), file="e.h5", scene_index=0, slot=0, seed=5, family="pick_up",
                           task=parse_task({"type": "pick_up", "objects": [1]}), instruction="Pick it up.",
                           split="train", scene=SceneSpec.from_dict(scene["spec"]), directions=scene["directions"],
                           paths=config.paths, render=config.render, disturbances=disturbances)
        results[name] = run_episode_unit(unit)
    assert results["plain"].ok and results["drawn"].ok and results["drawn"].disturbance is None
    assert results["drawn"].sha256 == results["plain"].sha256

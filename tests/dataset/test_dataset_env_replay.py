"""`samplehd validate --replay` on the suite's small dataset: recorded actions sent open loop to the
environment reach the recorded outcome, and the command's exit codes (tests/envs/test_envs_replay_check.py:
every family)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import h5py
import pytest

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)
from samplehd.cli import main
from samplehd.dataset.reader import DatasetReader
from samplehd.envs.replay_check import replay_dataset
from samplehd.fileio import file_sha256


def test_recorded_actions_replay_to_the_recorded_outcome(micro_dataset: Path) -> None:
    report = replay_dataset(micro_dataset)
    assert len(report.episodes) == len(DatasetReader(micro_dataset).episodes) > 0
    failed = [(e.index, e.family) for e in report.episodes if not (e.recorded_success and e.replayed_success)]
    assert not failed, f"episodes that do not replay to success: {failed}"
    assert report.agrees
    # Steering vectors are float32 and turned into joint targets by IK: close, not bitwise.
    assert all(e.tcp_deviation < 0.005 for e in report.episodes), report.episodes


def _never_close(root: Path, index: int) -> None:
    """Rewrite an episode's recorded gripper commands to "open", keeping info.json's size and SHA-256
    true (so only the replay can tell)."""
    path = DatasetReader(root).episode_path(index)
    with h5py.File(path, "r+") as f:
        steering = f["frames/steering"][...]
        steering[:, 6] = 1.0
        f["frames/steering"][...] = steering
    info = json.loads((root / "info.json").read_text())
    info["episodes"][index].update(size=path.stat().st_size, sha256=file_sha256(path))
    (root / "info.json").write_text(json.dumps(info))


def test_validate_replay_exit_codes(micro_dataset: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["validate", str(micro_dataset), "--replay", "--episodes", "1"]) == 0
    assert "1 of 1 episodes replay to the recorded outcome" in capsys.readouterr().out
    copy = tmp_path / "ds"
    shutil.copytree(micro_dataset, copy)
    _never_close(copy, 0)
    assert main(["validate", str(copy)]) == 0  # the files are intact
    assert main(["validate", str(copy), "--replay", "--episodes", "1"]) == 1
    family = DatasetReader(copy).episodes[0].family
    assert f"episode 0 ({family}): recorded success, replayed failure" in capsys.readouterr().out

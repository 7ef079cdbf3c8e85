"""`samplehd export-mjcf`: a whole scene with keyframes, as MuJoCo's own loader reads it."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from samplehd.cli import main
from samplehd.dataset.reader import DatasetReader


def _hold(model: mujoco.MjModel, key: str, seconds: float = 0.5) -> tuple[mujoco.MjData, np.ndarray]:
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key(key).id)
    start = data.qpos.copy()
    for _ in range(int(seconds / model.opt.timestep)):
        mujoco.mj_step(model, data)
    return data, start


def test_dataset_episode_scene_loads_and_holds(micro_dataset: Path, tmp_path: Path) -> None:
    reader = DatasetReader(micro_dataset)
    out = tmp_path / "ep0.xml"
    assert main(["export-mjcf", "--dataset", str(micro_dataset), "--episode", "0", "--out", str(out)]) == 0
    model = mujoco.MjModel.from_xml_path(str(out))  # what `python -m mujoco.viewer --mjcf` loads
    scene = reader.scene(reader.episodes[0].scene_index)
    for i in range(len(scene["objects"])):
        assert model.body(f"object_{i}").id > 0
    assert [model.key(i).name for i in range(model.nkey)] == ["home", "final"]
    f = reader.frames(0, ["qpos", "act"])
    assert np.allclose(model.key("home").qpos, f["qpos"][0]) and np.allclose(model.key("home").act, f["act"][0])
    assert np.allclose(model.key("final").qpos, f["qpos"][-1])
    data, start = _hold(model, "home")
    assert np.abs(data.qpos[:6] - start[:6]).max() < 1e-3  # act holds the targets, ctrl 0 keeps them
    data, start = _hold(model, "final")
    assert np.abs(data.qpos - start).max() < 0.01


def test_scene_file_exports_with_home_keyframe(micro_dataset: Path, tmp_path: Path) -> None:
    from samplehd.robot.constants import HOME_QPOS

    scene_file = sorted((micro_dataset / "scenes").glob("*.json"))[0]
    out = tmp_path / "s.xml"
    assert main(["export-mjcf", "--scene", str(scene_file), "--out", str(out)]) == 0
    model = mujoco.MjModel.from_xml_path(str(out))
    assert model.nkey == 1 and np.allclose(model.key("home").qpos[:6], HOME_QPOS)
    assert np.allclose(model.key("home").act, HOME_QPOS)
    data, start = _hold(model, "home")
    assert np.abs(data.qpos - start).max() < 1e-3  # arm and objects stay put


@pytest.mark.parametrize("args, says", [
    (["--episode", "0"], "--dataset and --episode go together"),
    (["--episode", "99", "--dataset", "DS"], "--episode 99"),
    (["--scene", "DS/scenes.json"], "give one scene file"),
    (["--scene", "DS/nothing.json"], "cannot read"),
])
def test_bad_arguments_are_one_line_errors(micro_dataset: Path, tmp_path: Path, capsys, args, says) -> None:
    args = [a.replace("DS", str(micro_dataset)) for a in args]
    out = tmp_path / "x.xml"
    assert main(["export-mjcf", *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and says in err and not out.exists()

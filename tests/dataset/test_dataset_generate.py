"""Generation end to end on real scenes, planner and physics: format, reader, validation, determinism."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from dataset_helpers import fingerprint, micro_config

from samplehd.dataset.reader import DatasetReader
from samplehd.dataset.validate import validate_dataset
from samplehd.errors import ConfigError, DatasetError
from samplehd.record.episode import FRAME_FIELDS


def test_micro_dataset_is_valid_and_readable(micro_dataset: Path) -> None:
    problems, counts = validate_dataset(micro_dataset)
    assert problems == []
    reader = DatasetReader(micro_dataset)
    assert reader.complete and len(reader) == counts["episodes"] >= 1
    info = reader.info
    assert info["versions"]["mujoco"] and info["config"]["num_scenes"] == 2
    assert len(reader.scenes) == 2 and all("spec" in s for s in reader.scenes)
    for i, entry in enumerate(reader.episodes):
        ep = reader.episode(i)
        assert ep.success and ep.num_frames == entry.num_frames and ep.seed == entry.seed
        assert set(FRAME_FIELDS) <= set(ep.frames) and ep.images == {}
        inst = reader.instruction(i)
        assert inst["instruction_index"] == i and inst["family"] == ep.family
        assert inst["image_index"] == ep.scene_index
        meta = reader.episode_meta(i)
        assert meta.render is None and meta.images == {}
    # per-episode seeds are recorded, and split follows the scene
    cands = json.loads((micro_dataset / "candidates.json").read_text())["instructions"]
    assert len({c["seed"] for c in cands}) == len(cands)


def test_resume_of_a_finished_dataset_changes_nothing(micro_dataset: Path, tmp_path: Path) -> None:
    from samplehd.dataset.generate import generate_dataset

    copy = tmp_path / "ds"
    shutil.copytree(micro_dataset, copy)
    summary = generate_dataset(copy, micro_config(), resume=True)
    assert summary.units_run == 0
    assert fingerprint(copy) == fingerprint(micro_dataset)


def test_two_workers_give_the_same_dataset(micro_dataset: Path, tmp_path: Path) -> None:
    from samplehd.dataset.generate import generate_dataset
    from samplehd.workers import Backend

    out = tmp_path / "ds2"
    generate_dataset(out, micro_config(), Backend("local", 2))
    assert fingerprint(out) == fingerprint(micro_dataset)
    a, b = DatasetReader(micro_dataset), DatasetReader(out)
    for i in range(len(a)):  # bitwise identical physics states
        assert np.array_equal(a.frames(i, ["qpos"])["qpos"], b.frames(i, ["qpos"])["qpos"])


def test_existing_dataset_needs_resume_and_same_config(micro_dataset: Path) -> None:
    from samplehd.dataset.generate import generate_dataset

    # The library names its own parameters (the command line says them as --out, --resume).
    with pytest.raises(DatasetError, match="^out=.*pass `resume` to continue it") as exc:
        generate_dataset(micro_dataset, micro_config())
    assert exc.value.field == "out"
    with pytest.raises(ConfigError, match="num_scenes"):
        generate_dataset(micro_dataset, micro_config().__class__.from_dict({"num_scenes": 3}, base=micro_config()),
                         resume=True)


def test_unwritable_output_is_one_clear_error(tmp_path: Path) -> None:
    from samplehd.dataset.generate import generate_dataset

    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(DatasetError, match="not writable") as exc:
        generate_dataset(blocker / "ds", micro_config())
    assert "\n" not in str(exc.value)


def test_config_errors_name_file_and_field(tmp_path: Path) -> None:
    from samplehd.dataset.config import load_config, preset_config

    bad = tmp_path / "c.json"
    bad.write_text(json.dumps({"render": {"widht": 10}}))
    with pytest.raises(ConfigError, match=r"c\.json: render: unknown option\(s\) \['widht'\]"):
        load_config(bad, preset_config("tiny"))
    bad.write_text(json.dumps({"scenes": 3}))
    with pytest.raises(ConfigError, match=r"c\.json: unknown option\(s\) \['scenes'\]"):
        load_config(bad, preset_config("tiny"))
    bad.write_text(json.dumps({"instructions": {"per_scene": 0}}))
    with pytest.raises(ConfigError, match="per_scene"):
        load_config(bad, preset_config("tiny"))
    assert preset_config("sample-hd").num_scenes == 2000


def test_target_cutoff_counts_in_slot_major_order() -> None:
    from samplehd.dataset.generate import _Cutoff

    order = [(0, 0), (1, 0), (0, 1), (1, 1)]
    c = _Cutoff(order, target=2)
    c.record((0, 1), True)  # finished first, but not yet countable
    assert c.end is None
    c.record((0, 0), True)
    c.record((1, 0), False)
    assert c.end == 3 and c.needed(2) and not c.needed(3)


def test_units_run_scene_by_scene_unless_the_target_can_stop_early(micro_dataset: Path) -> None:
    from samplehd.dataset.config import dispatch_order
    from samplehd.dataset.journal import read_journal

    keys = [(0, 0), (1, 0), (0, 1), (1, 1), (0, 2)]
    assert dispatch_order(keys, 0) == [(0, 0), (0, 1), (0, 2), (1, 0), (1, 1)]
    assert dispatch_order(keys, 5) == dispatch_order(keys, 9) == sorted(keys)
    assert dispatch_order(keys, 4) == [(0, 0), (1, 0), (0, 1), (1, 1), (0, 2)]
    # the micro dataset (no target, one worker in this process) ran its units in that order
    ran = [(int(r["scene_index"]), int(r["slot"])) for r in read_journal(micro_dataset)]
    assert ran == sorted(ran) and len({k[0] for k in ran}) == 2


def test_a_kept_world_is_handed_out_as_a_fresh_compile(micro_dataset: Path) -> None:
    import mujoco

    from samplehd.dataset.work import unit_world
    from samplehd.motion.assist import compile_scene_with_assist
    from samplehd.scene.spec import SceneSpec

    def saved(model: mujoco.MjModel) -> bytes:
        buf = np.zeros(mujoco.mj_sizeModel(model), np.uint8)
        mujoco.mj_saveModel(model, None, buf)
        return buf.tobytes()

    scene = SceneSpec.from_dict(json.loads((micro_dataset / "scenes.json").read_text())["scenes"][0]["spec"])
    fresh_model, fresh_data = compile_scene_with_assist(scene, 0.002, "primitive")
    first, _ = unit_world(scene, 0.002, "primitive", True)
    first.geom_friction[:] = 0.0  # a unit that changes its model changes no other unit's
    second, data = unit_world(scene, 0.002, "primitive", True)
    assert second is not first and saved(second) == saved(fresh_model)
    for name in ("qpos", "qvel", "ctrl", "act", "xpos", "qacc"):
        assert np.array_equal(getattr(data, name), getattr(fresh_data, name)), name


def test_unknown_camera_fails_before_any_work() -> None:
    from samplehd.dataset.render import RenderConfig, check_cameras

    with pytest.raises(ConfigError, match=r"unknown camera\(s\) \['sceen'\]; valid: operator, scene, wrist"):
        check_cameras(RenderConfig("fast", 64, 36, ("sceen",)))
    check_cameras(RenderConfig("fast", 64, 36, ("scene", "wrist")))

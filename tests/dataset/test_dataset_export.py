"""Exports (LeRobot v3.0 layout as lerobot 0.6.1 reads it; SAMPLE-HD layout), stats and the CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from samplehd.cli import main
from samplehd.dataset.reader import DatasetReader


@pytest.fixture(scope="module")
def lerobot_export(rendered_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from samplehd.export.lerobot import export_lerobot

    out = tmp_path_factory.mktemp("lerobot") / "lr"
    export_lerobot(rendered_dataset, out, "samplehd/test", modalities=["rgb", "depth", "segmentation"])
    return out


def test_lerobot_layout(lerobot_export: Path, rendered_dataset: Path) -> None:
    import av
    import pyarrow.parquet as pq

    reader = DatasetReader(rendered_dataset)
    info = json.loads((lerobot_export / "meta" / "info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["fps"] == 20
    assert info["total_episodes"] == len(reader) and info["total_frames"] == sum(e.num_frames for e in reader.episodes)
    key = "observation.images.scene"
    assert info["features"][key]["dtype"] == "video" and info["features"][key]["shape"] == [36, 64, 3]
    for k in ("timestamp", "frame_index", "episode_index", "index", "task_index", "action", "observation.state"):
        assert k in info["features"]
    # What LeRobot's policies read (lerobot's dataset_to_policy_features): image/video features are
    # cameras and must be RGB; keys starting with "action" are actions and there must be one.
    cams = {k: f for k, f in info["features"].items() if f["dtype"] in ("image", "video")}
    assert list(cams) == [key] and all(f["shape"][2] == 3 for f in cams.values())
    assert [k for k in info["features"] if k.startswith("action")] == ["action"]
    data = pq.read_table(lerobot_export / "data/chunk-000/file-000.parquet")
    assert json.loads(data.schema.metadata[b"huggingface"])["info"]["features"]
    assert data.num_rows == info["total_frames"]
    assert data.column("index").to_pylist() == list(range(data.num_rows))
    eps = pq.read_table(lerobot_export / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    assert [e["episode_index"] for e in eps] == list(range(len(eps)))
    assert eps[0]["dataset_from_index"] == 0 and eps[-1]["dataset_to_index"] == data.num_rows
    for a, b in zip(eps, eps[1:], strict=False):
        assert a["dataset_to_index"] == b["dataset_from_index"]
        assert a[f"videos/{key}/to_timestamp"] == pytest.approx(b[f"videos/{key}/from_timestamp"])
    # state columns equal the episode's records
    first = reader.episode(eps[0]["samplehd/instruction_index"])
    state = np.array(data.column("observation.state").to_pylist()[: first.num_frames])
    assert np.allclose(state[:, :6], first.frames["joint_pos"], atol=1e-6)
    tasks = pq.read_table(lerobot_export / "meta/tasks.parquet")
    assert json.loads(tasks.schema.metadata[b"pandas"])["index_columns"] == ["task"]
    assert eps[0]["tasks"][0] in tasks.column("task").to_pylist()
    stats = json.loads((lerobot_export / "meta/stats.json").read_text())
    assert len(stats["action"]["mean"]) == 7 and np.array(stats[key]["mean"]).shape == (3, 1, 1)
    with av.open(str(lerobot_export / f"videos/{key}/chunk-000/file-000.mp4")) as c:
        assert sum(1 for _ in c.decode(video=0)) == info["total_frames"]


def test_lerobot_depth_and_segmentation_round_trip(lerobot_export: Path, rendered_dataset: Path) -> None:
    """Opt-in depth comes back within 1 mm and segmentation ids exactly, as uint16 arrays under keys that
    LeRobot's policies ignore."""
    import pyarrow.parquet as pq

    info = json.loads((lerobot_export / "meta" / "info.json").read_text())
    feats = info["features"]
    depth, seg = feats["depth.scene"], feats["segmentation.scene"]
    assert depth["dtype"] == seg["dtype"] == "uint16" and depth["shape"] == seg["shape"] == [36, 64]
    assert depth["info"]["unit"] == "mm"
    data = pq.read_table(lerobot_export / "data/chunk-000/file-000.parquet")
    hf = json.loads(data.schema.metadata[b"huggingface"])["info"]["features"]
    assert hf["depth.scene"] == {"shape": [36, 64], "dtype": "uint16", "_type": "Array2D"}
    reader = DatasetReader(rendered_dataset)
    eps = pq.read_table(lerobot_export / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    depth_col = data.column("depth.scene").to_numpy(zero_copy_only=False)
    seg_col = data.column("segmentation.scene").to_numpy(zero_copy_only=False)
    for e in eps:
        ep = reader.episode(e["samplehd/instruction_index"], images="load")
        for t in range(e["length"]):
            row = e["dataset_from_index"] + t
            mm = np.stack(depth_col[row]).astype(np.float64)
            assert np.abs(mm / 1000.0 - ep.images["scene"]["depth"][t]).max() <= 1e-3
            assert np.array_equal(np.stack(seg_col[row]), ep.images["scene"]["segmentation"][t])
    stats = json.loads((lerobot_export / "meta/stats.json").read_text())
    assert np.array(stats["depth.scene"]["mean"]).shape == (1,)
    assert 500 < stats["depth.scene"]["mean"][0] < 5000  # millimetres
    assert stats["segmentation.scene"]["max"][0] >= 3  # ids, not scaled


def test_lerobot_default_is_rgb_only(rendered_dataset: Path, tmp_path: Path) -> None:
    assert main(["export", "lerobot", str(rendered_dataset), "--out", str(tmp_path / "d")]) == 0
    info = json.loads((tmp_path / "d" / "meta" / "info.json").read_text())
    assert not [k for k in info["features"] if k.startswith(("depth.", "segmentation."))]
    assert info["features"]["observation.images.scene"]["dtype"] == "video"


def test_lerobot_selection_errors_are_one_line(rendered_dataset: Path, tmp_path: Path,
                                              capsys: pytest.CaptureFixture) -> None:
    base = ["export", "lerobot", str(rendered_dataset), "--out"]
    assert main([*base, str(tmp_path / "a"), "--cameras", "wrist"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--cameras ['wrist']: not stored" in err and "stored cameras: scene" in err
    assert main([*base, str(tmp_path / "b"), "--modalities", "normals"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "valid: rgb, depth, segmentation" in err
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()
    # Only depth: no videos, one image feature.
    assert main([*base, str(tmp_path / "c"), "--modalities", "depth", "--frames-per-file", "500"]) == 0
    info = json.loads((tmp_path / "c" / "meta" / "info.json").read_text())
    assert [k for k in info["features"] if k.startswith(("observation.images", "depth"))] == ["depth.scene"]
    assert info["video_path"] is None and not (tmp_path / "c" / "videos").exists()
    assert len(list((tmp_path / "c" / "data").glob("*/*.parquet"))) > 1  # files split by --frames-per-file


def test_stats_counts_and_plots(micro_dataset: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from samplehd.dataset.stats import dataset_stats

    s = dataset_stats(micro_dataset)
    reader = DatasetReader(micro_dataset)
    assert sum(s["families"].values()) == len(reader)
    assert sum(s["classes"].values()) == sum(len(sc["objects"]) for sc in reader.scenes)
    assert s["frames_per_episode"]["max"] == max(e.num_frames for e in reader.episodes)
    assert main(["stats", str(micro_dataset), "--out", str(tmp_path / "plots")]) == 0
    assert (tmp_path / "plots" / "families.png").exists() and (tmp_path / "plots" / "stats.json").exists()
    assert "frames per episode" in capsys.readouterr().out


def test_validate_cli_exit_codes(micro_dataset: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    import shutil

    assert main(["validate", str(micro_dataset)]) == 0
    copy = tmp_path / "ds"
    shutil.copytree(micro_dataset, copy)
    path = DatasetReader(copy).episode_path(0)
    path.write_bytes(path.read_bytes()[:1000])
    assert main(["validate", str(copy)]) == 1
    assert path.name in capsys.readouterr().out
    assert main(["generate", "--preset", "tiny", "--out", str(micro_dataset)]) == 2  # exists: needs --resume


def test_lerobot_export_records_its_env_and_splits(lerobot_export: Path, rendered_dataset: Path) -> None:
    from samplehd.benchmark.lerobot_tabletop import LeRobotTabletop
    from samplehd.envs.lerobot_contract import env_options_from_export
    from samplehd.language.levels import LEVELS, held_out_for

    info = json.loads((lerobot_export / "meta" / "info.json").read_text())
    record = json.loads((lerobot_export / "meta" / "samplehd.json").read_text())
    splits = {p.stem: json.loads(p.read_text()) for p in (lerobot_export / "meta" / "splits").glob("*.json")}
    train, test = splits["train"], splits["test"]
    assert train + test == list(range(info["total_episodes"])) and record["episodes"] == splits
    # Per level: the train episodes that do not move or say what the level holds out (export order: train first).
    reader = DatasetReader(rendered_dataset)
    order = [i for i, e in enumerate(reader.episodes) if e.split == "train"]
    for level in LEVELS:
        keep = [n for n, i in enumerate(order)
                if not held_out_for(level, reader.instruction(i), reader.scene(reader.episodes[i].scene_index))]
        assert splits[f"train_{level}"] == keep and set(keep) <= set(train)
    assert set(splits["train_L1"]) <= set.intersection(*(set(splits[f"train_{lv}"]) for lv in LEVELS[1:]))
    assert f"0:{len(train)}" == info["splits"]["train"]
    assert record["state_layout"]["observation.state"] == info["features"]["observation.state"]["names"]
    options = env_options_from_export(lerobot_export)
    assert options["families"] == sorted({e.family for e in DatasetReader(rendered_dataset).episodes})
    env = LeRobotTabletop(options["families"][0], options)
    for cam in options["cameras"]:
        shape = info["features"][f"observation.images.{cam}"]["shape"]
        assert list(env.observation_space["pixels"][cam].shape) == shape
    assert env.metadata["render_fps"] == info["fps"]


def test_lerobot_export_carries_camera_intrinsics_and_extrinsics(lerobot_export: Path, rendered_dataset: Path) -> None:
    """meta/samplehd.json gives each exported camera's K and where its extrinsics are (world-fixed cameras:
    a column of the episodes table). Projecting an object's recorded position with them lands on that
    object's pixels in the exported segmentation."""
    import pyarrow.parquet as pq

    record = json.loads((lerobot_export / "meta" / "samplehd.json").read_text())
    cams = record["cameras"]
    assert set(cams) == {"scene"}  # the cameras the dataset stores
    eps = pq.read_table(lerobot_export / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    data = pq.read_table(lerobot_export / "data/chunk-000/file-000.parquet")
    seg_col = data.column("segmentation.scene").to_numpy(zero_copy_only=False)
    reader = DatasetReader(rendered_dataset)
    k = np.array(cams["scene"]["intrinsics"])
    assert k.shape == (3, 3) and (cams["scene"]["width"], cams["scene"]["height"]) == (64, 36)
    assert cams["scene"]["extrinsics"]["per_episode"] == "samplehd/extrinsics.scene"
    hits = total = 0
    for e in eps:
        pose = np.array(e["samplehd/extrinsics.scene"]).reshape(4, 4)
        ep = reader.episode(e["samplehd/instruction_index"], images="none")
        seg = np.stack(seg_col[e["dataset_from_index"]])
        for i, p in enumerate(ep.frames["object_pos"][0]):
            cam = (p - pose[:3, 3]) @ pose[:3, :3]  # world → camera axes (looks along -z, y up)
            u = k[0, 0] * cam[0] / -cam[2] + k[0, 2]
            v = -k[1, 1] * cam[1] / -cam[2] + k[1, 2]
            total += 1
            near = seg[max(0, int(v) - 1):int(v) + 2, max(0, int(u) - 1):int(u) + 2]  # 3x3 px around it
            hits += bool((near == 3 + i).any())
    # an object's origin may hide behind another object or the arm (8 of 12 exact pixels hit here);
    # a wrong K or pose hits next to none
    assert hits >= total / 2, (hits, total)


def test_wrist_camera_extrinsics_are_its_mount_on_the_gripper(micro_dataset: Path) -> None:
    """The wrist camera moves with the gripper: the gripper body's pose times the recorded mount is the
    camera's pose at any frame (here the middle of an episode, the arm far from home)."""
    import mujoco

    from samplehd.export.camera_geometry import CameraGeometry
    from samplehd.render.renderer import camera_pose
    from samplehd.scene.spec import SceneSpec, compile_scene

    reader = DatasetReader(micro_dataset)
    entry = reader.episodes[0]
    ep = reader.episode(0, images="none")
    scene = reader.scene(entry.scene_index)
    geometry = CameraGeometry(["scene", "wrist"], {"scene": (64, 36), "wrist": (64, 36)})
    fixed = geometry.episode_extrinsics(scene, ep.frames["qpos"][0])
    record = geometry.record()
    assert set(fixed) == {"scene"} and record["wrist"]["extrinsics"]["moves_with"] == "robot_gripper"
    mount = np.array(record["wrist"]["extrinsics"]["mount"])
    model, d = compile_scene(SceneSpec.from_dict(scene["spec"]), robot_look="primitive")
    body = model.body("robot_gripper").id
    poses = []
    for t in (0, ep.num_frames // 2):
        d.qpos[:] = ep.frames["qpos"][t]
        mujoco.mj_kinematics(model, d)
        mujoco.mj_camlight(model, d)
        frame = np.eye(4)
        frame[:3, :3], frame[:3, 3] = d.xmat[body].reshape(3, 3), d.xpos[body]
        poses.append(camera_pose(model, d, "wrist"))
        assert np.allclose(frame @ mount, poses[-1], atol=1e-6), t
        assert np.allclose(np.array(fixed["scene"]).reshape(4, 4), camera_pose(model, d, "scene"))  # world-fixed
    assert np.linalg.norm(poses[1][:3, 3] - poses[0][:3, 3]) > 0.05  # the wrist camera moved


def test_lerobot_native_depth_video_round_trips(rendered_dataset: Path, tmp_path: Path) -> None:
    """--depth-video: depth as LeRobot's native depth feature (lossless 12-bit log codes in an HEVC
    gray12le video, is_depth_map in its info): the decoded codes are exactly the exported ones and give
    the stored depth back within the quantization step (about 1 mm at 1.5 m)."""
    import av
    import pyarrow.parquet as pq

    from samplehd.export.lerobot import depth_codes, depth_from_codes, export_lerobot

    out = tmp_path / "lr"
    res = export_lerobot(rendered_dataset, out, "samplehd/test", cameras=["scene"], modalities=["rgb", "depth"],
                         depth_video=True)
    key = "observation.images.scene_depth"
    assert res["videos"] == ["observation.images.scene", key] and res["arrays"] == []
    meta = json.loads((out / "meta" / "info.json").read_text())
    feat = meta["features"][key]
    assert feat["dtype"] == "video" and feat["shape"] == [36, 64, 1]
    info = feat["info"]
    assert info["is_depth_map"] is True and info["video.pix_fmt"] == "gray12le" and info["video.codec"] == "hevc"
    assert info["depth_unit"] == "mm"
    assert (info["video.depth_min"], info["video.depth_max"], info["video.shift"], info["video.use_log"]) == (
        0.01, 10.0, 3.5, True)
    eps = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    with av.open(str(out / f"videos/{key}/chunk-000/file-000.mp4")) as video:
        codes = np.stack([f.to_ndarray(format="gray12le") for f in video.decode(video=0)])
    reader = DatasetReader(rendered_dataset)
    assert len(codes) == sum(e["length"] for e in eps)
    for e in eps:
        first = round(e[f"videos/{key}/from_timestamp"] * meta["fps"])
        depth = reader.episode(e["samplehd/instruction_index"], images="load").images["scene"]["depth"][:]
        got = codes[first:first + e["length"]]
        assert np.array_equal(got, depth_codes(depth))  # lossless
        near = (depth > 0.05) & (depth < 3.0)
        err = np.abs(depth_from_codes(got) - depth)[near]
        assert err.max() <= 0.5 * 3.3e-4 * (3.0 + 3.5) + 1e-6  # half a log step at 3 m


def test_depth_video_without_depth_is_one_line_and_writes_nothing(rendered_dataset: Path, tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """--depth-video exports the depth as a video: without depth among --modalities there is none to
    write, which is said in one line (exit 2) rather than ignored."""
    out = tmp_path / "lr"
    assert main(["export", "lerobot", str(rendered_dataset), "--out", str(out), "--depth-video"]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "--depth-video" in err and "depth" in err.split(":", 2)[-1] and not out.exists()

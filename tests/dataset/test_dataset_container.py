"""The HDF5 episode container: round trip, atomic writes, lazy images, damaged files reported."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import numpy as np
import pytest

from samplehd.dataset.container import FrameImages, read_episode, read_meta, write_episode
from samplehd.dataset.reader import DatasetReader
from samplehd.dataset.validate import validate_dataset
from samplehd.errors import DatasetError
from samplehd.tasks.task import Task


def test_round_trip_is_exact_and_atomic(rendered_dataset: Path, tmp_path: Path) -> None:
    reader = DatasetReader(rendered_dataset)
    ep = reader.episode(0, images="load")
    out = tmp_path / "e.h5"
    info = write_episode(out, ep, {"slot": 1})
    assert [p.name for p in tmp_path.iterdir()] == ["e.h5"]  # no temporary file left
    back = read_episode(out)
    for k, v in ep.frames.items():
        assert back.frames[k].dtype == v.dtype and np.array_equal(back.frames[k], v)
    for cam, mods in ep.images.items():
        for mod, arr in mods.items():
            lazy = back.images[cam][mod]
            assert isinstance(lazy, FrameImages) and len(lazy) == ep.num_frames
            assert np.array_equal(lazy[5], arr[5])  # one chunk per frame, exact (depth float32 too)
    assert info.num_frames == ep.num_frames and info.size == out.stat().st_size
    assert read_meta(out)["slot"] == 1


def test_rendered_images_match_the_render_settings(rendered_dataset: Path) -> None:
    reader = DatasetReader(rendered_dataset)
    assert validate_dataset(rendered_dataset)[0] == []
    img = reader.image(0, "scene", "rgb", 0)
    depth = reader.image(0, "scene", "depth", 0)
    seg = reader.image(0, "scene", "segmentation", 0)
    assert img.shape == (36, 64, 3) and img.dtype == np.uint8
    assert depth.dtype == np.float32 and np.isfinite(depth).all() and depth.min() > 0
    assert seg.dtype == np.uint8 and seg.max() >= 3  # an object is visible
    assert reader.episode_meta(0).render["width"] == 64


def test_episode_meta_is_typed_and_reads_back_as_the_file_stores_it(rendered_dataset: Path) -> None:
    """The reader's episode attributes are typed (the task a Task) and write back as read_meta reads them."""
    reader = DatasetReader(rendered_dataset)
    for k, entry in enumerate(reader.episodes):
        meta = reader.episode_meta(k)
        raw = read_meta(reader.episode_path(k))
        raw["instruction_index"] = k
        assert meta.to_dict() == raw and list(meta.to_dict()) == list(raw)
        assert isinstance(meta.task, Task) and meta.task.family == meta.family == entry.family
        assert meta.task.to_program_dict() == raw["task"] and meta.num_frames == entry.num_frames
        assert meta.images == {"scene": ("depth", "rgb", "segmentation")} and meta.extra == {"split": entry.split}


def test_rerender_matches_fresh_render_and_resumes(rendered_dataset: Path, tmp_path: Path) -> None:
    """Images rendered from stored states (set qpos/qvel/act, mj_forward; no re-simulation) are
    reproduced exactly, and running rerender again skips finished episodes."""
    from samplehd.dataset.render import RenderConfig
    from samplehd.dataset.rerender import rerender_dataset
    from samplehd.scene.spec import SceneSpec, compile_scene

    copy = tmp_path / "ds"
    shutil.copytree(rendered_dataset, copy)
    res = rerender_dataset(copy, RenderConfig("fast", 64, 36))
    assert res["rendered"] == 0 and res["skipped"] == res["episodes"]
    reader = DatasetReader(rendered_dataset)
    ep = reader.episode(0)
    model, _ = compile_scene(SceneSpec.from_dict(reader.scene(ep.scene_index)["spec"]))
    picks = [0, ep.num_frames // 2, ep.num_frames - 1]
    again = RenderConfig("fast", 64, 36).images(model, {k: v[picks] for k, v in ep.frames.items()})
    for mod in ("rgb", "depth", "segmentation"):
        stored = np.stack([ep.images["scene"][mod][t] for t in picks])
        assert np.array_equal(again["scene"][mod], stored), mod


@pytest.mark.parametrize("damage", ["truncate", "flip", "delete", "extra"])
def test_validate_reports_damaged_episodes(micro_dataset: Path, tmp_path: Path, damage: str) -> None:
    copy = tmp_path / "ds"
    shutil.copytree(micro_dataset, copy)
    path = DatasetReader(copy).episode_path(0)
    if damage == "truncate":
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 2])
    elif damage == "flip":
        data = bytearray(path.read_bytes())
        data[len(data) // 2] ^= 0xFF
        path.write_bytes(bytes(data))
    elif damage == "delete":
        path.unlink()
    else:
        (path.parent / f".{path.name}.tmp-1").write_bytes(b"partial")
    problems, _ = validate_dataset(copy)
    assert problems and all("\n" not in p for p in problems)
    assert any(path.name in p for p in problems)
    if damage == "truncate":
        with pytest.raises(DatasetError, match="truncated or corrupted"):
            read_episode(path)


def test_reader_tolerates_a_dataset_being_written(micro_dataset: Path, tmp_path: Path) -> None:
    import json

    copy = tmp_path / "ds"
    shutil.copytree(micro_dataset, copy)
    info = json.loads((copy / "info.json").read_text())
    info["status"] = "in_progress"
    (copy / "info.json").write_text(json.dumps(info))
    (copy / "scenes.json").unlink()
    (copy / "instructions.json").unlink()
    (copy / "episodes" / ".s000009_00.h5.tmp-123").write_bytes(b"half")
    reader = DatasetReader(copy)
    assert not reader.complete
    assert len(reader.scenes) == 2
    assert len(reader) == len(DatasetReader(micro_dataset))
    assert reader.instructions[0]["instruction"] == DatasetReader(micro_dataset).instructions[0]["instruction"]
    assert reader.episode(0).num_frames > 0


def test_replace_keeps_frames(micro_dataset: Path, tmp_path: Path) -> None:
    ep = DatasetReader(micro_dataset).episode(0)
    ep2 = dataclasses.replace(ep, info={"note": "x"})
    write_episode(tmp_path / "x.h5", ep2)
    assert read_episode(tmp_path / "x.h5").info == {"note": "x"}


def test_image_chunks_are_plain_gzip_any_hdf5_reader_decodes(rendered_dataset: Path, tmp_path: Path) -> None:
    """Image chunks are deflated outside HDF5 and written as they are: each one must be a zlib stream
    that HDF5's own gzip filter (and plain zlib) decodes to the exact frame."""
    import zlib

    import h5py

    ep = DatasetReader(rendered_dataset).episode(0, images="load")
    out = tmp_path / "e.h5"
    write_episode(out, ep)
    with h5py.File(out, "r") as f:
        for cam, mods in ep.images.items():
            for mod, arr in mods.items():
                ds = f[f"images/{cam}/{mod}"]
                assert ds.compression == "gzip" and not ds.shuffle and ds.chunks == (1, *arr.shape[1:])
                assert ds.dtype == (np.uint8 if mod != "depth" else np.float32)
                assert np.array_equal(ds[()], arr), f"{cam}/{mod}: HDF5's gzip filter decodes other values"
                last = len(arr) - 1
                mask, raw = ds.id.read_direct_chunk((last, *(0,) * (arr.ndim - 1)))
                assert mask == 0 and zlib.decompress(raw) == np.ascontiguousarray(arr[last], ds.dtype).tobytes()


@pytest.mark.parametrize("every", [1, 2])
def test_frames_deflated_as_rendered_write_the_same_file(world, tmp_path: Path, every: int) -> None:
    """`generate` deflates each frame as soon as it is rendered: the same images (decoded) and the same file
    bytes as rendering every frame first and writing the arrays."""
    from samplehd.dataset.render import RenderConfig
    from samplehd.record.episode import FRAME_FIELDS, Episode
    from samplehd.render.deflated import DeflatedFrames

    model, data = world
    t = 4
    sizes = {"N": 0, "nq": model.nq, "nv": model.nv, "na": model.na}
    frames = {k: np.zeros((t, *(sizes.get(d, d) for d in shape)), dtype) for k, (shape, dtype) in FRAME_FIELDS.items()}
    frames["qpos"] = np.repeat(data.qpos[None], t, axis=0)
    frames["qpos"][:, 0] += np.linspace(0.0, 0.6, t)  # swing the arm
    config = RenderConfig("fast", 32, 24, ("operator", "wrist"), every=every)
    raw = config.images(model, frames)
    packed = config.images(model, frames, deflated=True)
    digests = []
    for name, images in (("raw", raw), ("packed", packed)):
        for cam in ("operator", "wrist"):
            for mod in ("rgb", "depth", "segmentation"):
                stream = images[cam][mod]
                inner = stream.images if every > 1 else stream
                assert isinstance(inner, DeflatedFrames) == (name == "packed")
                want = raw[cam][mod].images if every > 1 else raw[cam][mod]
                assert np.array_equal(np.asarray(inner), want)
        ep = Episode(scene_index=0, instruction_index=0, family="pick", seed=0, subtasks=("Pick",), frames=frames,
                     success=True, info={}, images=images)
        digests.append(write_episode(tmp_path / f"{name}.h5", ep, render=config.to_dict()).sha256)
    assert digests[0] == digests[1]
    back = read_episode(tmp_path / "packed.h5", images="lazy")
    assert back.images["operator"]["segmentation"].dtype == np.uint8


def test_a_large_file_is_hashed_beside_its_writing_and_a_failed_write_leaves_no_thread(tmp_path: Path) -> None:
    """Files of several MB are hashed on a helper thread while they are written: the digest is the file's,
    and a write that fails raises the one-line error with no thread or temporary file left behind."""
    import hashlib
    import threading

    from samplehd.dataset import container
    from samplehd.record.episode import FRAME_FIELDS, Episode

    t = 6
    sizes = {"N": 0, "nq": 3, "nv": 3, "na": 0}
    frames = {k: np.zeros((t, *(sizes.get(d, d) for d in shape)), dtype) for k, (shape, dtype) in FRAME_FIELDS.items()}
    noise = np.random.default_rng(0).integers(0, 256, (t, 480, 640, 3), dtype=np.uint8)  # incompressible
    ep = Episode(scene_index=0, instruction_index=0, family="pick", seed=0, subtasks=("Pick",), frames=frames,
                 success=True, info={}, images={"scene": {"rgb": noise}})
    out = tmp_path / "big.h5"
    info = write_episode(out, ep, render={"mode": "fast"})
    assert info.size == out.stat().st_size >= container._THREADED_DIGEST_BYTES
    assert info.sha256 == hashlib.sha256(out.read_bytes()).hexdigest()
    missing = tmp_path / "no-such-folder" / "big.h5"
    with pytest.raises(DatasetError, match="no-such-folder"):
        write_episode(missing, ep, render={"mode": "fast"})
    assert not [th for th in threading.enumerate() if th.name == "samplehd-digest"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.h5"]

"""Export a samplehd dataset to the LeRobot v3.0 layout, written with pyarrow and PyAV.

lerobot 0.5+ needs Python ≥ 3.12 (samplehd runs on 3.11), so the files are written here directly and
``scripts/check_lerobot.sh`` proves that ``LeRobotDataset(repo_id, root=...)`` from lerobot 0.6.1
loads them. Layout (paths and keys as lerobot's ``datasets/utils.py``)::

    meta/info.json                                   codebase_version v3.0, fps, features, totals, paths
    meta/stats.json                                  per feature min/max/mean/std/count/q01..q99
    meta/tasks.parquet                               task (index) → task_index
    meta/episodes/chunk-000/file-000.parquet         one row per episode: length, tasks, data and video
                                                     file indices and ranges, samplehd ids
    data/chunk-XXX/file-YYY.parquet                  one row per frame
    videos/observation.images.<camera>/chunk-XXX/file-YYY.mp4   the episodes' RGB, concatenated

Frame features: ``observation.state`` (6 joint positions [rad] + gripper opening [m]),
``observation.tcp_pose`` (TCP position [m] + quaternion w,x,y,z), ``action`` (SAMPLE-HD's 7-D steering
vector), ``action.joint`` (commanded joint targets [rad] + gripper command), ``subtask_index``,
``grasped_object``, and LeRobot's ``timestamp``, ``frame_index``, ``episode_index``, ``index``,
``task_index``; the task is the instruction text. Training episodes come first, then test, and
``info.json`` ``splits`` gives both ranges. Depth and segmentation stay in the HDF5 episodes (LeRobot
videos are lossy).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.dataset.staging import export_source, staged_directory
from samplehd.errors import DatasetError

__all__ = ["CODEBASE_VERSION", "export_lerobot"]

CODEBASE_VERSION = "v3.0"
CHUNKS_SIZE = 1000
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
VIDEO_PATH = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
EPISODES_PATH = "meta/episodes/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
_QUANTILES = (0.01, 0.10, 0.50, 0.90, 0.99)

_VECTOR_FEATURES: dict[str, tuple[int, list[str]]] = {
    "observation.state": (7, [f"joint_{i}" for i in range(6)] + ["gripper_opening"]),
    "observation.tcp_pose": (7, ["x", "y", "z", "qw", "qx", "qy", "qz"]),
    "action": (7, ["vx", "vy", "vz", "wx", "wy", "wz", "gripper"]),
    "action.joint": (7, [f"joint_{i}" for i in range(6)] + ["gripper"]),
}
_SCALAR_FEATURES = {"subtask_index": "int64", "grasped_object": "int64", "timestamp": "float32",
                    "frame_index": "int64", "episode_index": "int64", "index": "int64", "task_index": "int64"}


def _episode_columns(frames: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return {
        "observation.state": np.concatenate([frames["joint_pos"], frames["gripper_opening"][:, None]], 1),
        "observation.tcp_pose": np.concatenate([frames["tcp_pos"], frames["tcp_quat"]], 1),
        "action": frames["steering"],
        "action.joint": np.concatenate([frames["command_joint_pos"], frames["gripper_command"][:, None]], 1),
        "subtask_index": frames["subtask_index"].astype(np.int64),
        "grasped_object": frames["grasped_object"].astype(np.int64),
    }


def _hf_features() -> dict[str, Any]:
    feats: dict[str, Any] = {}
    for k, (n, _) in _VECTOR_FEATURES.items():
        feats[k] = {"feature": {"dtype": "float32", "_type": "Value"}, "length": n, "_type": "List"}
    for k, dtype in _SCALAR_FEATURES.items():
        feats[k] = {"dtype": dtype, "_type": "Value"}
    return {"info": {"features": feats}}


class _Stats:
    """Running min/max/sum/sumsq and a kept sample for quantiles, per feature."""

    def __init__(self) -> None:
        self.parts: dict[str, list[np.ndarray]] = {}

    def add(self, key: str, values: np.ndarray) -> None:
        self.parts.setdefault(key, []).append(np.asarray(values, dtype=np.float64).reshape(len(values), -1))

    def result(self) -> dict[str, dict[str, list]]:
        out = {}
        for key, parts in self.parts.items():
            x = np.concatenate(parts, 0)
            d = {"min": x.min(0), "max": x.max(0), "mean": x.mean(0), "std": x.std(0)}
            for q in _QUANTILES:
                d[f"q{int(round(q * 100)):02d}"] = np.quantile(x, q, axis=0)
            out[key] = {k: v.tolist() for k, v in d.items()}
            out[key]["count"] = [int(len(x))]
        return out


def _image_stats(sample: list[np.ndarray]) -> dict[str, list]:
    x = np.stack(sample).astype(np.float64) / 255.0  # (n, H, W, 3)
    flat = x.reshape(-1, 3)
    d = {"min": flat.min(0), "max": flat.max(0), "mean": flat.mean(0), "std": flat.std(0)}
    for q in _QUANTILES:
        d[f"q{int(round(q * 100)):02d}"] = np.quantile(flat, q, axis=0)
    out = {k: [[[float(c)]] for c in v] for k, v in d.items()}
    out["count"] = [int(len(sample))]
    return out


def _write_parquet(path: Path, columns: dict[str, Any], hf: dict[str, Any] | None = None) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    arrays, names = [], []
    for k, v in columns.items():
        if isinstance(v, np.ndarray) and v.ndim == 2:
            flat = pa.array(v.astype(np.float32).ravel())
            arrays.append(pa.FixedSizeListArray.from_arrays(flat, v.shape[1]))
        else:
            arrays.append(pa.array(v))
        names.append(k)
    table = pa.Table.from_arrays(arrays, names=names)
    if hf is not None:
        table = table.replace_schema_metadata({"huggingface": json.dumps(hf)})
    path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(table, path)


def _write_tasks(path: Path, tasks: list[str]) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table({"task_index": pa.array(range(len(tasks)), pa.int64()), "task": pa.array(tasks, pa.string())})
    pandas_meta = {"index_columns": ["task"], "column_indexes": [{"name": None, "field_name": None,
                   "pandas_type": "unicode", "numpy_type": "object", "metadata": {"encoding": "UTF-8"}}],
                   "columns": [{"name": "task_index", "field_name": "task_index", "pandas_type": "int64",
                                "numpy_type": "int64", "metadata": None},
                               {"name": "task", "field_name": "task", "pandas_type": "unicode",
                                "numpy_type": "object", "metadata": None}],
                   "attributes": {}, "creator": {"library": "pyarrow", "version": pa.__version__},
                   "pandas_version": "2.2.0"}
    table = table.replace_schema_metadata({"pandas": json.dumps(pandas_meta)})
    path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(table, path)


def export_lerobot(root: str | Path, out: str | Path, repo_id: str = "samplehd/dataset", codec: str | None = None,
                   frames_per_file: int = 200_000, cameras: list[str] | None = None,
                   progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """Write the LeRobot v3.0 layout of a complete samplehd dataset into ``out`` (atomically: a
    temporary folder renamed at the end).

    Args:
        root: the samplehd dataset.
        out: the new LeRobot dataset folder (must not exist).
        repo_id: recorded in the export for ``LeRobotDataset(repo_id, root=out)``.
        codec: video encoder (default: AV1 as LeRobot, else H.264).
        frames_per_file: frames per data/video file before a new file is started.
        cameras: RGB cameras to export as videos (default: every camera stored with RGB).
        progress: ``progress(done, total)`` per episode.

    Returns:
        ``{episodes, frames, tasks, videos: [keys], codec}``.
    """
    from samplehd.dataset.video import VideoWriter, pick_codec

    reader, out = export_source(root, out)
    render = reader.info.get("render") or {}
    stored = list(render.get("cameras", [])) if render.get("mode", "none") != "none" and "rgb" in render.get(
        "modalities", []) else []
    cams = cameras if cameras is not None else stored
    missing = [c for c in cams if c not in stored]
    if missing:
        raise DatasetError(f"--cameras {missing}: not stored in {root}; stored RGB cameras: {stored or 'none'}")
    width, height = int(render.get("width", 0)), int(render.get("height", 0))
    if cams and (width % 2 or height % 2):
        raise DatasetError(f"{root}: images are {width}x{height}; videos need even sides (rerender at an even size)")
    fps = int(round(float(reader.config.get("paths", {}).get("control_hz", 20.0))))
    codec = pick_codec(codec) if cams else None
    order = sorted(range(len(reader)), key=lambda i: (reader.episodes[i].split != "train", i))
    tasks: dict[str, int] = {}
    stats = _Stats()
    image_samples: dict[str, list[np.ndarray]] = {c: [] for c in cams}
    ep_rows: list[dict[str, Any]] = []
    buffer: dict[str, list[np.ndarray]] = {}
    writers: dict[str, Any] = {}
    chunk = file = 0
    in_file = 0  # frames in the current data/video file
    index = 0

    def flush_file() -> None:
        if buffer:
            cols = {k: np.concatenate(v, 0) for k, v in buffer.items()}
            _write_parquet(tmp / DATA_PATH.format(chunk_index=chunk, file_index=file), cols, _hf_features())
            buffer.clear()
        for w in writers.values():
            w.close()
        writers.clear()

    with staged_directory(out) as tmp:
        for n, i in enumerate(order):
            entry = reader.episodes[i]
            ep = reader.episode(i)
            t = ep.num_frames
            if in_file and in_file + t > frames_per_file:
                flush_file()
                file += 1
                if file == CHUNKS_SIZE:
                    chunk, file = chunk + 1, 0
                in_file = 0
            text = str(reader.instruction(i).get("instruction", ""))
            task_index = tasks.setdefault(text, len(tasks))
            cols = _episode_columns(ep.frames)
            cols["timestamp"] = (np.arange(t) / fps).astype(np.float32)
            cols["frame_index"] = np.arange(t, dtype=np.int64)
            cols["episode_index"] = np.full(t, n, dtype=np.int64)
            cols["index"] = np.arange(index, index + t, dtype=np.int64)
            cols["task_index"] = np.full(t, task_index, dtype=np.int64)
            for k, v in cols.items():
                buffer.setdefault(k, []).append(v)
                stats.add(k, v)
            row: dict[str, Any] = {
                "episode_index": n, "tasks": [text], "length": t, "data/chunk_index": chunk, "data/file_index": file,
                "dataset_from_index": index, "dataset_to_index": index + t,
            }
            for cam in cams:
                key = f"observation.images.{cam}"
                if key not in writers:
                    writers[key] = VideoWriter(tmp / VIDEO_PATH.format(video_key=key, chunk_index=chunk,
                                                                       file_index=file), width, height, fps, codec)
                rgb = ep.images[cam]["rgb"]
                frames_rgb = rgb[:]
                writers[key].write(frames_rgb)
                image_samples[cam].extend(frames_rgb[:: max(1, t // 4)][:4])
                row.update({f"videos/{key}/chunk_index": chunk, f"videos/{key}/file_index": file,
                            f"videos/{key}/from_timestamp": in_file / fps,
                            f"videos/{key}/to_timestamp": (in_file + t) / fps})
            row.update({"meta/episodes/chunk_index": 0, "meta/episodes/file_index": 0,
                        "samplehd/instruction_index": i, "samplehd/scene_index": entry.scene_index,
                        "samplehd/family": entry.family, "samplehd/split": entry.split})
            ep_rows.append(row)
            index += t
            in_file += t
            if progress:
                progress(n + 1, len(order))
        flush_file()
        _write_tasks(tmp / "meta" / "tasks.parquet", list(tasks))
        _write_parquet(tmp / EPISODES_PATH.format(chunk_index=0, file_index=0),
                       {k: [r[k] for r in ep_rows] for k in (ep_rows[0] if ep_rows else {})})
        all_stats = stats.result()
        for cam in cams:
            if image_samples[cam]:
                all_stats[f"observation.images.{cam}"] = _image_stats(image_samples[cam])
        (tmp / "meta" / "stats.json").write_text(json.dumps(all_stats, indent=1))
        features: dict[str, Any] = {}
        for k, (dim, names) in _VECTOR_FEATURES.items():
            features[k] = {"dtype": "float32", "shape": [dim], "names": names}
        for cam in cams:
            features[f"observation.images.{cam}"] = {
                "dtype": "video", "shape": [height, width, 3], "names": ["height", "width", "channels"],
                "info": {"video.height": height, "video.width": width,
                         "video.codec": {"libsvtav1": "av1", "libx264": "h264"}.get(codec or "", codec),
                         "video.pix_fmt": "yuv420p", "video.fps": fps, "video.channels": 3, "has_audio": False,
                         "is_depth_map": False}}
        for k, dtype in _SCALAR_FEATURES.items():
            features[k] = {"dtype": dtype, "shape": [1], "names": None}
        n_train = sum(1 for i in order if reader.episodes[i].split == "train")
        splits = {"train": f"0:{n_train}"}
        if n_train < len(order):
            splits["test"] = f"{n_train}:{len(order)}"
        info = {"codebase_version": CODEBASE_VERSION, "fps": fps, "features": features,
                "total_episodes": len(order), "total_frames": index, "total_tasks": len(tasks),
                "chunks_size": CHUNKS_SIZE, "data_files_size_in_mb": 100, "video_files_size_in_mb": 200,
                "data_path": DATA_PATH, "video_path": VIDEO_PATH if cams else None, "robot_type": "ur5e",
                "splits": splits}
        (tmp / "meta" / "info.json").write_text(json.dumps(info, indent=4))
        (tmp / "meta" / "samplehd.json").write_text(json.dumps(
            {"repo_id": repo_id, "source": str(Path(root).resolve()), "source_format": reader.info.get(
                "format_version"), "versions": reader.info.get("versions")}, indent=1))
    return {"episodes": len(order), "frames": index, "tasks": len(tasks), "videos": [f"observation.images.{c}"
                                                                                      for c in cams], "codec": codec}

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
    meta/splits/train.json, test.json                episode indices of each split (JSON list), for
                                                     ``lerobot-train --dataset.episodes``
    meta/splits/train_L1.json … train_L4.json        the train episodes that training for a generalisation
                                                     level may use (L1: none of the held-out classes,
                                                     colour–class combinations and paraphrases; L2–L4:
                                                     none of that level's; ``samplehd.language.levels``)
    meta/samplehd.json                               source, versions, ``episodes`` per split, ``state_layout``,
                                                     ``families``, ``episode_lengths`` and ``env``: the
                                                     ``samplehd/Tabletop-v0`` options (cameras, size, render
                                                     preset, control mode and rates, families, scene, checker)
                                                     whose observations match the export; the LeRobot env
                                                     plugin builds its environment from it

Frame features: ``observation.state`` (6 joint positions [rad] + gripper opening [m]),
``observation.tcp_pose`` (TCP position [m] + quaternion w,x,y,z), ``action`` (SAMPLE-HD's 7-D steering
vector; the only feature whose key starts with ``action``, so LeRobot's policies see one action),
``command.joint`` (commanded joint targets [rad] + gripper command), ``subtask_index``,
``grasped_object``, and LeRobot's ``timestamp``, ``frame_index``, ``episode_index``, ``index``,
``task_index``; the task is the instruction text. A dataset made with disturbances adds the per-frame
flags ``disturbance_active`` and ``recovery`` (int64, 0 in undisturbed episodes), the episode columns
``samplehd/disturbance.{kind, frame, failure, recovery_first, recovery_last, outcome, success}`` ("" /
-1 where an episode has none) and ``disturbances`` (config and counts) in ``meta/samplehd.json``.
Training episodes come first, then test, and
``info.json`` ``splits`` gives both ranges.

Images: by default only RGB, as a video feature ``observation.images.<camera>`` per camera (lossy
AV1/H.264, as LeRobot): LeRobot's policies (ACT, Diffusion, ...) take every ``image``/``video``
feature for an RGB camera, so nothing else is one. Depth and segmentation are opt-in
(``modalities``) and stay exact, as uint16 arrays in the data parquet (``datasets.Array2D``,
``(H, W)``) under keys that LeRobot's policies ignore (neither ``observation.*`` nor ``action*``):

* ``depth.<camera>``: uint16 millimetres (rounded: within 0.5 mm; 0 = no data, clipped at
  65.535 m); ``info``: ``unit: "mm"``.
* ``segmentation.<camera>``: uint16 instance ids, exact (0 background, 1 table, 2 robot, 3 + i
  scene object i).

lerobot 0.6.1 returns them as (H, W) integer tensors; their stats are scalars in the same units.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.dataset.container import CameraRender, camera_settings
from samplehd.dataset.lerobot_contract import (
    ACTION,
    COMMAND_JOINT,
    DEPTH_CODE_MAX,
    DEPTH_VIDEO_PARAMS,
    EXPORT_RECORD,
    STATE,
    TCP_POSE,
    VECTOR_FEATURES,
    depth_video_key,
    image_feature_key,
)
from samplehd.errors import DatasetError
from samplehd.export.camera_geometry import CameraGeometry
from samplehd.export.staging import export_source, staged_directory
from samplehd.language.levels import LEVELS, held_out_for
from samplehd.render.renderer import MODALITIES
from samplehd.render.video import VideoWriter, pick_codec

__all__ = ["CODEBASE_VERSION", "SPLIT_PATH", "depth_codes", "depth_from_codes", "export_lerobot"]

CODEBASE_VERSION = "v3.0"
CHUNKS_SIZE = 1000
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
VIDEO_PATH = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
EPISODES_PATH = "meta/episodes/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
SPLIT_PATH = "meta/splits/{split}.json"  # episode indices of a split, for lerobot-train --dataset.episodes
DATA_FILE_MB = 100  # a data file with image columns is closed once it holds this much image data
_QUANTILES = (0.01, 0.10, 0.50, 0.90, 0.99)

_SCALAR_FEATURES = {"subtask_index": "int64", "grasped_object": "int64", "timestamp": "float32",
                    "frame_index": "int64", "episode_index": "int64", "index": "int64", "task_index": "int64"}
# Per-frame disturbance flags (samplehd.record.disturbances), exported when the dataset was made with
# disturbances; keys that LeRobot's policies ignore (neither observation.* nor action*).
_LABEL_FEATURES = {"disturbance_active": "int64", "recovery": "int64"}
# Per-episode disturbance labels in the episodes parquet (-1 / "" where an episode has none).
_LABEL_EPISODE_KEYS = ("kind", "frame", "failure", "recovery_first", "recovery_last", "outcome", "success")


def _episode_labels(info: dict[str, Any], success: bool) -> dict[str, Any]:
    """The ``samplehd/disturbance.*`` columns of an episode's row in the episodes parquet."""
    lab = info.get("disturbance") or {}
    row = {f"samplehd/disturbance.{k}": lab.get(k, -1 if k in ("frame", "recovery_first", "recovery_last")
                                                      else "") for k in _LABEL_EPISODE_KEYS[:-1]}
    row["samplehd/disturbance.success"] = bool(lab.get("success", success))
    return row


def _episode_columns(frames: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return {
        STATE: np.concatenate([frames["joint_pos"], frames["gripper_opening"][:, None]], 1),
        TCP_POSE: np.concatenate([frames["tcp_pos"], frames["tcp_quat"]], 1),
        ACTION: frames["steering"],
        COMMAND_JOINT: np.concatenate([frames["command_joint_pos"], frames["gripper_command"][:, None]], 1),
        "subtask_index": frames["subtask_index"].astype(np.int64),
        "grasped_object": frames["grasped_object"].astype(np.int64),
    }


def _hf_features(array_shapes: dict[str, tuple[int, int]], labels: bool = False) -> dict[str, Any]:
    feats: dict[str, Any] = {}
    for k, names in VECTOR_FEATURES.items():
        feats[k] = {"feature": {"dtype": "float32", "_type": "Value"}, "length": len(names), "_type": "List"}
    for k, dtype in {**_SCALAR_FEATURES, **(_LABEL_FEATURES if labels else {})}.items():
        feats[k] = {"dtype": dtype, "_type": "Value"}
    for k, shape in array_shapes.items():
        feats[k] = {"shape": list(shape), "dtype": "uint16", "_type": "Array2D"}
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


def _image_stats(sample: list[np.ndarray], rgb: bool) -> dict[str, list]:
    """Stats of sampled frames: RGB (H, W, 3) per channel in LeRobot's (3, 1, 1) layout and in [0, 1]
    (as LeRobot returns RGB); depth/segmentation (H, W) as one value (shape (1,)) in native units."""
    x = np.stack(sample).astype(np.float64) / (255.0 if rgb else 1.0)
    flat = x.reshape(-1, 3 if rgb else 1)
    d = {"min": flat.min(0), "max": flat.max(0), "mean": flat.mean(0), "std": flat.std(0)}
    for q in _QUANTILES:
        d[f"q{int(round(q * 100)):02d}"] = np.quantile(flat, q, axis=0)
    out = {k: ([[[float(c)]] for c in v] if rgb else [float(c) for c in v]) for k, v in d.items()}
    out["count"] = [int(len(sample))]
    return out


def _as_uint16(mod: str, frames: np.ndarray) -> np.ndarray:
    """Depth [m] → uint16 millimetres (0 = no data, clipped at 65.535 m); segmentation ids → uint16."""
    if mod == "depth":
        mm = np.round(np.nan_to_num(np.asarray(frames, np.float64), nan=0.0, posinf=65535.0, neginf=0.0) * 1000.0)
        return np.clip(mm, 0, 65535).astype(np.uint16)
    return np.asarray(frames).astype(np.uint16)


def depth_codes(depth: np.ndarray) -> np.ndarray:
    """Depth [m] → LeRobot's 12-bit depth codes (uint16, log scale, :data:`DEPTH_VIDEO_PARAMS`); no data
    (0, inf, nan) and depths outside [depth_min, depth_max] are clipped to the ends."""
    p = DEPTH_VIDEO_PARAMS
    lo, hi = math.log(p["depth_min"] + p["shift"]), math.log(p["depth_max"] + p["shift"])
    d = np.nan_to_num(np.asarray(depth, np.float64), nan=0.0, posinf=p["depth_max"], neginf=0.0)
    norm = (np.log(np.maximum(d, 0.0) + p["shift"]) - lo) / (hi - lo)
    return np.clip(np.rint(norm * DEPTH_CODE_MAX), 0, DEPTH_CODE_MAX).astype(np.uint16)


def depth_from_codes(codes: np.ndarray) -> np.ndarray:
    """LeRobot's 12-bit depth codes → depth [m] (``lerobot.datasets.depth_utils.dequantize_depth``'s inverse)."""
    p = DEPTH_VIDEO_PARAMS
    lo, hi = math.log(p["depth_min"] + p["shift"]), math.log(p["depth_max"] + p["shift"])
    d = np.exp(np.asarray(codes, np.float64) * (hi - lo) / DEPTH_CODE_MAX + lo) - p["shift"]
    return np.clip(d, p["depth_min"], p["depth_max"])


def _uint16_lists(frames16: np.ndarray) -> Any:
    """(T, H, W) uint16 frames as a pyarrow ``list<list<uint16>>`` column (``datasets.Array2D`` storage)."""
    import pyarrow as pa

    t, h, w = frames16.shape
    rows = pa.ListArray.from_arrays(pa.array(np.arange(0, t * h * w + 1, w, dtype=np.int32)),
                                    pa.array(np.ascontiguousarray(frames16).ravel(), pa.uint16()))
    return pa.ListArray.from_arrays(pa.array(np.arange(0, t * h + 1, h, dtype=np.int32)), rows)


def _table(columns: dict[str, Any], hf: dict[str, Any] | None = None) -> Any:
    """A pyarrow table: 2-D arrays as fixed-size float32 lists, pyarrow arrays as they are, everything
    else through ``pa.array``."""
    import pyarrow as pa

    arrays, names = [], []
    for k, v in columns.items():
        if isinstance(v, np.ndarray) and v.ndim == 2:
            flat = pa.array(v.astype(np.float32).ravel())
            arrays.append(pa.FixedSizeListArray.from_arrays(flat, v.shape[1]))
        elif isinstance(v, pa.Array):
            arrays.append(v)
        else:
            arrays.append(pa.array(v))
        names.append(k)
    table = pa.Table.from_arrays(arrays, names=names)
    if hf is not None:
        table = table.replace_schema_metadata({"huggingface": json.dumps(hf)})
    return table


def _write_parquet(path: Path, columns: dict[str, Any], hf: dict[str, Any] | None = None) -> None:
    import pyarrow.parquet as pq

    path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(_table(columns, hf), path)


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


def _streams(root: str | Path, render: dict[str, Any] | None, cameras: list[str] | None,
             modalities: list[str] | None) -> tuple[dict[str, CameraRender], list[tuple[str, str]]]:
    """The per-camera settings and the (camera, modality) streams to export; one-line errors."""
    settings = camera_settings(render)
    cams = list(dict.fromkeys(cameras)) if cameras is not None else list(settings)
    missing = [c for c in cams if c not in settings]
    if missing:
        raise DatasetError(f"cameras={missing}: not stored in {root}; stored cameras: "
                           f"{', '.join(settings) or 'none (rerender adds images)'}", field="cameras")
    mods = list(dict.fromkeys(modalities)) if modalities is not None else ["rgb"]
    bad = [m for m in mods if m not in MODALITIES]
    if bad:
        raise DatasetError(f"modalities={bad}: valid: {', '.join(MODALITIES)}", field="modalities")
    streams = [(c, m) for c in cams for m in settings[c]["modalities"] if m in mods]
    if modalities is not None:
        absent = [m for m in mods if all(mod != m for _, mod in streams)]
        if absent:
            stored = {c: settings[c]["modalities"] for c in cams}
            raise DatasetError(f"modalities={absent}: not stored for cameras {cams} in {root}; stored: {stored}",
                               field="modalities")
    for cam, mod in streams:
        w, h = settings[cam]["width"], settings[cam]["height"]
        if mod == "rgb" and (w % 2 or h % 2):
            raise DatasetError(f"{root}: camera {cam!r} images are {w}x{h}; videos need even sides (rerender it "
                               f"at an even size, or leave it out with `cameras` / `modalities`)")
    return settings, streams


def _env_record(config: dict[str, Any], settings: dict[str, CameraRender], cameras: list[str],
                families: list[str]) -> dict[str, Any]:
    """``{"env": options}``: the ``samplehd/Tabletop-v0`` options (EnvConfig field names) that give
    observations like the exported ones, or ``{"env_note": why}`` when no single env can."""
    if not cameras:
        return {"env_note": "no RGB camera was exported: a LeRobot policy of this export has no image input"}
    sizes = {(settings[c]["width"], settings[c]["height"]) for c in cameras}
    presets = {settings[c]["mode"] for c in cameras}
    if len(sizes) > 1 or len(presets) > 1:
        return {"env_note": f"cameras {cameras} differ in size {sorted(sizes)} or preset {sorted(presets)}; "
                            "the environment renders every camera alike (export them at one size)"}
    (width, height), = sizes
    paths = config.get("paths", {})
    env = {"obs_mode": "rgb", "cameras": cameras, "width": width, "height": height, "render_preset": presets.pop(),
           "control_mode": "steering", "control_hz": float(paths.get("control_hz", 20.0)),
           "physics_hz": float(paths.get("physics_hz", 500.0)), "families": families,
           "scene": config.get("scene", {}), "grasp_assist": bool(paths.get("grasp_assist", True))}
    if "checker" in paths:
        env["checker"] = paths["checker"]
    return {"env": env}


def _level_train_lists(reader: Any, train: list[int]) -> dict[str, list[int]]:
    """``{"train_L1": [...], ...}``: the export's train episodes that training for each level may use
    (:func:`samplehd.language.levels.held_out_for`); ``train`` holds the dataset's indices in export order."""
    scenes = {s["image_index"]: s for s in reader.scenes}
    out: dict[str, list[int]] = {f"train_{level}": [] for level in LEVELS}
    for n, i in enumerate(train):
        instruction, scene = reader.instruction(i), scenes.get(reader.episodes[i].scene_index, {})
        for level in LEVELS:
            if not held_out_for(level, instruction, scene):
                out[f"train_{level}"].append(n)
    return out


def export_lerobot(root: str | Path, out: str | Path, repo_id: str = "samplehd/dataset", codec: str | None = None,
                   frames_per_file: int = 200_000, cameras: list[str] | None = None,
                   progress: Callable[[int, int], None] | None = None,
                   modalities: list[str] | None = None, depth_video: bool = False) -> dict[str, Any]:
    """Write the LeRobot v3.0 layout of a complete samplehd dataset into ``out`` (atomically: a
    temporary folder renamed at the end).

    Args:
        root: the samplehd dataset.
        out: the new LeRobot dataset folder (must not exist).
        repo_id: recorded in the export for ``LeRobotDataset(repo_id, root=out)``.
        codec: video encoder (default: AV1 as LeRobot, else H.264).
        frames_per_file: frames per data/video file before a new file is started (a data file with
            depth/segmentation images is also closed once it holds ``DATA_FILE_MB`` of them).
        cameras: cameras to export (default: every stored camera).
        progress: ``progress(done, total)`` per episode.
        modalities: which of rgb (video features), depth and segmentation (uint16 arrays under
            ``depth.<camera>`` / ``segmentation.<camera>``) to export (default: rgb only).
        depth_video: depth as LeRobot's native depth video ``observation.images.<camera>_depth``
            (lossless 12-bit log codes, :data:`~samplehd.dataset.lerobot_contract.DEPTH_VIDEO_PARAMS`)
            instead of the uint16 millimetre array ``depth.<camera>``; LeRobot's policies take every
            video feature as an image input.

    Returns:
        ``{episodes, frames, tasks, videos: [keys], images: [keys], codec}``.

    Raises:
        DatasetError: not a complete dataset, ``out`` exists, a camera or modality is not stored, an
            RGB camera has odd image sides, or ``depth_video`` without depth among ``modalities``.
    """
    import pyarrow.parquet as pq


    if depth_video and "depth" not in (modalities or ()):
        raise DatasetError(f"depth_video=True: it writes the exported depth as a video, but modalities="
                           f"{modalities or ['rgb']} exports no depth; add depth to modalities", field="depth_video")
    reader, out = export_source(root, out)
    settings, streams = _streams(root, reader.info.get("render"), cameras, modalities)
    videos = [(c, m) for c, m in streams if m == "rgb" or (depth_video and m == "depth")]
    images = [(c, m) for c, m in streams if (c, m) not in videos]
    image_keys = [image_feature_key(c, m) for c, m in images]

    def key_of(cam: str, mod: str) -> str:
        return depth_video_key(cam) if depth_video and mod == "depth" else image_feature_key(cam, mod)
    fps = int(round(float(reader.config.get("paths", {}).get("control_hz", 20.0))))
    if codec is not None:
        codec = pick_codec(codec)  # a bad --codec is refused even where no video would be written
    codec = (codec or pick_codec()) if any(m == "rgb" for _, m in videos) else None
    order = sorted(range(len(reader)), key=lambda i: (reader.episodes[i].split != "train", i))
    tasks: dict[str, int] = {}
    stats = _Stats()
    samples: dict[str, list[np.ndarray]] = {key_of(c, m): [] for c, m in streams}
    ep_rows: list[dict[str, Any]] = []
    writers: dict[str, Any] = {}
    data: dict[str, Any] = {}  # the open parquet writer of the current data file
    chunk = file = 0
    in_file = 0  # frames in the current data/video file
    in_bytes = 0  # image bytes in the current data file
    index = 0
    labels = isinstance(reader.config.get("disturbances"), dict)  # made with disturbances
    hf = _hf_features({image_feature_key(c, m): (settings[c]["height"], settings[c]["width"]) for c, m in images},
                      labels)
    exported = list(dict.fromkeys(c for c, _ in streams))
    geometry = CameraGeometry(exported, {c: (settings[c]["width"], settings[c]["height"]) for c in exported})

    def flush_file() -> None:
        if "writer" in data:
            data.pop("writer").close()
        for w in writers.values():
            w.close()
        writers.clear()

    with staged_directory(out, source=reader.root) as tmp:
        for n, i in enumerate(order):
            entry = reader.episodes[i]
            ep = reader.episode(i)
            t = ep.num_frames
            if in_file and (in_file + t > frames_per_file or in_bytes >= DATA_FILE_MB * 1_000_000):
                flush_file()
                file += 1
                if file == CHUNKS_SIZE:
                    chunk, file = chunk + 1, 0
                in_file = in_bytes = 0
            text = str(reader.instruction(i).get("instruction", ""))
            task_index = tasks.setdefault(text, len(tasks))
            cols: dict[str, Any] = _episode_columns(ep.frames)
            cols["timestamp"] = (np.arange(t) / fps).astype(np.float32)
            cols["frame_index"] = np.arange(t, dtype=np.int64)
            cols["episode_index"] = np.full(t, n, dtype=np.int64)
            cols["index"] = np.arange(index, index + t, dtype=np.int64)
            cols["task_index"] = np.full(t, task_index, dtype=np.int64)
            if labels:
                for k in _LABEL_FEATURES:
                    cols[k] = np.asarray(ep.frames.get(k, np.zeros(t)), dtype=np.int64)
            for k, v in cols.items():
                stats.add(k, v)
            picks = slice(None, None, max(1, t // 4))
            for cam, mod in images:
                key = image_feature_key(cam, mod)
                frames16 = _as_uint16(mod, ep.images[cam][mod][:])
                in_bytes += frames16.nbytes
                cols[key] = _uint16_lists(frames16)
                samples[key].extend(frames16[picks][:4])
            if "writer" not in data:
                path = tmp / DATA_PATH.format(chunk_index=chunk, file_index=file)
                path.parent.mkdir(parents=True, exist_ok=True)
                table = _table(cols, hf)
                data["writer"] = pq.ParquetWriter(path, table.schema)
                data["writer"].write_table(table)
            else:
                data["writer"].write_table(_table(cols, hf))
            row: dict[str, Any] = {
                "episode_index": n, "tasks": [text], "length": t, "data/chunk_index": chunk, "data/file_index": file,
                "dataset_from_index": index, "dataset_to_index": index + t,
            }
            for cam, mod in videos:
                key = key_of(cam, mod)
                if key not in writers:
                    writers[key] = VideoWriter(tmp / VIDEO_PATH.format(video_key=key, chunk_index=chunk,
                                                                       file_index=file),
                                               settings[cam]["width"], settings[cam]["height"], fps, codec,
                                               pix_fmt="yuv420p" if mod == "rgb" else "gray12le")
                frames = ep.images[cam][mod][:]
                if mod == "depth":
                    writers[key].write(depth_codes(frames))
                    samples[key].extend(_as_uint16(mod, frames[picks][:4]))  # stats in millimetres
                else:
                    writers[key].write(frames)
                    samples[key].extend(frames[picks][:4])
                row.update({f"videos/{key}/chunk_index": chunk, f"videos/{key}/file_index": file,
                            f"videos/{key}/from_timestamp": in_file / fps,
                            f"videos/{key}/to_timestamp": (in_file + t) / fps})
            row.update({"meta/episodes/chunk_index": 0, "meta/episodes/file_index": 0,
                        "samplehd/instruction_index": i, "samplehd/scene_index": entry.scene_index,
                        "samplehd/family": entry.family, "samplehd/split": entry.split})
            if exported:
                extrinsics = geometry.episode_extrinsics(reader.scene(entry.scene_index), ep.frames["qpos"][0])
                row.update({f"samplehd/extrinsics.{c}": v for c, v in extrinsics.items()})
            if labels:
                row.update(_episode_labels(ep.info, ep.success))
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
        for cam, mod in streams:
            key = key_of(cam, mod)
            if samples[key]:
                all_stats[key] = _image_stats(samples[key], rgb=mod == "rgb")
        (tmp / "meta" / "stats.json").write_text(json.dumps(all_stats, indent=1))
        features: dict[str, Any] = {}
        for k, names in VECTOR_FEATURES.items():
            features[k] = {"dtype": "float32", "shape": [len(names)], "names": names}
        for cam, mod in streams:
            w, h = settings[cam]["width"], settings[cam]["height"]
            key, names = key_of(cam, mod), ["height", "width", "channels"]
            if (cam, mod) in videos and mod == "depth":
                info = {"video.height": h, "video.width": w, "video.codec": "hevc", "video.pix_fmt": "gray12le",
                        "video.fps": fps, "video.channels": 1, "has_audio": False, "is_depth_map": True,
                        "depth_unit": "mm",  # of its stats; LeRobot decodes the frames to millimetres
                        **{f"video.{k}": v for k, v in DEPTH_VIDEO_PARAMS.items()}}
                features[key] = {"dtype": "video", "shape": [h, w, 1], "names": names, "info": info}
            elif mod == "rgb":
                info = {"video.height": h, "video.width": w,
                        "video.codec": {"libsvtav1": "av1", "libx264": "h264"}.get(codec or "", codec),
                        "video.pix_fmt": "yuv420p", "video.fps": fps, "video.channels": 3, "has_audio": False,
                        "is_depth_map": False}
                features[key] = {"dtype": "video", "shape": [h, w, 3], "names": names, "info": info}
            elif mod == "depth":
                features[key] = {
                    "dtype": "uint16", "shape": [h, w], "names": ["height", "width"],
                    "info": {"unit": "mm", "samplehd.source": f"images/{cam}/depth (float32 m), rounded to mm"}}
            else:
                features[key] = {
                    "dtype": "uint16", "shape": [h, w], "names": ["height", "width"],
                    "info": {"samplehd.ids": "0 background, 1 table, 2 robot, 3 + i scene object i"}}
        for k, dtype in {**_SCALAR_FEATURES, **(_LABEL_FEATURES if labels else {})}.items():
            features[k] = {"dtype": dtype, "shape": [1], "names": None}
        n_train = sum(1 for i in order if reader.episodes[i].split == "train")
        splits = {"train": f"0:{n_train}"}
        if n_train < len(order):
            splits["test"] = f"{n_train}:{len(order)}"
        info = {"codebase_version": CODEBASE_VERSION, "fps": fps, "features": features,
                "total_episodes": len(order), "total_frames": index, "total_tasks": len(tasks),
                "chunks_size": CHUNKS_SIZE, "data_files_size_in_mb": DATA_FILE_MB, "video_files_size_in_mb": 200,
                "data_path": DATA_PATH, "video_path": VIDEO_PATH if videos else None, "robot_type": "ur5e",
                "splits": splits}
        (tmp / "meta" / "info.json").write_text(json.dumps(info, indent=4))
        episodes = {"train": list(range(n_train)), "test": list(range(n_train, len(order)))}
        episodes.update(_level_train_lists(reader, order[:n_train]))
        for split, ids in episodes.items():
            (tmp / SPLIT_PATH.format(split=split)).parent.mkdir(parents=True, exist_ok=True)
            (tmp / SPLIT_PATH.format(split=split)).write_text(json.dumps(ids) + "\n")
        record = {"repo_id": repo_id, "source": str(Path(root).resolve()),
                  "source_format": reader.info.get("format_version"), "versions": reader.info.get("versions"),
                  "episodes": episodes, "state_layout": dict(VECTOR_FEATURES),
                  "families": sorted({reader.episodes[i].family for i in order}),
                  "episode_lengths": {"max": max((r["length"] for r in ep_rows), default=0),
                                      "mean": float(np.mean([r["length"] for r in ep_rows])) if ep_rows else 0.0}}
        record.update(_env_record(reader.config, settings, [c for c, m in videos if m == "rgb"], record["families"]))
        if exported:
            record["cameras"] = geometry.record()
        if labels:
            record["disturbances"] = {"config": reader.config["disturbances"],
                                      "counts": reader.info.get("counts", {}).get("disturbances", {})}
        (tmp / EXPORT_RECORD).write_text(json.dumps(record, indent=1))
    return {"episodes": len(order), "frames": index, "tasks": len(tasks),
            "videos": [key_of(c, m) for c, m in videos], "arrays": image_keys, "codec": codec}

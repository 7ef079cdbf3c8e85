"""Replay of recorded episodes: restore the physics state of any frame and re-render it from any
camera at any resolution, without re-simulating; MP4 videos and per-subtask contact sheets."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import mujoco
import numpy as np

from samplehd.errors import DatasetError
from samplehd.record.episode import Episode

__all__ = ["contact_sheet", "render_episode", "restore_frame", "subtask_contact_sheet", "write_mp4"]


def restore_frame(model: mujoco.MjModel, data: mujoco.MjData, frames: dict[str, np.ndarray], k: int) -> None:
    """Set ``data`` to the recorded state of frame ``k`` (qpos, qvel, act, time) and run mj_forward."""
    if frames["qpos"].shape[-1] != model.nq or frames["qvel"].shape[-1] != model.nv:
        raise DatasetError(f"episode states have nq={frames['qpos'].shape[-1]}, nv={frames['qvel'].shape[-1]}, "
                           f"but the model has nq={model.nq}, nv={model.nv}; compile the episode's own scene")
    data.qpos[:] = frames["qpos"][k]
    data.qvel[:] = frames["qvel"][k]
    if model.na:
        data.act[:] = frames["act"][k]
    data.time = float(frames["time"][k])
    mujoco.mj_forward(model, data)


def render_episode(
    model: mujoco.MjModel,
    episode: Episode,
    cameras: Sequence[str] = ("operator",),
    modalities: Sequence[str] = ("rgb",),
    width: int = 640,
    height: int = 360,
    preset: str = "fast",
    frames: Sequence[int] | None = None,
) -> dict[str, dict[str, np.ndarray]]:
    """Render recorded frames: ``images[camera][modality]`` with the frame index as first axis.

    Args:
        model: the episode's compiled scene.
        episode: the recorded episode.
        cameras: camera names.
        modalities: any of rgb, depth, segmentation.
        width: image width [px].
        height: image height [px].
        preset: render preset (fast, hd).
        frames: frame indices to render (default: all).
    """
    from samplehd.render.renderer import SceneRenderer

    idx = range(episode.num_frames) if frames is None else frames
    data = mujoco.MjData(model)
    out: dict[str, dict[str, list[np.ndarray]]] = {c: {m: [] for m in modalities} for c in cameras}
    with SceneRenderer(model, width, height, preset) as r:
        for k in idx:
            restore_frame(model, data, episode.frames, k)
            for cam in cameras:
                imgs = r.render(data, cam, list(modalities))
                for m in modalities:
                    out[cam][m].append(imgs[m])
    return {c: {m: np.stack(v) for m, v in mods.items()} for c, mods in out.items()}


def write_mp4(path: str | Path, rgb: np.ndarray, fps: float = 20.0) -> None:
    """Write (T, H, W, 3) uint8 frames as an H.264 MP4 [fps frames per second]."""
    import av

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    h, w = rgb.shape[1:3]
    with av.open(str(path), mode="w") as container:
        stream = container.add_stream("libx264", rate=int(round(fps)))
        stream.width, stream.height = w - w % 2, h - h % 2
        stream.pix_fmt = "yuv420p"
        stream.options = {"crf": "20"}
        for frame in rgb:
            f = av.VideoFrame.from_ndarray(np.ascontiguousarray(frame[: stream.height, : stream.width]), format="rgb24")
            for packet in stream.encode(f):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)


def contact_sheet(images: Sequence[np.ndarray], cols: int = 4, labels: Sequence[str] | None = None) -> np.ndarray:
    """Tile RGB images (same size) into one image, optionally labelled."""
    from PIL import Image, ImageDraw

    h, w = images[0].shape[:2]
    rows = -(-len(images) // cols)
    sheet = np.full((rows * h, cols * w, 3), 255, np.uint8)
    for k, img in enumerate(images):
        r, c = divmod(k, cols)
        sheet[r * h:(r + 1) * h, c * w:(c + 1) * w] = img[..., :3]
    if labels:
        im = Image.fromarray(sheet)
        draw = ImageDraw.Draw(im)
        for k, text in enumerate(labels):
            r, c = divmod(k, cols)
            draw.rectangle([c * w, r * h, c * w + 7 * len(text) + 6, r * h + 14], fill=(0, 0, 0))
            draw.text((c * w + 3, r * h + 1), text, fill=(255, 255, 255))
        sheet = np.asarray(im)
    return sheet


def subtask_contact_sheet(model: mujoco.MjModel, episode: Episode, camera: str = "operator", width: int = 320,
                          height: int = 180, preset: str = "fast", cols: int = 4) -> np.ndarray:
    """One image per subtask (its last frame, the first for ApproachGrasp's start), labelled, tiled."""
    sub = episode.frames["subtask_index"]
    picks, labels = [], []
    if episode.num_frames == 0:
        return np.full((height, width, 3), 255, np.uint8)
    for s, name in enumerate(episode.subtasks):
        ks = np.flatnonzero(sub == s)
        if len(ks):
            picks.append(int(ks[-1]))
            labels.append(f"{s}: {name}")
    imgs = render_episode(model, episode, (camera,), ("rgb",), width, height, preset, picks)[camera]["rgb"]
    return contact_sheet(list(imgs), cols, labels)

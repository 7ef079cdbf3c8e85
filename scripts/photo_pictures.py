"""Make the photo-preset pictures of docs/RENDERING.md: one scene in the fast, hd and photo presets side by side, and a
contact sheet of photo frames of one recorded episode.

Usage: python scripts/photo_pictures.py DATASET OUT_DIR [--scene-seed 25] [--episode 0]
(DATASET: a directory written by ``samplehd generate``; the pictures are rendered from its stored states.)
"""

from __future__ import annotations

import argparse
from pathlib import Path

import mujoco
import numpy as np
from PIL import Image, ImageDraw

import samplehd  # noqa: F401  (chooses the GL backend)
from samplehd.dataset.reader import DatasetReader
from samplehd.render.contact_sheet import contact_sheet
from samplehd.render.renderer import SceneRenderer
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import sample_scene
from samplehd.scene.spec import SceneSpec, compile_scene


def _label(img: np.ndarray, text: str) -> np.ndarray:
    im = Image.fromarray(img)
    d = ImageDraw.Draw(im)
    d.rectangle((0, 0, 8 * len(text) + 10, 18), fill=(0, 0, 0))
    d.text((5, 3), text, fill=(255, 255, 255))
    return np.asarray(im)


def presets_side_by_side(seed: int, out: Path, width: int = 640, height: int = 360) -> None:
    model, data = compile_scene(sample_scene(0, seed, SceneConfig()).scene)
    tiles = []
    for preset in ("fast", "hd", "photo"):
        with SceneRenderer(model, width, height, preset) as r:
            tiles.append(_label(r.render(data, "scene")["rgb"], preset))
    Image.fromarray(np.concatenate(tiles, axis=1)).save(out)


def episode_sheet(dataset: Path, index: int, out: Path, count: int = 8, width: int = 480, height: int = 270) -> None:
    reader = DatasetReader(dataset)
    entry = reader.episodes[index]
    frames = reader.frames(index, ["qpos", "qvel", "act", "subtask_index"])
    model, data = compile_scene(SceneSpec.from_dict(dict(reader.scene(entry.scene_index)["spec"])))
    n = len(frames["qpos"])
    picks = np.unique(np.linspace(0, n - 1, count).round().astype(int))
    images, labels = [], []
    with SceneRenderer(model, width, height, "photo") as r:
        for k in picks:
            data.qpos[:] = frames["qpos"][k]
            data.qvel[:] = frames["qvel"][k]
            if model.na:
                data.act[:] = frames["act"][k]
            mujoco.mj_forward(model, data)
            images.append(r.render(data, "scene")["rgb"])
            labels.append(f"frame {k} subtask {int(frames['subtask_index'][k])}")
    Image.fromarray(contact_sheet(images, 4, labels)).save(out)
    print(reader.episode_meta(index).instruction)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("dataset", type=Path)
    p.add_argument("out", type=Path)
    p.add_argument("--scene-seed", type=int, default=25)
    p.add_argument("--episode", type=int, default=0)
    a = p.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    presets_side_by_side(a.scene_seed, a.out / "presets_fast_hd_photo.png")
    episode_sheet(a.dataset, a.episode, a.out / "photo_episode_sheet.png")


if __name__ == "__main__":
    main()

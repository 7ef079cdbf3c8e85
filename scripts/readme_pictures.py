"""Make the README's pictures: docs/images/world.png (one scene of the ``sample-hd`` preset, hd, 1280×720)
and docs/images/modalities.png (the same scene's RGB, depth and segmentation side by side).

    python scripts/readme_pictures.py [--out docs/images] [--seed 5] [--sheet SEEDS.png]

The scene is drawn by the real sampler with the preset's scene settings (the ``shop-vrb`` catalogue) and
shown from its own randomised scene camera, the robot in its default (mesh) look. ``--sheet`` instead
writes a small contact sheet of the scenes of seeds SEED … SEED+11, to choose one.
"""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import argparse
from pathlib import Path

import numpy as np
from PIL import Image

from samplehd.dataset.config import preset_config
from samplehd.render.contact_sheet import contact_sheet
from samplehd.render.image_io import colorize_depth
from samplehd.render.renderer import SceneRenderer
from samplehd.scene.sampler import sample_scene
from samplehd.scene.spec import compile_scene
from samplehd.viewer.imaging import colourise_segmentation


def _scene(seed: int):  # noqa: ANN202 - (model, data)
    return compile_scene(sample_scene(0, seed, preset_config("sample-hd").scene).scene)


def world(seed: int, out: Path, width: int = 1280, height: int = 720) -> None:
    model, data = _scene(seed)
    with SceneRenderer(model, width, height, "hd") as r:
        Image.fromarray(r.render(data, "scene")["rgb"]).save(out, optimize=True)


def modalities(seed: int, out: Path, width: int = 426, height: int = 240) -> None:
    model, data = _scene(seed)
    with SceneRenderer(model, width, height, "hd") as r:
        img = r.render(data, "scene", ("rgb", "depth", "segmentation"))
    tiles = [img["rgb"], colorize_depth(img["depth"]), colourise_segmentation(img["segmentation"])]
    Image.fromarray(np.concatenate(tiles, axis=1)).save(out, optimize=True)


def sheet(first: int, out: Path) -> None:
    images, labels = [], []
    for seed in range(first, first + 12):
        model, data = _scene(seed)
        with SceneRenderer(model, 320, 180, "fast") as r:
            images.append(r.render(data, "scene")["rgb"])
        labels.append(f"seed {seed}")
    Image.fromarray(contact_sheet(images, 4, labels)).save(out)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", type=Path, default=Path("docs/images"))
    p.add_argument("--seed", type=int, default=5)
    p.add_argument("--sheet", type=Path, default=None, help="write a contact sheet of 12 seeds here instead")
    a = p.parse_args()
    if a.sheet is not None:
        sheet(a.seed, a.sheet)
        return
    world(a.seed, a.out / "world.png")
    modalities(a.seed, a.out / "modalities.png")


if __name__ == "__main__":
    main()

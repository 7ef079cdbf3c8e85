"""Make the README's pictures: docs/images/world.png (one scene of the ``sample-hd`` preset, hd, 1280×720),
docs/images/modalities.png (the same scene's RGB, depth and segmentation side by side) and
docs/images/paths_stack.png (the last frame of each subtask of a ground-truth stack path, hd, 240×150).

    python scripts/readme_pictures.py [--out docs/images] [--seed 5] [--stack-seed 2] [--sheet SEEDS.png]

The scene is drawn by the real sampler with the preset's scene settings (the ``shop-vrb`` catalogue) and
shown from its own randomised scene camera, the robot in its default (mesh) look. The stack path is the
first episode of a states-only ``tiny`` dataset of stack instructions (default catalogue, ``shop-vrb``,
seed ``--stack-seed``), rendered from its recorded states. ``--sheet`` instead writes a small contact
sheet of the scenes of seeds SEED … SEED+11, to choose one.
"""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import argparse
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

from samplehd.dataset.config import GenerateConfig, preset_config
from samplehd.dataset.container import read_episode
from samplehd.dataset.generate import generate_dataset
from samplehd.dataset.reader import DatasetReader
from samplehd.record.replay import subtask_contact_sheet
from samplehd.render.contact_sheet import contact_sheet
from samplehd.render.image_io import colorize_depth
from samplehd.render.image_spec import ImageSpec
from samplehd.render.renderer import SceneRenderer
from samplehd.scene.sampler import sample_scene
from samplehd.scene.spec import SceneSpec, compile_scene
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


def stack_path(seed: int, out: Path, width: int = 240, height: int = 150) -> None:
    stacks = {"num_scenes": 2, "seed": seed, "test_every": 0, "scene": {"min_objects": 4, "max_objects": 4},
              "instructions": {"per_scene": 1, "families": ["stack"]}, "render": {"mode": "none"}}
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "stacks"
        generate_dataset(data, GenerateConfig.from_dict(stacks, base=preset_config("tiny")))
        reader = DatasetReader(data)
        entry = reader.episodes[0]
        episode = read_episode(data / entry.file, images="none")
        model, _ = compile_scene(SceneSpec.from_dict(dict(reader.scene(entry.scene_index)["spec"])))
        print(f"{out}: {reader.instruction(0)['instruction']!r} ({episode.num_frames} frames)")
        Image.fromarray(subtask_contact_sheet(model, episode, ImageSpec(width, height, "hd", ("scene",)))).save(
            out, optimize=True)


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
    p.add_argument("--stack-seed", type=int, default=2, help="seed of the stack path's dataset")
    p.add_argument("--sheet", type=Path, default=None, help="write a contact sheet of 12 seeds here instead")
    a = p.parse_args()
    if a.sheet is not None:
        sheet(a.seed, a.sheet)
        return
    world(a.seed, a.out / "world.png")
    modalities(a.seed, a.out / "modalities.png")
    stack_path(a.stack_seed, a.out / "paths_stack.png")


if __name__ == "__main__":
    main()

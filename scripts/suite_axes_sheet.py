"""One suite episode beside its variant at strength 5 on every robustness axis (scene camera), as a
contact sheet: per axis the clean twin, then the variant, each captioned with the axis and its
instruction; two axes per row. The variant is the suite's own where it holds one (a physical axis':
the attempt the oracle proved), else made as a build would make it; an axis with nothing to change
on the episode is left out. Written as a 128-colour PNG to stay small.

    python scripts/suite_axes_sheet.py SUITE OUT.png [EPISODE] [--preset fast|hd|photo] [--axes AXIS ...]
"""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import argparse
import textwrap

import numpy as np
from PIL import Image, ImageDraw

from samplehd.benchmark.axes import AXES, perturb
from samplehd.benchmark.sensor import corrupt_observation, sensor_rng
from samplehd.benchmark.suite import same_episode
from samplehd.envs.suite_file import Suite, SuiteEpisode, read_suite
from samplehd.envs.tabletop import TabletopEnv
from samplehd.errors import SceneError
from samplehd.render.contact_sheet import contact_sheet

WIDTH, HEIGHT = 320, 240
CAPTION_LINES, LINE_PX, CHARS = 4, 12, 44


def _variant(suite: Suite, twin: dict, axis: str, attempts: int = 8) -> dict | str:
    """The suite's variant of ``twin`` at strength 5 on ``axis``, else the first that can be made (a
    distractor may find no free spot), or why none can (no other instruction of the family has no
    ``task_swap``; a text without a noun of the groups has no ``nouns``)."""
    for ep in suite.episodes:
        if ep.axis == axis and ep.strength == 5 and ep.twin == twin["id"]:
            return ep.to_dict()
    reason = ""
    for attempt in range(attempts):
        try:
            variant = perturb(twin, axis, 5, seed=suite.build.get("seed", 0), attempt=attempt)
        except SceneError as exc:
            reason = str(exc)
            continue
        if same_episode(variant, twin):
            return "nothing to change"
        return variant
    return reason


def _captioned(frame: np.ndarray, title: str, text: str) -> np.ndarray:
    """The frame over a white strip with its title and the instruction, wrapped."""
    strip = Image.new("RGB", (frame.shape[1], CAPTION_LINES * LINE_PX + 4), (255, 255, 255))
    draw = ImageDraw.Draw(strip)
    lines = [title, *textwrap.wrap(text, CHARS)][:CAPTION_LINES]
    for k, line in enumerate(lines):
        draw.text((3, 2 + k * LINE_PX), line, fill=(0, 0, 0) if k else (160, 0, 0))
    return np.concatenate([frame, np.asarray(strip)], axis=0)


def main(suite_name: str, out: str, index: int = 0, preset: str = "fast", axes: tuple[str, ...] = tuple(AXES)) -> None:
    suite = read_suite(suite_name)
    twin = suite.episode(index).to_dict()
    # A slot per object: the distractors at strength 5 bring a scene to up to ten objects.
    env = TabletopEnv(render_mode="rgb_array", width=WIDTH, height=HEIGHT, render_preset=preset,
                      scene={"max_objects": 12})
    tiles = []
    try:
        for axis in axes:
            variant = _variant(suite, twin, axis)
            if isinstance(variant, str):
                print(f"{axis}: no variant of episode {index}: {variant}")
                continue
            for ep, name in ((twin, f"{axis}: clean twin"), (variant, f"{axis}: strength 5")):
                env.reset(options=SuiteEpisode.from_dict({"id": 0, **ep}).reset_options())
                frame = {"scene_rgb": env.render()}  # the sensor axis corrupts what the policy sees
                rgb = corrupt_observation(frame, ep.get("sensor"), sensor_rng(ep["reset_seed"]))["scene_rgb"]
                tiles.append(_captioned(rgb, name, ep["instruction"]))
    finally:
        env.close()
    sheet = Image.fromarray(contact_sheet(tiles, 4))
    sheet.quantize(128, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE).save(out, optimize=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("suite")
    parser.add_argument("out")
    parser.add_argument("episode", nargs="?", type=int, default=0)
    parser.add_argument("--preset", default="fast", choices=("fast", "hd", "photo"))
    parser.add_argument("--axes", nargs="+", default=list(AXES), choices=list(AXES), help="default: every axis")
    args = parser.parse_args()
    main(args.suite, args.out, args.episode, args.preset, tuple(args.axes))

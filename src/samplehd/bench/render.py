"""Render throughput per modality and preset at 320×180, 640×360 and 1280×720; the path-traced ``photo``
preset at 320×180 and 640×360 (1 sample per pixel + denoising, on the CPU or on an NVIDIA GPU)."""

from __future__ import annotations

import mujoco
import numpy as np

from samplehd.bench import Figure, median_rate
from samplehd.errors import RenderError
from samplehd.render.photo.runtime import photo_backend
from samplehd.render.renderer import MODALITIES, SceneRenderer
from samplehd.scene.world import OPERATOR_CAMERA, compile_world

RESOLUTIONS = ((320, 180), (640, 360), (1280, 720))
MODALITY_SETS = (*((m,) for m in MODALITIES), MODALITIES)
PHOTO_RESOLUTIONS = ((320, 180), (640, 360))


def run(repeats: int = 3) -> list[Figure]:
    """Frames/s of the kitchen world with the robot, from the operator camera."""
    model, data = compile_world()
    figures = []
    for preset in ("fast", "hd"):
        for w, h in RESOLUTIONS:
            with SceneRenderer(model, w, h, preset) as r:
                for mods in MODALITY_SETS:
                    r.render(data, OPERATOR_CAMERA.name, mods)  # warm-up: first frame uploads textures
                    count = 10 if (preset == "hd" or w >= 1280) else 30
                    fps = median_rate(lambda r=r, mods=mods: r.render(data, OPERATOR_CAMERA.name, mods), count, repeats)
                    figures.append(Figure("render", f"{'+'.join(mods)} fps {w}x{h} {preset}", fps, "1/s"))
    figures += _photo(model, data, repeats)
    return figures


def _photo(model: mujoco.MjModel, data: mujoco.MjData, repeats: int) -> list[Figure]:
    """Photo frames/s; skipped (with a note) where Mitsuba or LLVM is missing."""
    figures = []
    for w, h in PHOTO_RESOLUTIONS:
        try:
            r = SceneRenderer(model, w, h, "photo")
        except RenderError as exc:
            return [Figure("render", "rgb fps photo", float("nan"), "1/s", note=f"skipped: {exc}")]
        with r:
            r.render(data, OPERATOR_CAMERA.name, ("rgb",))  # warm-up: builds the scene and compiles the kernels
            note = f"{photo_backend()}, 1 spp + denoising"
            count = 30 if photo_backend() == "cuda_ad_rgb" else 3  # a GPU frame takes milliseconds
            for mods in (("rgb",), MODALITIES):
                fps = median_rate(lambda r=r, mods=mods: r.render(data, OPERATOR_CAMERA.name, mods), count, repeats)
                figures.append(Figure("render", f"{'+'.join(mods)} fps {w}x{h} photo", fps, "1/s", note=note))
            figures += _alignment(r, data, w, h)
    return figures


def _alignment(r: SceneRenderer, data: mujoco.MjData, w: int, h: int) -> list[Figure]:
    """How well the path-traced picture lines up with GL depth and segmentation: what the path tracer hits at
    each pixel centre against what GL draws there."""
    gl = r.render(data, OPERATOR_CAMERA.name, ("depth", "segmentation"))
    depth, seg = r.photo_geometry()
    both = np.isfinite(depth) & (gl["depth"] < 25.0)
    note = "pixel centres, operator camera, kitchen world with the robot"
    return [
        Figure("render", f"photo segmentation = GL {w}x{h}", float((seg == gl["segmentation"]).mean()), "ratio",
               note=note),
        Figure("render", f"photo depth within 1 mm of GL {w}x{h}",
               float((np.abs(depth - gl["depth"])[both] < 1e-3).mean()), "ratio", note=note),
    ]

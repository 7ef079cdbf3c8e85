"""Render throughput per modality and preset at 320×180, 640×360 and 1280×720."""

from __future__ import annotations

from samplehd.bench import Figure, median_rate
from samplehd.render.renderer import MODALITIES, SceneRenderer
from samplehd.scene.world import compile_world

RESOLUTIONS = ((320, 180), (640, 360), (1280, 720))
MODALITY_SETS = (*((m,) for m in MODALITIES), MODALITIES)


def run(repeats: int = 3) -> list[Figure]:
    """Frames/s of the kitchen world with the robot, from the operator camera."""
    model, data = compile_world()
    figures = []
    for preset in ("fast", "hd"):
        for w, h in RESOLUTIONS:
            with SceneRenderer(model, w, h, preset) as r:
                for mods in MODALITY_SETS:
                    r.render(data, "operator", mods)  # warm-up: first frame uploads textures
                    count = 10 if (preset == "hd" or w >= 1280) else 30
                    fps = median_rate(lambda r=r, mods=mods: r.render(data, "operator", mods), count, repeats)
                    figures.append(Figure("render", f"{'+'.join(mods)} fps {w}x{h} {preset}", fps, "1/s"))
    return figures

"""Scene sampling throughput (1 and 2 workers, fast and hd at 640×360) and rejection statistics."""

from __future__ import annotations

import statistics
import tempfile
import time
from collections import Counter
from pathlib import Path

from samplehd.bench import Figure
from samplehd.render.image_spec import ImageSpec
from samplehd.render.renderer import MODALITIES
from samplehd.scene.generate import generate_scenes
from samplehd.scene.sampler import sample_scene
from samplehd.world.seeding import scene_seed


def run(repeats: int = 3, num: int = 8, stats_scenes: int = 100) -> list[Figure]:
    """Scenes/s end to end (sample, settle, occlusion check, render, annotate, write)."""
    figures = []
    for preset in ("fast", "hd"):
        for workers in (1, 2):
            rates = []
            for rep in range(repeats):
                with tempfile.TemporaryDirectory() as tmp:
                    t0 = time.perf_counter()
                    generate_scenes(Path(tmp), num, seed=100 + rep,
                                    image=ImageSpec(640, 360, preset, modalities=MODALITIES), workers=workers)
                    rates.append(num / (time.perf_counter() - t0))
            figures.append(Figure("scenes", f"scenes/s 640x360 {preset} workers={workers}", statistics.median(rates),
                                  "1/s", f"{num} scenes per run, incl. process start-up"))
    rejections: Counter[str] = Counter()
    first_try = 0
    for i in range(stats_scenes):
        r = sample_scene(i, scene_seed(12345, i))
        rejections.update(r.rejections)
        first_try += r.attempts == 1
    for reason, count in sorted(rejections.items()):
        figures.append(Figure("scenes", f"rejections per 100 scenes: {reason}", 100 * count / stats_scenes, "count"))
    figures.append(Figure("scenes", "scenes accepted at the first attempt", first_try / stats_scenes, "fraction",
                          "placement + settling + occlusion all passed for the first candidate scene"))
    return figures

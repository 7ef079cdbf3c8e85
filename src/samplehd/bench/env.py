"""Environment throughput: ``samplehd/Tabletop-v0`` env steps/s per observation config.

Configs (one camera, 20 Hz control, steering actions): ``state`` (no images), ``rgb128`` (RGB
128×128) and ``rgbdseg256`` (RGB, depth and segmentation 256×256). The robosuite comparison lives in
``benchmarks/bench_env.py`` (robosuite needs its own venv).
"""

from __future__ import annotations

import statistics
import time
from typing import Any

import numpy as np

from samplehd.bench import Figure

__all__ = ["CONFIGS", "measure", "run"]

CONFIGS: dict[str, dict[str, Any]] = {
    "state": {"obs_mode": "state"},
    "rgb128": {"obs_mode": "rgb", "width": 128, "height": 128, "cameras": ["scene"]},
    "rgbdseg256": {"obs_mode": "rgbd_seg", "width": 256, "height": 256, "cameras": ["scene"]},
}


def measure(name: str, steps: int = 100, repeats: int = 3, seed: int = 0) -> dict[str, float]:
    """Median env steps/s of one config over ``repeats`` runs of ``steps`` steps, and the reset time.

    Actions are small random steering commands (so the arm moves without crashing into the table);
    a terminated episode is reset outside the timed region.
    """
    from samplehd.envs.tabletop import TabletopEnv

    env = TabletopEnv(control_mode="steering", num_scenes=1, scene_seed=seed, **CONFIGS[name])
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)  # samples and compiles the scene
    t0 = time.perf_counter()
    env.reset(seed=seed + 1)
    reset_s = time.perf_counter() - t0
    rates = []
    for _ in range(repeats):
        elapsed, done = 0.0, 0
        while done < steps:
            a = np.append(rng.uniform(-0.3, 0.3, 6), 1.0).astype(np.float32)
            t0 = time.perf_counter()
            _, _, term, trunc, _ = env.step(a)
            elapsed += time.perf_counter() - t0
            done += 1
            if term or trunc:
                env.reset(seed=int(rng.integers(1 << 30)))
        rates.append(steps / elapsed)
    env.close()
    return {"steps_per_s": statistics.median(rates), "reset_s": reset_s}


def run(repeats: int = 3) -> list[Figure]:
    """Env steps/s per observation config (samplehd side only)."""
    figures = []
    for name in CONFIGS:
        m = measure(name, repeats=repeats)
        figures.append(Figure("env", f"env steps/s {name}", m["steps_per_s"], "1/s",
                              "Tabletop-v0, steering, 20 Hz, one camera, median"))
        figures.append(Figure("env", f"env reset s {name}", m["reset_s"], "s", "scene cached (pool of 1)"))
    return figures

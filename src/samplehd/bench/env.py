"""Environment throughput: ``samplehd/Tabletop-v0`` env steps/s per observation config.

Configs (one camera, 20 Hz control, steering actions): ``state`` (no images), ``rgb128`` (RGB
128×128) and ``rgbdseg256`` (RGB, depth and segmentation 256×256). ``samplehd bench env
--robosuite-python PY`` measures robosuite 1.5 side by side (it needs its own venv with mujoco 3.x).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import time
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.bench import Figure
from samplehd.envs.tabletop import TabletopEnv

__all__ = ["CONFIGS", "add_arguments", "measure", "report", "robosuite_rates", "run"]

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


_ROBOSUITE_SCRIPT = Path(__file__).with_name("_robosuite_env.py")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """``samplehd bench env``: steps/s per config, side by side with robosuite when its venv is given."""
    parser.add_argument("--robosuite-python", help="python of a venv with robosuite (and mujoco 3.x)")
    parser.add_argument("--repeats", type=int, default=3, help="repeats (interleaved with robosuite's)")
    parser.add_argument("--steps", type=int, default=60, help="env steps per repeat")
    parser.add_argument("--configs", nargs="+", default=list(CONFIGS), choices=list(CONFIGS))
    parser.add_argument("--json", type=Path, help="also write the results here")


def robosuite_rates(python: str, config: str, steps: int) -> dict[str, float]:
    """robosuite's steps/s and reset time for one config, measured in its own venv."""
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    proc = subprocess.run([python, str(_ROBOSUITE_SCRIPT), "--configs", config, "--steps", str(steps),
                           "--repeats", "1"], capture_output=True, text=True, env=env, check=True)
    line = [s for s in proc.stdout.splitlines() if s.startswith("{")][-1]
    return json.loads(line)[config]


def report(args: argparse.Namespace) -> int:
    """Median steps/s per config (and ratios to robosuite, measured interleaved in the same run)."""
    results = {}
    for name in args.configs:
        ours, theirs, ours_reset, theirs_reset = [], [], [], []
        for r in range(args.repeats):
            m = measure(name, steps=args.steps, repeats=1, seed=r)
            ours.append(m["steps_per_s"])
            ours_reset.append(m["reset_s"])
            if args.robosuite_python:
                t = robosuite_rates(args.robosuite_python, name, args.steps)
                theirs.append(t["steps_per_s"])
                theirs_reset.append(t["reset_s"])
        results[name] = {"samplehd_steps_per_s": statistics.median(ours),
                         "samplehd_reset_s": statistics.median(ours_reset)}
        if theirs:
            ratios = [a / b for a, b in zip(ours, theirs, strict=True)]
            results[name].update(robosuite_steps_per_s=statistics.median(theirs), ratio=statistics.median(ratios),
                                 ratios=ratios, robosuite_reset_s=statistics.median(theirs_reset))
    print(f"{'config':<12} {'samplehd':>10} {'robosuite':>10} {'ratio':>7}")
    for name, r in results.items():
        rs, ratio = r.get("robosuite_steps_per_s"), r.get("ratio")
        print(f"{name:<12} {r['samplehd_steps_per_s']:>10.1f} {rs or float('nan'):>10.1f} "
              f"{ratio or float('nan'):>6.2f}x")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(results, indent=1) + "\n")
    return 0

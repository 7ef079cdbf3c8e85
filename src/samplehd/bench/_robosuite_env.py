"""robosuite 1.5 side of the environment benchmark (run with robosuite's own venv, not samplehd's).

Lift with a UR5e, the BASIC composite controller (OSC_POSE on the arm), 20 Hz control, one camera
(frontview), random actions; prints one JSON object: env steps/s per observation config (median of
repeats) and reset time.

    python3 -m venv /tmp/rs-venv && /tmp/rs-venv/bin/pip install robosuite "mujoco==3.9.0"
    MUJOCO_GL=egl /tmp/rs-venv/bin/python src/samplehd/bench/_robosuite_env.py --configs state rgb128 rgbdseg256

``samplehd bench env --robosuite-python PYTHON`` runs it as a subprocess with that interpreter (this file
imports nothing of samplehd and is not an area of ``samplehd bench``).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")

CONFIGS = {
    "state": {"use_camera_obs": False, "has_offscreen_renderer": False},
    "rgb128": {"use_camera_obs": True, "camera_heights": 128, "camera_widths": 128},
    "rgbdseg256": {"use_camera_obs": True, "camera_heights": 256, "camera_widths": 256, "camera_depths": True,
                   "camera_segmentations": "instance"},
}


def measure(name: str, steps: int, repeats: int) -> dict[str, float]:
    import robosuite as suite
    from robosuite.controllers import load_composite_controller_config

    controller = load_composite_controller_config(controller="BASIC", robot="UR5e")
    options = {"has_offscreen_renderer": True, "camera_names": "frontview", **CONFIGS[name]}
    env = suite.make("Lift", robots="UR5e", controller_configs=controller, has_renderer=False, control_freq=20,
                     horizon=100000, ignore_done=True, **options)
    rng = np.random.default_rng(0)
    low, high = env.action_spec
    t0 = time.perf_counter()
    env.reset()
    reset_s = time.perf_counter() - t0
    for _ in range(3):  # warm-up
        env.step(rng.uniform(low, high))
    rates = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(steps):
            env.step(rng.uniform(low, high))
        rates.append(steps / (time.perf_counter() - t0))
    env.close()
    return {"steps_per_s": statistics.median(rates), "reset_s": reset_s}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--configs", nargs="+", default=list(CONFIGS), choices=list(CONFIGS))
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    import robosuite

    out = {"robosuite": robosuite.__version__}
    for name in args.configs:
        out[name] = measure(name, args.steps, args.repeats)
    print(json.dumps(out))


if __name__ == "__main__":
    main()

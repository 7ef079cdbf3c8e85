"""samplehd Tabletop-v0 vs robosuite 1.5 (Lift, UR5e, OSC, one camera, 20 Hz): env steps/s per
observation config, measured side by side in one run (interleaved per repeat) and given as ratios.

    .venv/bin/python benchmarks/bench_env.py --robosuite-python /tmp/rs-venv/bin/python --out outputs/bench/env.json

robosuite runs in its own venv (it needs mujoco 3.x) as a subprocess (benchmarks/robosuite_env.py).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def robosuite_rates(python: str, config: str, steps: int) -> dict[str, float]:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    proc = subprocess.run([python, str(HERE / "robosuite_env.py"), "--configs", config, "--steps", str(steps),
                           "--repeats", "1"], capture_output=True, text=True, env=env, check=True)
    line = [s for s in proc.stdout.splitlines() if s.startswith("{")][-1]
    return json.loads(line)[config]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robosuite-python", default="/tmp/rs-venv/bin/python")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--steps", type=int, default=60)
    parser.add_argument("--configs", nargs="+", default=["state", "rgb128", "rgbdseg256"])
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()

    import samplehd  # noqa: F401  (GL backend)
    from samplehd.bench.env import measure

    results = {}
    for name in args.configs:
        ours, theirs, ours_reset, theirs_reset = [], [], [], []
        for r in range(args.repeats):
            m = measure(name, steps=args.steps, repeats=1, seed=r)
            ours.append(m["steps_per_s"])
            ours_reset.append(m["reset_s"])
            t = robosuite_rates(args.robosuite_python, name, args.steps)
            theirs.append(t["steps_per_s"])
            theirs_reset.append(t["reset_s"])
            print(f"{name} repeat {r}: samplehd {ours[-1]:.1f} steps/s, robosuite {theirs[-1]:.1f} steps/s",
                  file=sys.stderr, flush=True)
        ratios = [a / b for a, b in zip(ours, theirs, strict=True)]
        results[name] = {
            "samplehd_steps_per_s": statistics.median(ours),
            "robosuite_steps_per_s": statistics.median(theirs),
            "ratio": statistics.median(ratios),
            "ratios": ratios,
            "samplehd_reset_s": statistics.median(ours_reset),
            "robosuite_reset_s": statistics.median(theirs_reset),
        }
    print(f"{'config':<12} {'samplehd':>10} {'robosuite':>10} {'ratio':>7}")
    for name, r in results.items():
        print(f"{name:<12} {r['samplehd_steps_per_s']:>10.1f} {r['robosuite_steps_per_s']:>10.1f} {r['ratio']:>6.2f}x")
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()

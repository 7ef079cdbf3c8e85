"""Benchmark the robot layer: physics steps/s with the arm moving, control steps/s per action mode
and their ratio to raw mj_step (the control layer's cost), analytic IK solves/s. Prints medians;
pins itself to one core.

Usage: .venv/bin/python benchmarks/bench_robot.py [--repeats 5] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="repeats per figure (medians are printed)")
    parser.add_argument("--json", help="also write the figures here")
    args = parser.parse_args(argv)
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {max(os.sched_getaffinity(0))})

    import samplehd  # noqa: F401  (GL backend before mujoco)
    from samplehd.bench.robot import (
        control_steps_per_second,
        ik_solves_per_second,
        physics_steps_per_second,
        robot_world,
    )

    model, data = robot_world()
    phys = physics_steps_per_second(model, data, repeats=args.repeats)
    print("physics steps/s, kitchen world, arm moving (raw mj_step):")
    print(f"  mj_step once per step      {phys['python_loop']:>10,.0f}")
    print(f"  mj_step(model, data, 25)   {phys['nstep_25']:>10,.0f}")
    control = control_steps_per_second(model, data, repeats=args.repeats)
    print("control at 20 Hz, physics 500 Hz, safety monitor on:")
    print(f"  {'mode':<16} {'control/s':>10} {'physics/s':>10} {'/raw nstep':>10} {'/raw loop':>10}")
    for mode, f in control.items():
        print(
            f"  {mode:<16} {f['control_steps']:>10,.0f} {f['physics_steps']:>10,.0f} "
            f"{f['ratio_nstep']:>10.2f} {f['ratio_python_loop']:>10.2f}"
        )
    ik = ik_solves_per_second(repeats=args.repeats)
    print("analytic IK (TCP, random reachable poses and seeds, one core):")
    print(f"  single pose  {ik['single']:>10,.0f} solves/s")
    print(f"  batch        {ik['batch']:>10,.0f} solves/s")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"physics": phys, "control": control, "ik": ik}, fh, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Robot figures: physics steps/s with the arm moving, control steps/s per mode vs raw mj_step, IK/s.

The control layer's cost is the ratio of physics steps/s reached through
:class:`~samplehd.robot.controller.RobotController` (safety monitor on) to raw ``mj_step`` on the
same world with the arm moving, both measured in the same run, alternating, medians of repeats.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np

from samplehd.bench import Figure, pin_to_one_core
from samplehd.robot.constants import HOME_QPOS, JOINT_NAMES, POSITION_ACTUATORS, TCP_OFFSET, VELOCITY_ACTUATORS
from samplehd.robot.controller import ACTION_MODES, ControlConfig, RobotController
from samplehd.robot.kinematics import fk_tcp, forward_kinematics, ik_batch, inverse_kinematics, pos_quat_from_pose
from samplehd.scene.world import compile_world

__all__ = [
    "add_arguments",
    "control_steps_per_second",
    "ik_solves_per_second",
    "physics_steps_per_second",
    "report",
    "robot_world",
    "run",
]


def robot_world() -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The kitchen world with the robot and no objects (arm at home)."""
    return compile_world()


def _timed(fn: Callable[[], int], repeats: int) -> float:
    """Median of work units per second over repeats; ``fn`` returns how many units it did."""
    rates = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        n = fn()
        rates.append(n / (time.perf_counter() - t0))
    return statistics.median(rates)


def _raw_stepper(model: mujoco.MjModel, data: mujoco.MjData, steps: int, nstep: int) -> Callable[[], int]:
    """Raw mj_step with the arm moving: the position/velocity servos ramp back and forth."""
    ids = np.array([model.actuator(a).id for a in (*POSITION_ACTUATORS, *VELOCITY_ACTUATORS)])
    qadr = np.array([model.jnt_qposadr[model.joint(j).id] for j in JOINT_NAMES])
    speed = np.tile([0.4, 0.3, -0.3, 0.5, 0.5, 0.8], 2)
    period = max(1, round(0.5 / model.opt.timestep))  # reverse every 0.5 s

    def go() -> int:
        data.qpos[qadr] = HOME_QPOS
        data.qvel[:] = 0.0
        done = 0
        sign = 1.0
        while done < steps:
            data.ctrl[ids] = sign * speed
            chunk = min(period, steps - done)
            if nstep > 1:
                for _ in range(chunk // nstep):
                    mujoco.mj_step(model, data, nstep)
            else:
                for _ in range(chunk):
                    mujoco.mj_step(model, data)
            done += chunk
            sign = -sign
        return steps

    return go


def physics_steps_per_second(
    model: mujoco.MjModel, data: mujoco.MjData, steps: int = 5000, repeats: int = 5
) -> dict[str, float]:
    """Raw physics throughput with the arm moving.

    Returns:
        ``{"python_loop": steps/s calling mj_step once per step, "nstep_25": steps/s with
        mj_step(model, data, 25)}`` [1/s].
    """
    return {
        "python_loop": _timed(_raw_stepper(model, data, steps, 1), repeats),
        "nstep_25": _timed(_raw_stepper(model, data, steps, 25), repeats),
    }


def _mode_actions(mode: str) -> list[np.ndarray]:
    """Two alternating actions per mode that keep the arm moving near home."""
    if mode == "joint_position":
        return [np.r_[HOME_QPOS + 0.15, 1.0], np.r_[HOME_QPOS - 0.15, -1.0]]
    if mode == "joint_delta":
        return [np.r_[np.full(6, 0.05), 1.0], np.r_[np.full(6, -0.05), -1.0]]
    if mode == "cartesian_pose":
        out = []
        for dx in (0.08, -0.08):
            pose = fk_tcp(HOME_QPOS)
            pose[:3, 3] += [dx, dx, -dx]
            pos, quat = pos_quat_from_pose(pose)
            out.append(np.r_[pos, quat, 1.0 if dx > 0 else -1.0])
        return out
    if mode == "cartesian_delta":
        return [np.r_[0.01, 0.01, -0.01, 0.0, 0.0, 0.05, 1.0], np.r_[-0.01, -0.01, 0.01, 0.0, 0.0, -0.05, -1.0]]
    return [np.r_[0.8, 0.6, -0.5, 0.2, 0.0, 0.5, 1.0], np.r_[-0.8, -0.6, 0.5, -0.2, 0.0, -0.5, -1.0]]


def control_steps_per_second(
    model: mujoco.MjModel, data: mujoco.MjData, control_steps: int = 400, repeats: int = 5
) -> dict[str, dict[str, float]]:
    """Control throughput per mode and its ratio to raw mj_step, measured alternately.

    Returns:
        ``{mode: {"control_steps": control steps/s, "physics_steps": physics steps/s through the
        controller, "ratio_python_loop": ..., "ratio_nstep": ...}}``; the ratios divide the
        controller's physics steps/s by raw mj_step (once per step / 25 at a time) measured in
        between the controller's repeats.
    """
    ctrl = RobotController(model, data, ControlConfig(physics_hz=round(1.0 / model.opt.timestep)))
    substeps = ctrl.config.substeps
    raw_loop = _raw_stepper(model, data, control_steps * substeps, 1)
    raw_nstep = _raw_stepper(model, data, control_steps * substeps, 25)
    out: dict[str, dict[str, float]] = {}
    flip = 10  # change direction every 10 control steps (0.5 s)
    for mode in ACTION_MODES:
        actions = _mode_actions(mode)

        def controlled(mode: str = mode, actions: list[np.ndarray] = actions) -> int:
            ctrl.reset(HOME_QPOS)
            for i in range(control_steps):
                ctrl.step(actions[(i // flip) % 2], mode)
            if ctrl.stopped is not None:
                raise RuntimeError(f"benchmark motion in mode {mode} hit a safety stop: {ctrl.stopped}")
            return control_steps

        rates, loop_rates, nstep_rates = [], [], []
        controlled()  # warm-up
        for _ in range(repeats):
            rates.append(_timed(controlled, 1))
            loop_rates.append(_timed(raw_loop, 1))
            nstep_rates.append(_timed(raw_nstep, 1))
        rate = statistics.median(rates)
        out[mode] = {
            "control_steps": rate,
            "physics_steps": rate * substeps,
            "ratio_python_loop": statistics.median([r * substeps / b for r, b in zip(rates, loop_rates, strict=True)]),
            "ratio_nstep": statistics.median([r * substeps / b for r, b in zip(rates, nstep_rates, strict=True)]),
        }
    return out


def ik_solves_per_second(count: int = 20000, repeats: int = 5, seed: int = 0) -> dict[str, float]:
    """Analytic IK throughput on one core for reachable TCP poses with random seeds.

    Returns:
        ``{"single": solves/s of inverse_kinematics one pose at a time, "batch": solves/s of
        ik_batch on all poses at once}`` [1/s].
    """
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (count, 6))
    seeds = rng.uniform(-np.pi, np.pi, (count, 6))

    poses = forward_kinematics(q, TCP_OFFSET)
    n_single = min(count, 5000)

    def single() -> int:
        for i in range(n_single):
            inverse_kinematics(poses[i], seeds[i], TCP_OFFSET)
        return n_single

    def batch() -> int:
        ik_batch(poses, seeds, TCP_OFFSET)
        return count

    return {"single": _timed(single, repeats), "batch": _timed(batch, repeats)}


def run(repeats: int = 3) -> list[Figure]:
    """All robot figures (see the module docstring)."""
    model, data = robot_world()
    figures: list[Figure] = []
    phys = physics_steps_per_second(model, data, repeats=repeats)
    figures.append(Figure("robot", "physics steps/s, arm moving", phys["python_loop"], "1/s", "mj_step per step"))
    figures.append(Figure("robot", "physics steps/s, arm moving, nstep 25", phys["nstep_25"], "1/s", "mj_step(m,d,25)"))
    for mode, f in control_steps_per_second(model, data, repeats=repeats).items():
        figures.append(Figure("robot", f"control steps/s {mode}", f["control_steps"], "1/s", "20 Hz, 25 substeps"))
        figures.append(
            Figure("robot", f"control/raw physics {mode}", f["ratio_nstep"], "ratio", "vs mj_step(m,d,25), same run")
        )
        figures.append(
            Figure("robot", f"control/raw loop {mode}", f["ratio_python_loop"], "ratio", "vs mj_step once per step")
        )
    ik = ik_solves_per_second(repeats=repeats)
    figures.append(Figure("robot", "IK solves/s single", ik["single"], "1/s", "inverse_kinematics, one core"))
    figures.append(Figure("robot", "IK solves/s batch", ik["batch"], "1/s", "ik_batch 20k poses, one core"))
    return figures


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """``samplehd bench robot``: physics steps/s, control steps/s per action mode, IK solves/s (one core)."""
    parser.add_argument("--repeats", type=int, default=5, help="repeats per figure (medians)")
    parser.add_argument("--json", type=Path, help="also write the figures here")


def report(args: argparse.Namespace) -> int:
    """Print the robot figures, pinned to one core."""
    pin_to_one_core(last=True)
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
        args.json.write_text(json.dumps({"physics": phys, "control": control, "ik": ik}, indent=2))
    return 0

"""Minimal table world for the robot tests, independent of the kitchen world (samplehd.scene.world)."""

from __future__ import annotations

from collections.abc import Callable

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import mujoco
import numpy as np

from samplehd.robot.constants import ROBOT_BASE_QUAT
from samplehd.robot.ur5e import add_robot

BASE_POS = np.array([-0.40, 0.0, 0.75])
TABLE_TOP = 0.75


def build_table_world(
    extra: Callable[[mujoco.MjSpec], None] | None = None,
    base_quat: np.ndarray = ROBOT_BASE_QUAT,
    timestep: float = 0.002,
) -> mujoco.MjSpec:
    """Floor, a box table (body ``table``, geom ``table_top`` with its top at z 0.75) and the robot."""
    spec = mujoco.MjSpec()
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[3, 3, 0.1])
    table = spec.worldbody.add_body(name="table", pos=[0.0, 0.0, TABLE_TOP - 0.02])
    table.add_geom(name="table_top", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.5, 0.7, 0.02])
    spec.worldbody.add_geom(
        name="backdrop_wall", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.02, 1.5, 1.0], pos=[-1.0, 0.0, 1.0]
    )
    add_robot(spec.worldbody, BASE_POS, base_quat, spec=spec)
    if extra is not None:
        extra(spec)
    return spec


def add_box(
    spec: mujoco.MjSpec, index: int, pos, half=(0.025, 0.03, 0.04), mass: float = 0.3, free: bool = True
) -> None:
    """Scene object ``object_{index}``: a box, free or fixed to the world."""
    body = spec.worldbody.add_body(name=f"object_{index}", pos=list(pos))
    if free:
        body.add_freejoint()
    body.add_geom(name=f"object_{index}_box", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(half), mass=mass)

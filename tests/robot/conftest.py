"""Fixtures of the robot tests."""

from __future__ import annotations

import mujoco
import pytest
from robot_world import build_table_world

from samplehd.robot.constants import HOME_QPOS
from samplehd.robot.controller import ControlConfig, RobotController


@pytest.fixture(scope="session")
def table_model() -> mujoco.MjModel:
    """Compiled minimal world (no objects)."""
    return build_table_world().compile()


@pytest.fixture()
def controller(table_model: mujoco.MjModel) -> RobotController:
    """A controller at home on fresh data of the minimal world."""
    data = mujoco.MjData(table_model)
    ctrl = RobotController(table_model, data, ControlConfig())
    ctrl.reset(HOME_QPOS)
    return ctrl

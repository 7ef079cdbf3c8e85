"""Shared fixtures: expensive things (compiled worlds, renderers) are built once per session."""

from __future__ import annotations

import pytest

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)


@pytest.fixture(scope="session")
def world():
    """The kitchen world with the robot and no objects: (model, data) after mj_forward."""
    from samplehd.scene.world import compile_world

    return compile_world()


@pytest.fixture(scope="session")
def empty_world():
    """The kitchen world without the robot."""
    from samplehd.scene.world import WorldConfig, compile_world

    return compile_world(config=WorldConfig(with_robot=False))

"""Shared fixtures: expensive things (compiled worlds, renderers) are built once per session.

The suite is hermetic: before anything reads them, the user registry of imported classes, the
decomposition cache and numba's cache of compiled code point at a private empty directory, and every
subprocess a test starts inherits that. Nothing a user imported can change what the suite sees.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import tempfile
from pathlib import Path

import pytest

_PRIVATE_HOME = Path(tempfile.mkdtemp(prefix="samplehd-tests-"))
os.environ["SAMPLEHD_REGISTRY_DIR"] = str(_PRIVATE_HOME / "registry")
os.environ["SAMPLEHD_CACHE_DIR"] = str(_PRIVATE_HOME / "cache")
# numba's compiled-code cache (the free-spot loops) goes there too, not beside the sources or in the home
os.environ["NUMBA_CACHE_DIR"] = str(_PRIVATE_HOME / "numba")

import samplehd  # noqa: E402,F401  (sets MUJOCO_GL before mujoco is imported)

# Importing triton (torch's compiler, present beside CUDA builds of torch) after an EGL context exists
# crashes the process (SIGSEGV in triton's module init). The suite renders before it trains
# (Stable-Baselines3, samplehd.learn), so where triton is installed it is loaded before any context.
if importlib.util.find_spec("triton") is not None:
    import triton  # noqa: E402,F401


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    shutil.rmtree(_PRIVATE_HOME, ignore_errors=True)


@pytest.fixture(scope="session")
def private_user_home() -> Path:
    """The private directory holding this session's (empty) registry and caches."""
    return _PRIVATE_HOME


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

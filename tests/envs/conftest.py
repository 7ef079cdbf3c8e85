"""Fixtures of the environment tests: small, fast scene pools shared by the whole session."""

from __future__ import annotations

import pytest

from samplehd.envs import register_envs

# Three objects, two pooled scenes: resets reuse sampled scenes, so tests stay fast.
FAST = {"scene": {"min_objects": 3, "max_objects": 3}, "num_scenes": 2, "scene_seed": 7}


@pytest.fixture(scope="session", autouse=True)
def _registered() -> None:
    register_envs()


@pytest.fixture()
def fast_options() -> dict:
    return {k: (dict(v) if isinstance(v, dict) else v) for k, v in FAST.items()}

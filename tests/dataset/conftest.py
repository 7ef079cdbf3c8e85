"""Fixtures of the dataset tests: one small real dataset (real scenes, planner and physics), made once."""

from __future__ import annotations

from pathlib import Path

import pytest
from dataset_helpers import micro_config

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)


@pytest.fixture(scope="session")
def micro_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The MICRO dataset, states only, made in this process (1 worker)."""
    from samplehd.dataset.generate import generate_dataset

    out = tmp_path_factory.mktemp("micro") / "ds"
    summary = generate_dataset(out, micro_config())
    assert summary.episodes >= 1, "the micro dataset needs at least one successful episode"
    return out


@pytest.fixture(scope="session")
def rendered_dataset(tmp_path_factory: pytest.TempPathFactory, micro_dataset: Path) -> Path:
    """A copy of the micro dataset re-rendered at 64×36 (RGB, depth, segmentation)."""
    import shutil

    from samplehd.dataset.render import RenderConfig
    from samplehd.dataset.rerender import rerender_dataset

    out = tmp_path_factory.mktemp("rendered") / "ds"
    shutil.copytree(micro_dataset, out)
    from samplehd.workers import Backend

    rerender_dataset(out, RenderConfig("fast", 64, 36), Backend("local", 2))
    return out

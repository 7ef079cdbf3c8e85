"""Catalogue tests run against an empty, private user registry and cache."""

from __future__ import annotations

import pytest

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)


@pytest.fixture(autouse=True)
def private_registry(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch):
    """Point the registry and the decomposition cache at fresh temporary directories."""
    from samplehd.catalogue.registry import refresh

    base = tmp_path_factory.mktemp("user")
    monkeypatch.setenv("SAMPLEHD_REGISTRY_DIR", str(base / "registry"))
    monkeypatch.setenv("SAMPLEHD_CACHE_DIR", str(base / "cache"))
    refresh()
    yield base
    refresh()

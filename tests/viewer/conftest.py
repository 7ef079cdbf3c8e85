"""Fixtures of the viewer tests: a real tiny dataset made once per session by ``samplehd generate``,
its files as the tests expect them, copies of it in the states a dataset passes through while it is
written, viewer servers on free ports in threads, and a headless Chromium driven by selenium (skipped
cleanly when chromium, chromedriver or selenium is missing)."""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from dataset_states import DatasetFiles, read_dataset_files

# The tiny preset on three scenes, with every second scene in the test split (so both splits exist),
# one attempt per path and a 10 Hz recording (half the frames to simulate and render). The tests
# need at least one episode and one rejected path (`dataset_files` says so if a change of the
# generator breaks that). Every expected value of the tests is read from the generated files.
TINY_SCENES = 3
# The ground-truth paths now rarely fail, so the rejected path comes from a real checker setting: a
# picked-up object must be lifted 0.5 m, which the pick_up path (lifting about 25 cm) does not do.
# Seed 0, 3 scenes: place ×3, remove, stack, pick_up candidates → 5 episodes, 1 rejected path.
TINY_OVERRIDES = {"test_every": 2,
                  "paths": {"max_attempts": 1, "control_hz": 10.0, "checker": {"lift_height": 0.5}}}


@pytest.fixture(scope="session")
def tiny_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A real dataset made by ``samplehd generate --preset tiny`` (simulated and rendered), once per
    session. Tests must not change it: they copy it (``dataset_copy``) to change anything."""
    from samplehd.cli import main

    folder = tmp_path_factory.mktemp("viewer")
    config = folder / "config.json"
    config.write_text(json.dumps(TINY_OVERRIDES))
    out = folder / "tiny"
    code = main(["generate", "--preset", "tiny", "--config", str(config), "--scenes", str(TINY_SCENES),
                 "--out", str(out), "--workers", "2", "--quiet"])
    assert code == 0, "samplehd generate failed; run it by hand to see why"
    return out


@pytest.fixture(scope="session")
def dataset_files(tiny_dataset: Path) -> DatasetFiles:
    """The generated dataset's files, checked to hold what the tests need."""
    files = read_dataset_files(tiny_dataset)
    assert files.info["status"] == "complete"
    assert len(files.scenes) == TINY_SCENES and {s["split"] for s in files.scenes} == {"train", "test"}
    assert files.episodes, "the tiny dataset has no successful episode; the viewer tests need one"
    assert files.rejections, "the tiny dataset has no rejected path; the viewer tests need one (try another seed)"
    return files


@pytest.fixture()
def dataset_copy(tiny_dataset: Path, tmp_path: Path) -> Path:
    """A private copy of the generated dataset, free to change."""
    return Path(shutil.copytree(tiny_dataset, tmp_path / tiny_dataset.name))


@pytest.fixture()
def serve() -> Iterator[Callable[[Path], str]]:
    """Start a viewer (``open_dataset``, as ``samplehd view``) on a dataset folder; returns its URL.
    Every server started is stopped at the end of the test."""
    from samplehd.viewer.app import ViewerApp
    from samplehd.viewer.server import ViewerServer, open_dataset

    servers: list[ViewerServer] = []

    def start(root: Path) -> str:
        server = ViewerServer(("127.0.0.1", 0), ViewerApp(open_dataset(root, render=False)))
        server.start_in_thread()
        servers.append(server)
        return server.url

    yield start
    for server in servers:
        server.shutdown()
        server.server_close()


@pytest.fixture(scope="session")
def viewer_url(tiny_dataset: Path) -> Iterator[str]:
    """Base URL of a viewer serving the generated dataset, on a free port."""
    from samplehd.viewer.app import ViewerApp
    from samplehd.viewer.server import ViewerServer, open_dataset

    server = ViewerServer(("127.0.0.1", 0), ViewerApp(open_dataset(tiny_dataset, render=False)))
    server.start_in_thread()
    yield server.url
    server.shutdown()
    server.server_close()


CHROME_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--no-first-run", "--window-size=1400,1000",
                "--hide-scrollbars", "--disable-dev-shm-usage")


def _find(*names: str) -> str | None:
    for name in names:
        path = shutil.which(name)
        if path:
            return path
    return None


@pytest.fixture(scope="session")
def browser() -> Iterator[Any]:
    """Headless Debian chromium through selenium and /usr/bin/chromedriver; skips when missing."""
    chromium = _find("chromium", "chromium-browser")
    driver_path = _find("chromedriver")
    if chromium is None or driver_path is None:
        pytest.skip("headless browser tests need Debian's chromium and chromium-driver "
                    "(apt-get install -y chromium chromium-driver)")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        pytest.skip("headless browser tests need selenium (pip install selenium)")
    os.environ.setdefault("SE_OFFLINE", "true")  # selenium-manager must never download a browser or driver
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    profile = tempfile.mkdtemp(prefix="samplehd-chromium-")
    for flag in (*CHROME_FLAGS, f"--user-data-dir={profile}"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(driver_path), options=options)
    driver.set_page_load_timeout(30)
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)

"""Fixtures of the viewer tests: a small synthetic dataset (no rendering), a synthetic episode store,
a server on a free port in a thread, and a headless Chromium driven by selenium (skipped cleanly
when chromium, chromedriver or selenium is missing)."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from viewer_fakes import FakeEpisodeStore, make_fake_dataset

from samplehd.viewer.index import DatasetIndex


@pytest.fixture(scope="session")
def fake_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_fake_dataset(tmp_path_factory.mktemp("viewer") / "dataset")


@pytest.fixture(scope="session")
def viewer_url(fake_dataset: Path) -> Iterator[str]:
    """Base URL of a viewer serving the fake dataset with fake episodes, on a free port."""
    from samplehd.viewer.app import ViewerApp
    from samplehd.viewer.server import ViewerServer

    index = DatasetIndex(fake_dataset)
    index.episodes = FakeEpisodeStore(index)
    server = ViewerServer(("127.0.0.1", 0), ViewerApp(index))
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

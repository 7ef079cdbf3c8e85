"""The viewer page in headless Chromium: loads without console errors, filters scenes, shows the
annotation under the cursor, draws the program tree and target outlines, plays episodes, and the
server refuses paths outside the dataset."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("selenium", reason="headless browser tests need selenium (pip install selenium)")

from selenium.webdriver.common.action_chains import ActionChains  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import Select, WebDriverWait  # noqa: E402


def _open(browser: Any, url: str) -> None:
    browser.get(url)
    browser.get_log("browser")  # start each check with an empty console


def _console_errors(browser: Any) -> list[str]:
    return [e["message"] for e in browser.get_log("browser") if e["level"] == "SEVERE"]


def _wait(browser: Any, condition: Any, timeout: float = 10.0) -> Any:
    return WebDriverWait(browser, timeout, poll_frequency=0.05).until(condition)


def _cards(browser: Any) -> list[int]:
    return [int(c.get_attribute("data-scene")) for c in browser.find_elements(By.CSS_SELECTOR, "#scene-grid .card")]


def test_scene_grid_loads_and_filters(browser: Any, viewer_url: str) -> None:
    _open(browser, viewer_url)
    _wait(browser, lambda b: len(_cards(b)) == 4)
    assert "4 scenes" in browser.find_element(By.ID, "counts").text
    Select(browser.find_element(By.CSS_SELECTOR, "select[data-filter=family]")).select_by_value("pick_up")
    _wait(browser, lambda b: _cards(b) == [1, 3])
    assert "family=pick_up" in browser.current_url
    Select(browser.find_element(By.CSS_SELECTOR, "select[data-filter=split]")).select_by_value("test")
    _wait(browser, lambda b: _cards(b) == [3])
    browser.find_element(By.XPATH, "//button[text()='clear filters']").click()
    _wait(browser, lambda b: len(_cards(b)) == 4)
    Select(browser.find_element(By.CSS_SELECTOR, "select[data-filter=success]")).select_by_value("failure")
    _wait(browser, lambda b: _cards(b) == [0, 2])
    _wait(browser, lambda b: all(img.get_attribute("naturalWidth") not in (None, "0")
                                 for img in b.find_elements(By.CSS_SELECTOR, "#scene-grid img")))
    assert _console_errors(browser) == []


def test_scene_page_annotates_the_object_under_the_cursor(browser: Any, viewer_url: str) -> None:
    _open(browser, f"{viewer_url}#/scene/0")
    image = _wait(browser, lambda b: b.find_element(By.ID, "scene-image"))
    _wait(browser, lambda b: int(image.get_attribute("naturalWidth") or 0) == 320)
    size = image.size
    # object 1 of the fake scene covers pixels x 125..185, y 80..150 of the 320×180 image
    dx = (155 / 320 - 0.5) * size["width"]
    dy = (115 / 180 - 0.5) * size["height"]
    ActionChains(browser).move_to_element_with_offset(image, int(dx), int(dy)).perform()
    card = browser.find_element(By.ID, "hover-card")
    _wait(browser, lambda b: "#1 bowl" in card.text)
    assert "segmentation id" in card.text and "depth 1.320 m" in card.text
    assert browser.find_element(By.CSS_SELECTOR, "tr[data-object='1']").get_attribute("class") == "hot"
    for modality in ("depth", "segmentation", "rgb"):
        browser.find_element(By.CSS_SELECTOR, f"button[data-modality={modality}]").click()
        _wait(browser, lambda b, m=modality: image.get_attribute("src").endswith(f"/image/{m}"))
        _wait(browser, lambda b: int(image.get_attribute("naturalWidth") or 0) == 320)
    links = browser.find_elements(By.CSS_SELECTOR, "#instruction-list a")
    assert [a.text for a in links][:1] == ["Put the mug on the left."]
    assert _console_errors(browser) == []


def test_instruction_page_draws_program_tree_and_targets(browser: Any, viewer_url: str) -> None:
    _open(browser, f"{viewer_url}#/instruction/1")
    _wait(browser, lambda b: b.find_elements(By.CSS_SELECTOR, "#program-tree svg.tree g.node"))
    nodes = browser.find_elements(By.CSS_SELECTOR, "#program-tree svg.tree g.node")
    assert len(nodes) == 7
    assert len(browser.find_elements(By.CSS_SELECTOR, "#program-tree svg.tree path[marker-end]")) == 6
    assert browser.find_element(By.ID, "instruction-family").text == "stack"
    tokens = [t.text for t in browser.find_elements(By.CSS_SELECTOR, "#flat-program .tok")]
    assert tokens == ["stack", "scene", "filter_name[mug]", "scene", "filter_name[bowl]"]
    legend = browser.find_element(By.ID, "target-legend").text
    assert "moved: #0" in legend and "reference: #1" in legend
    # the overlay holds orange (moved) and blue (reference) outline pixels
    counts = _wait(browser, lambda b: b.execute_script("""
        const c = document.getElementById('overlay');
        if (!c.width) return null;
        const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
        let moved = 0, ref = 0;
        for (let i = 0; i < d.length; i += 4) {
          if (d[i + 3] === 255 && d[i] === 255 && d[i + 1] === 120) moved++;
          if (d[i + 3] === 255 && d[i] === 0 && d[i + 1] === 170) ref++;
        }
        return moved && ref ? [moved, ref] : null;"""))
    assert counts[0] > 100 and counts[1] > 100
    assert _console_errors(browser) == []


def _frame_number(browser: Any) -> int:
    return int(browser.find_element(By.ID, "frame-label").text.split()[1])


def test_episode_player_advances_frames(browser: Any, viewer_url: str) -> None:
    _open(browser, f"{viewer_url}#/episode/s000000_00")
    _wait(browser, lambda b: b.find_elements(By.ID, "frame-label") and _frame_number(b) == 1)
    frame_image = browser.find_element(By.ID, "episode-frame")
    _wait(browser, lambda b: int(frame_image.get_attribute("naturalWidth") or 0) == 320)
    browser.find_element(By.ID, "step").click()
    assert _frame_number(browser) == 2 and frame_image.get_attribute("src").split("?")[0].endswith("/frame/1")
    browser.find_element(By.ID, "play").click()
    _wait(browser, lambda b: _frame_number(b) >= 8)
    browser.find_element(By.ID, "play").click()
    paused = _frame_number(browser)
    browser.implicitly_wait(0)
    WebDriverWait(browser, 0.5).until(lambda b: True)
    assert abs(_frame_number(browser) - paused) <= 1
    browser.find_element(By.ID, "last").click()
    assert _frame_number(browser) == 40
    assert "MoveToDefaultPos" in browser.find_element(By.ID, "subtask-now").text
    browser.find_element(By.ID, "first").click()
    assert "GripperMoveAvoid" in browser.find_element(By.ID, "subtask-now").text
    browser.find_element(By.CSS_SELECTOR, "button[data-modality=segmentation]").click()
    _wait(browser, lambda b: "modality=segmentation" in frame_image.get_attribute("src"))
    assert browser.find_element(By.ID, "verdict").text == "✓ success"
    # three plots and the timeline are drawn on canvases with real pixels
    drawn = browser.execute_script("""
        return [...document.querySelectorAll('.plot canvas, .timeline canvas')].map((c) => {
          const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
          let ink = 0; for (let i = 3; i < d.length; i += 4) if (d[i]) ink++;
          return ink; });""")
    assert len(drawn) == 4 and min(drawn) > 500
    assert _console_errors(browser) == []
    _open(browser, f"{viewer_url}#/episode/s000000_01")
    _wait(browser, lambda b: "object_dropped" in b.find_element(By.ID, "verdict").text)


def test_episode_list_and_refused_paths(browser: Any, viewer_url: str, fake_dataset: Path) -> None:
    _open(browser, f"{viewer_url}#/episodes")
    _wait(browser, lambda b: len(b.find_elements(By.CSS_SELECTOR, "#episode-table tr")) == 6)
    Select(browser.find_element(By.CSS_SELECTOR, "select[data-filter=success]")).select_by_value("failure")
    _wait(browser, lambda b: len(b.find_elements(By.CSS_SELECTOR, "#episode-table tr")) == 2)
    assert "no_feasible_grasp" in browser.find_element(By.ID, "rejection-table").text
    assert _console_errors(browser) == []
    (fake_dataset.parent / "outside.txt").write_text("secret")
    statuses = browser.execute_async_script("""
        const done = arguments[arguments.length - 1];
        Promise.all(['/files/%2e%2e/outside.txt', '/files/..%2foutside.txt', '/static/%2e%2e/server.py',
                     '/files/scenes.json'].map((u) => fetch(u).then((r) => r.status))).then(done);""")
    # the browser itself folds %2e%2e into ".." and drops it (404); what reaches the server is refused (403)
    assert all(code in (403, 404) for code in statuses[:3]) and statuses[3] == 200
    browser.get(f"{viewer_url}files/%2e%2e/outside.txt")
    assert "secret" not in browser.page_source


def test_dataset_being_written_shows_its_state_without_errors(browser: Any, tmp_path: Path) -> None:
    import os

    from viewer_fakes import make_fake_dataset

    from samplehd.viewer import DatasetIndex, ViewerApp, ViewerServer

    root = make_fake_dataset(tmp_path / "growing", num_scenes=3)
    (root / "scenes.json").write_text('{"info": {}, "scenes": [')
    (root / "instructions.json").unlink()
    os.remove(root / "images" / "SHD_train_000002.png")
    server = ViewerServer(("127.0.0.1", 0), ViewerApp(DatasetIndex(root)))
    server.start_in_thread()
    try:
        _open(browser, server.url)
        _wait(browser, lambda b: len(_cards(b)) == 3)
        banner = browser.find_element(By.ID, "banner")
        assert banner.is_displayed() and "still being written" in banner.text and "scenes.json: partial" in banner.text
        assert "image not written yet" in browser.find_element(By.CSS_SELECTOR, "[data-scene='2']").text
        _open(browser, f"{server.url}#/scene/2")
        _wait(browser, lambda b: "not written yet" in b.find_element(By.ID, "view").text)
        assert "no instructions for this scene" in browser.find_element(By.ID, "view").text
        assert _console_errors(browser) == []
    finally:
        server.shutdown()
        server.server_close()


def test_dataset_page_lists_file_states(browser: Any, viewer_url: str) -> None:
    _open(browser, f"{viewer_url}#/dataset")
    table = _wait(browser, lambda b: b.find_element(By.ID, "file-states"))
    assert "scenes.json" in table.text and "instructions.json" in table.text
    assert _console_errors(browser) == []

"""The viewer page while a dataset grows, in headless Chromium on a real generated dataset: an answer
for a page the user has left is dropped, a list page keeps its filters and scroll position and offers
"N new — refresh" instead of redrawing itself, previous/next stop at the ends, and empty results say
why."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from dataset_states import DatasetFiles

pytest.importorskip("selenium", reason="headless browser tests need selenium (pip install selenium)")

import page  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402


def _wait(browser: Any, condition: Any, timeout: float = 15.0) -> Any:
    return page.wait(browser, condition, timeout)


def _errors(browser: Any) -> list[str]:
    return [e["message"] for e in browser.get_log("browser") if e["level"] == "SEVERE"]


def _cards(browser: Any) -> list[int]:
    return page.scene_cards(browser)


@pytest.fixture()
def small_window(browser: Any) -> Iterator[Any]:
    """The session's browser in a window small enough that a scene list scrolls."""
    size = browser.get_window_size()
    browser.set_window_size(420, 420)
    yield browser
    browser.set_window_size(size["width"], size["height"])


def test_answer_for_a_page_the_user_left_is_dropped(browser: Any, viewer_url: str,
                                                    dataset_files: DatasetFiles) -> None:
    browser.get(f"{viewer_url}#/scene/0")
    _wait(browser, lambda b: b.find_element(By.TAG_NAME, "h1").text.startswith("Scene 0"))
    browser.get_log("browser")
    # The network answers instruction requests late (the page's own fetch, delayed in the browser).
    browser.execute_script("""
        const real = window.fetch;
        window.fetch = (url, opts) => String(url).includes('/api/instructions/')
          ? new Promise((ok) => setTimeout(() => ok(real(url, opts)), 1500)) : real(url, opts);""")
    browser.execute_script("location.hash = '#/instruction/0'")
    browser.execute_script("setTimeout(() => { location.hash = '#/scene/1'; }, 100)")
    _wait(browser, lambda b: b.find_element(By.TAG_NAME, "h1").text.startswith("Scene 1"))
    # the late answer arrives after 1.5 s; the page must still be scene 1
    browser.execute_async_script("setTimeout(arguments[arguments.length - 1], 2500)")
    assert browser.find_element(By.TAG_NAME, "h1").text.startswith("Scene 1")
    assert _errors(browser) == []


def test_growing_dataset_keeps_filters_and_scroll_until_refresh(small_window: Any, dataset_copy: Path,
                                                                dataset_files: DatasetFiles,
                                                                serve: Callable[[Path], str]) -> None:
    browser = small_window
    root = dataset_copy
    # scenes stage of generation: per-scene files only, the last scene not written yet
    (root / "scenes.json").unlink()
    last = dataset_files.scenes[-1]
    stem = last["image_filename"].removesuffix(".png")
    aside = root.parent / f"{stem}.json"
    shutil.move(root / "scenes" / f"{stem}.json", aside)
    split = last["split"]
    same_split = [s["image_index"] for s in dataset_files.scenes if s["split"] == split]
    assert len(same_split) >= 2, "the tiny dataset needs two scenes of the last scene's split"
    url = serve(root)
    browser.get(f"{url}#/?split={split}")
    _wait(browser, lambda b: _cards(b) == same_split[:-1])
    browser.execute_script("window.scrollTo(0, document.body.scrollHeight)")
    y = browser.execute_script("return window.scrollY")
    assert y > 0, "the window is small enough to scroll"
    shutil.move(aside, root / "scenes" / f"{stem}.json")
    button = _wait(browser, lambda b: b.find_element(By.ID, "refresh-list") if b.find_elements(
        By.ID, "refresh-list") and b.find_element(By.ID, "refresh-list").is_displayed() else None)
    assert button.text == "1 new scene — refresh"
    # nothing moved under the user: same cards, same place
    assert _cards(browser) == same_split[:-1]
    assert browser.execute_script("return window.scrollY") == y
    button.click()
    _wait(browser, lambda b: _cards(b) == same_split)
    assert browser.find_element(By.CSS_SELECTOR, "select[data-filter=split]").get_attribute("value") == split
    assert f"split={split}" in browser.current_url
    assert browser.execute_script("return window.scrollY") == y
    assert not browser.find_elements(By.ID, "refresh-list")
    # a reload keeps the place too
    browser.refresh()
    _wait(browser, lambda b: _cards(b) == same_split)
    _wait(browser, lambda b: b.execute_script("return window.scrollY") == y)
    assert _errors(browser) == []


def test_previous_next_stop_at_the_ends(browser: Any, viewer_url: str, dataset_files: DatasetFiles) -> None:
    last = len(dataset_files.scenes) - 1
    browser.get(f"{viewer_url}#/scene/0")
    _wait(browser, lambda b: b.find_element(By.TAG_NAME, "h1").text.startswith("Scene 0"))
    prev = browser.find_element(By.CSS_SELECTOR, "[data-step=prev]")
    assert prev.tag_name == "span" and prev.get_attribute("aria-disabled") == "true"
    assert browser.find_element(By.CSS_SELECTOR, "[data-step=next]").tag_name == "a"
    browser.get(f"{viewer_url}#/scene/{last}")
    _wait(browser, lambda b: b.find_element(By.TAG_NAME, "h1").text.startswith(f"Scene {last}"))
    assert browser.find_element(By.CSS_SELECTOR, "[data-step=next]").tag_name == "span"
    browser.get(f"{viewer_url}#/scene/-1")
    error = _wait(browser, lambda b: b.find_element(By.CSS_SELECTOR, "[data-error]"))
    assert "no scene -1" in error.text
    n = len(dataset_files.instructions)
    browser.get(f"{viewer_url}#/instruction/{n - 1}")
    _wait(browser, lambda b: b.find_element(By.TAG_NAME, "h1").text == f"Instruction {n - 1}")
    assert browser.find_element(By.CSS_SELECTOR, "[data-step=next]").tag_name == "span"
    assert _errors(browser) == []


def test_empty_results_say_why(browser: Any, dataset_copy: Path, serve: Callable[[Path], str]) -> None:
    info = json.loads((dataset_copy / "info.json").read_text())
    families = sorted({e["family"] for e in info["episodes"]})
    url = serve(dataset_copy)
    browser.get(f"{url}#/episodes?family={families[0]}&success=failure")
    empty = _wait(browser, lambda b: b.find_element(By.ID, "episodes-empty"))
    assert f"no episode matches these filters ({len(info['episodes'])} episodes in all)" in empty.text
    assert not browser.find_elements(By.ID, "episode-table")
    browser.get(f"{url}#/?family=bogus")
    _wait(browser, lambda b: "no scene matches these filters" in b.find_element(By.ID, "scene-grid").text)
    assert _errors(browser) == []

"""Reading the viewer page from a test without racing its redraws: the grid and the episode view are
rebuilt whenever data arrives, so an element found in one poll may be gone in the next."""

from __future__ import annotations

from typing import Any

from selenium.common.exceptions import StaleElementReferenceException
from selenium.webdriver.support.ui import WebDriverWait


def wait(browser: Any, condition: Any, timeout: float = 15.0) -> Any:
    """``condition(browser)`` once truthy; a poll that touched an element the page had just replaced
    counts as not yet."""
    return WebDriverWait(browser, timeout, poll_frequency=0.05,
                         ignored_exceptions=(StaleElementReferenceException,)).until(condition)


def scene_cards(browser: Any) -> list[int]:
    """The scene indices the grid shows, read in one script call so a redraw cannot split the read."""
    return browser.execute_script(
        "return Array.from(document.querySelectorAll('#scene-grid .card'), c => Number(c.dataset.scene));")

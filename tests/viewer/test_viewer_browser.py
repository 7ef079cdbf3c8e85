"""The viewer page in headless Chromium, on a real dataset made by ``samplehd generate``: loads
without console errors, filters scenes, shows the annotation under the cursor, draws the program tree
and target outlines, plays episodes, and the server refuses paths outside the dataset."""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from dataset_states import DatasetFiles, write_failed_episode
from PIL import Image

from samplehd.dataset.reader import DatasetReader

pytest.importorskip("selenium", reason="headless browser tests need selenium (pip install selenium)")

import page  # noqa: E402
from selenium.webdriver.common.action_chains import ActionChains  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import Select  # noqa: E402


def _open(browser: Any, url: str) -> None:
    browser.get(url)
    browser.get_log("browser")  # start each check with an empty console


def _console_errors(browser: Any) -> list[str]:
    return [e["message"] for e in browser.get_log("browser") if e["level"] == "SEVERE"]


def _wait(browser: Any, condition: Any, timeout: float = 10.0) -> Any:
    return page.wait(browser, condition, timeout)


def _cards(browser: Any) -> list[int]:
    return page.scene_cards(browser)


def _instructions_by_family(files: DatasetFiles) -> dict[str, list[int]]:
    """Scenes each family has an instruction in."""
    out: dict[str, list[int]] = {}
    for scene in files.scenes:
        for q in files.instructions_of(scene["image_index"]):
            if scene["image_index"] not in out.setdefault(q["family"], []):
                out[q["family"]].append(scene["image_index"])
    return out


def test_scene_grid_loads_and_filters(browser: Any, viewer_url: str, dataset_files: DatasetFiles) -> None:
    files = dataset_files
    indices = [s["image_index"] for s in files.scenes]
    _open(browser, viewer_url)
    _wait(browser, lambda b: _cards(b) == indices)
    assert f"{len(indices)} scenes" in browser.find_element(By.ID, "counts").text
    by_family = _instructions_by_family(files)
    # a family some scenes have and others lack shows the filter filtering
    family = next((f for f, found in sorted(by_family.items()) if len(found) < len(indices)), sorted(by_family)[0])
    Select(browser.find_element(By.CSS_SELECTOR, "select[data-filter=family]")).select_by_value(family)
    _wait(browser, lambda b: _cards(b) == by_family[family])
    assert f"family={family}" in browser.current_url
    split = files.scenes[by_family[family][0]]["split"]
    Select(browser.find_element(By.CSS_SELECTOR, "select[data-filter=split]")).select_by_value(split)
    _wait(browser, lambda b: _cards(b) == [i for i in by_family[family] if files.scenes[i]["split"] == split])
    browser.find_element(By.XPATH, "//button[text()='clear filters']").click()
    _wait(browser, lambda b: _cards(b) == indices)
    Select(browser.find_element(By.CSS_SELECTOR, "select[data-filter=success]")).select_by_value("failure")
    _wait(browser, lambda b: _cards(b) == [i for i in indices if "failure" in files.outcomes(i)])
    _wait(browser, lambda b: all(img.get_attribute("naturalWidth") not in (None, "0")
                                 for img in b.find_elements(By.CSS_SELECTOR, "#scene-grid img")))
    assert _console_errors(browser) == []


def _deepest_pixel(mask: np.ndarray) -> tuple[int, int]:
    """(x, y) of a pixel of ``mask`` farthest from its border (peeled off one ring at a time)."""
    inside = mask.copy()
    while True:
        peeled = inside.copy()
        peeled[1:] &= inside[:-1]
        peeled[:-1] &= inside[1:]
        peeled[:, 1:] &= inside[:, :-1]
        peeled[:, :-1] &= inside[:, 1:]
        if not peeled.any():
            ys, xs = np.nonzero(inside)
            return int(xs[len(xs) // 2]), int(ys[len(ys) // 2])
        inside = peeled


def test_scene_page_annotates_the_object_under_the_cursor(browser: Any, viewer_url: str,
                                                          dataset_files: DatasetFiles) -> None:
    scene = dataset_files.scenes[0]
    stem = scene["image_filename"].removesuffix(".png")
    ids = np.asarray(Image.open(dataset_files.root / "segmentation" / f"{stem}.png"))
    depth_mm = np.asarray(Image.open(dataset_files.root / "depth" / f"{stem}.png"))
    height, width = ids.shape
    offset = scene["segmentation_ids"]["object_offset"]
    k = max(range(len(scene["objects"])), key=lambda k: int((ids == offset + k).sum()))  # the largest in view
    x, y = _deepest_pixel(ids == offset + k)
    _open(browser, f"{viewer_url}#/scene/0")
    image = _wait(browser, lambda b: b.find_element(By.ID, "scene-image"))
    _wait(browser, lambda b: int(image.get_attribute("naturalWidth") or 0) == width)
    size = image.size
    dx = ((x + 0.5) / width - 0.5) * size["width"]
    dy = ((y + 0.5) / height - 0.5) * size["height"]
    ActionChains(browser).move_to_element_with_offset(image, int(dx), int(dy)).perform()
    card = browser.find_element(By.ID, "hover-card")
    _wait(browser, lambda b: f"#{k} {scene['objects'][k]['name']}" in card.text)
    assert f"id {offset + k}" in card.text and f"depth {depth_mm[y, x] / 1000:.3f} m" in card.text
    assert "segmentation id" in card.text
    assert browser.find_element(By.CSS_SELECTOR, f"tr[data-object='{k}']").get_attribute("class") == "hot"
    for modality in ("depth", "segmentation", "rgb"):
        browser.find_element(By.CSS_SELECTOR, f"button[data-modality={modality}]").click()
        _wait(browser, lambda b, m=modality: image.get_attribute("src").endswith(f"/image/{m}"))
        _wait(browser, lambda b: int(image.get_attribute("naturalWidth") or 0) == width)
    links = browser.find_elements(By.CSS_SELECTOR, "#instruction-list li > a")
    assert [a.text for a in links] == [q["instruction"] for q in dataset_files.instructions_of(0)]
    assert _console_errors(browser) == []


def test_instruction_page_draws_program_tree_and_targets(browser: Any, viewer_url: str,
                                                         dataset_files: DatasetFiles) -> None:
    files = dataset_files

    def in_view(scene: dict[str, Any]) -> set[int]:
        ids = np.asarray(Image.open(files.root / "segmentation" / scene["image_filename"]))
        return {int(v) - scene["segmentation_ids"]["object_offset"] for v in np.unique(ids)}

    # an instruction that moves one object relative to another, both in view
    q = next(q for q in files.instructions if isinstance(q["task"]["subject"], int)
             and {*q["task"]["objects"], q["task"]["subject"]} <= in_view(files.scenes[q["image_index"]]))
    moved, reference = q["task"]["objects"], q["task"]["subject"]
    _open(browser, f"{viewer_url}#/instruction/{q['instruction_index']}")
    _wait(browser, lambda b: b.find_elements(By.CSS_SELECTOR, "#program-tree svg.tree g.node"))
    nodes = browser.find_elements(By.CSS_SELECTOR, "#program-tree svg.tree g.node")
    assert len(nodes) == len(q["program"])
    edges = sum(len(node["inputs"]) for node in q["program"])
    assert len(browser.find_elements(By.CSS_SELECTOR, "#program-tree svg.tree path[marker-end]")) == edges
    assert browser.find_element(By.ID, "instruction-family").text == q["family"]
    tokens = [t.text for t in browser.find_elements(By.CSS_SELECTOR, "#flat-program .tok")]
    assert tokens == q["program_sequence"].split()
    legend = browser.find_element(By.ID, "target-legend").text
    assert f"moved: #{moved[0]}" in legend and f"reference: #{reference}" in legend
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
    scene = files.scenes[q["image_index"]]
    ids = np.asarray(Image.open(files.root / "segmentation" / scene["image_filename"]))
    offset = scene["segmentation_ids"]["object_offset"]
    assert 0 < counts[0] <= int(np.isin(ids, [offset + k for k in moved]).sum())
    assert 0 < counts[1] <= int((ids == offset + reference).sum())
    assert _console_errors(browser) == []


def _frame_number(browser: Any) -> int:
    return int(browser.find_element(By.ID, "frame-label").text.split()[1])


def test_episode_player_advances_frames(browser: Any, viewer_url: str, dataset_files: DatasetFiles,
                                        dataset_copy: Path, serve: Callable[[Path], str]) -> None:
    files = dataset_files
    stem, entry = files.stems[0], files.episodes[0]
    reader = DatasetReader(files.root)
    subtasks = list(reader.episode_meta(0).subtasks)
    subtask_index = reader.frames(0, ["subtask_index"])["subtask_index"]
    width = files.info["config"]["render"]["width"]
    _open(browser, f"{viewer_url}#/episode/{stem}")
    _wait(browser, lambda b: b.find_elements(By.ID, "frame-label") and _frame_number(b) == 1)
    frame_image = browser.find_element(By.ID, "episode-frame")
    _wait(browser, lambda b: int(frame_image.get_attribute("naturalWidth") or 0) == width)
    browser.find_element(By.ID, "step").click()
    assert _frame_number(browser) == 2 and frame_image.get_attribute("src").split("?")[0].endswith("/frame/1")
    browser.find_element(By.ID, "play").click()
    _wait(browser, lambda b: _frame_number(b) >= 8)
    browser.find_element(By.ID, "play").click()
    paused = _frame_number(browser)
    browser.implicitly_wait(0)
    time.sleep(0.5)  # long enough for several frames, were it still playing
    assert abs(_frame_number(browser) - paused) <= 1
    browser.find_element(By.ID, "last").click()
    assert _frame_number(browser) == entry["num_frames"]
    assert subtasks[subtask_index[-1]] in browser.find_element(By.ID, "subtask-now").text
    browser.find_element(By.ID, "first").click()
    assert subtasks[subtask_index[0]] in browser.find_element(By.ID, "subtask-now").text
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
    # the same episode, rewritten as one whose success check failed
    write_failed_episode(dataset_copy, stem, "object 1 dropped")
    _open(browser, f"{serve(dataset_copy)}#/episode/{stem}")
    _wait(browser, lambda b: "object 1 dropped" in b.find_element(By.ID, "verdict").text)


def test_episode_list_and_refused_paths(browser: Any, viewer_url: str, dataset_files: DatasetFiles) -> None:
    _open(browser, f"{viewer_url}#/episodes")
    _wait(browser, lambda b: len(b.find_elements(By.CSS_SELECTOR, "#episode-table tr")) == 1 + len(
        dataset_files.episodes))
    Select(browser.find_element(By.CSS_SELECTOR, "select[data-filter=success]")).select_by_value("failure")
    _wait(browser, lambda b: b.find_elements(By.ID, "episodes-empty"))  # failed paths
    rejections = browser.find_element(By.ID, "rejection-table").text  # are rejected, not recorded
    assert all(r["reason"] in rejections for r in dataset_files.rejections)
    assert _console_errors(browser) == []
    (dataset_files.root.parent / "outside.txt").write_text("secret")
    statuses = browser.execute_async_script("""
        const done = arguments[arguments.length - 1];
        Promise.all(['/files/%2e%2e/outside.txt', '/files/..%2foutside.txt', '/static/%2e%2e/server.py',
                     '/files/scenes.json'].map((u) => fetch(u).then((r) => r.status))).then(done);""")
    # the browser itself folds %2e%2e into ".." and drops it (404); what reaches the server is refused (403)
    assert all(code in (403, 404) for code in statuses[:3]) and statuses[3] == 200
    browser.get(f"{viewer_url}files/%2e%2e/outside.txt")
    assert "secret" not in browser.page_source


def test_dataset_being_written_shows_its_state_without_errors(browser: Any, dataset_copy: Path,
                                                              dataset_files: DatasetFiles,
                                                              serve: Callable[[Path], str]) -> None:
    # scenes stage of `samplehd generate`: the per-scene files are written, the last scene's image not
    # yet; scenes.json (written last) is half there, no instruction candidates nor episodes yet
    root = dataset_copy
    info = {k: dataset_files.info[k] for k in ("format_version", "versions", "config")}
    (root / "info.json").write_text(json.dumps({**info, "status": "in_progress"}))
    complete = (root / "scenes.json").read_bytes()
    (root / "scenes.json").write_bytes(complete[: len(complete) // 2])
    for name in ("instructions.json", "candidates.json", "journal.jsonl"):
        (root / name).unlink()
    shutil.rmtree(root / "episodes")
    last = dataset_files.scenes[-1]
    (root / "images" / last["image_filename"]).unlink()
    i = last["image_index"]
    url = serve(root)
    _open(browser, url)
    _wait(browser, lambda b: len(_cards(b)) == len(dataset_files.scenes))
    banner = browser.find_element(By.ID, "banner")
    assert banner.is_displayed() and "still being written" in banner.text and "scenes.json: partial" in banner.text
    assert "image not written yet" in browser.find_element(By.CSS_SELECTOR, f"[data-scene='{i}']").text
    _open(browser, f"{url}#/scene/{i}")
    _wait(browser, lambda b: "not written yet" in b.find_element(By.ID, "view").text)
    assert "no instructions for this scene" in browser.find_element(By.ID, "view").text
    assert _console_errors(browser) == []


def test_dataset_page_lists_file_states(browser: Any, viewer_url: str) -> None:
    _open(browser, f"{viewer_url}#/dataset")
    table = _wait(browser, lambda b: b.find_element(By.ID, "file-states"))
    assert "scenes.json" in table.text and "instructions.json" in table.text
    assert _console_errors(browser) == []

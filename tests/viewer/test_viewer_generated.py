"""The viewer on every page of the session's dataset made by ``samplehd generate --preset tiny``, through
the API and in headless Chromium, and on its episodes stored without images (rendered on demand)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from dataset_states import DatasetFiles

from samplehd.viewer.app import ViewerApp
from samplehd.viewer.server import open_dataset


def test_every_page_of_a_generated_dataset_answers(tiny_dataset: Path) -> None:
    app = ViewerApp(open_dataset(tiny_dataset))
    status = json.loads(app.handle("/api/status", {}).body)
    assert {f["name"]: f["state"] for f in status["files"]} == {
        "info.json": "ok", "scenes.json": "ok", "instructions.json": "ok", "episodes": "ok"}
    for scene in json.loads(app.handle("/api/scenes", {}).body)["scenes"]:
        i = scene["index"]
        for path in (f"/api/scenes/{i}", f"/api/scenes/{i}/thumb", f"/api/scenes/{i}/ids",
                     *(f"/api/scenes/{i}/image/{m}" for m in ("rgb", "depth", "segmentation"))):
            assert app.handle(path, {}).status == 200, path
    instructions = json.loads((tiny_dataset / "instructions.json").read_text())["instructions"]
    for q in instructions:
        answer = json.loads(app.handle(f"/api/instructions/{q['instruction_index']}", {}).body)
        assert len(answer["episodes"]) == 1, q["instruction_index"]  # instruction i ↔ episode i
    episodes = json.loads(app.handle("/api/episodes", {}).body)["episodes"]
    assert len(episodes) == len(instructions) >= 1
    for e in episodes:
        detail = json.loads(app.handle(f"/api/episodes/{e['episode']}", {}).body)
        assert detail["success"] and len(detail["series"]["joint_pos"]) == detail["num_frames"]
        camera = next(iter(detail["cameras"]))
        for modality in detail["cameras"][camera]:
            frame = app.handle(f"/api/episodes/{e['episode']}/frame/{detail['num_frames'] - 1}",
                               {"camera": camera, "modality": modality})
            assert frame.status == 200, (e["episode"], modality)


def test_browser_plays_a_generated_episode(browser: Any, viewer_url: str, dataset_files: DatasetFiles) -> None:
    import page
    from selenium.webdriver.common.by import By

    browser.get(viewer_url)
    page.wait(browser, lambda b: len(page.scene_cards(b)) == len(dataset_files.scenes), 20)
    browser.get(f"{viewer_url}#/instruction/0")
    page.wait(browser, lambda b: b.find_elements(By.CSS_SELECTOR, "#program-tree svg.tree g.node"), 20)
    browser.get(f"{viewer_url}#/episode/{dataset_files.stems[0]}")
    page.wait(browser, lambda b: b.find_elements(By.ID, "frame-label"), 20)
    page.wait(browser, lambda b: int(b.find_element(By.ID, "episode-frame").get_attribute("naturalWidth") or 0) > 0, 20)
    browser.find_element(By.ID, "play").click()
    page.wait(browser, lambda b: int(b.find_element(By.ID, "frame-label").text.split()[1]) >= 10, 20)
    browser.find_element(By.ID, "play").click()
    assert [e for e in browser.get_log("browser") if e["level"] == "SEVERE"] == []


@pytest.mark.render
def test_episode_stored_without_images_is_rendered_from_its_states(tiny_dataset: Path, dataset_copy: Path) -> None:
    import dataclasses
    import io

    import numpy as np
    from PIL import Image

    from samplehd.dataset.container import read_episode, read_meta, write_episode

    states_only = dataset_copy
    stem = json.loads((tiny_dataset / "info.json").read_text())["episodes"][0]["file"].split("/")[-1][:-3]
    path = states_only / "episodes" / f"{stem}.h5"
    meta = read_meta(path)
    episode = dataclasses.replace(read_episode(path, images="none"), images={})
    write_episode(path, episode, extra={k: meta[k] for k in ("slot", "instruction", "task")})
    rendered, stored = ViewerApp(open_dataset(states_only)), ViewerApp(open_dataset(tiny_dataset))
    try:
        detail = json.loads(rendered.handle(f"/api/episodes/{stem}", {}).body)
        assert detail["rendered_on_demand"] and set(detail["cameras"]) == {"scene", "operator", "wrist"}
        last = detail["num_frames"] - 1
        pictures = []
        for app in (rendered, stored):
            answer = app.handle(f"/api/episodes/{stem}/frame/{last}", {"camera": "scene", "modality": "rgb"})
            assert answer.status == 200
            pictures.append(np.asarray(Image.open(io.BytesIO(answer.body))).astype(int))
        assert np.abs(pictures[0] - pictures[1]).mean() < 1.0  # same state, same renderer, same pixels
        assert rendered.handle(f"/api/episodes/{stem}/frame/0", {"camera": "wrist", "modality": "depth"}).status == 200
        without = ViewerApp(open_dataset(states_only, render=False))
        refused = without.handle(f"/api/episodes/{stem}/frame/0", {"camera": "scene", "modality": "rgb"})
        assert refused.status == 404 and b"stores no images" in refused.body
    finally:
        rendered.index.episodes.renderer.close()
        stored.index.episodes.renderer.close()

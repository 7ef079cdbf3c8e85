"""The viewer's server without a browser, on a real dataset made by ``samplehd generate``: routes,
filters, images, containment, partial datasets."""

from __future__ import annotations

import http.client
import io
import json
import os
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import numpy as np
import pytest
from dataset_states import DatasetFiles, write_failed_episode
from PIL import Image

from samplehd.dataset.reader import DatasetReader
from samplehd.errors import DatasetError
from samplehd.viewer import DatasetIndex, ViewerApp, filter_scene_summaries, resolve_inside
from samplehd.viewer.imaging import colourise_depth, colourise_segmentation, raw_array_bytes
from samplehd.viewer.server import open_dataset


def _get(url: str, path: str, method: str = "GET") -> tuple[int, dict[str, str], bytes]:
    """Send ``path`` verbatim (no client-side normalisation of ``..``)."""
    parts = urlsplit(url)
    conn = http.client.HTTPConnection(parts.hostname, parts.port, timeout=60)
    conn.request(method, path)
    response = conn.getresponse()
    body = response.read()
    conn.close()
    return response.status, dict(response.getheaders()), body


@pytest.fixture()
def app(tiny_dataset: Path) -> ViewerApp:
    return ViewerApp(open_dataset(tiny_dataset, render=False))


def _json(app: ViewerApp, path: str, query: dict[str, str] | None = None) -> Any:
    response = app.handle(path, query or {})
    assert response.status == 200, (path, response.body[:300])
    return json.loads(response.body)


def test_resolve_inside_refuses_escapes(tmp_path: Path) -> None:
    root = tmp_path / "data"
    (root / "images").mkdir(parents=True)
    (tmp_path / "secret.txt").write_text("no")
    (root / "link").symlink_to(tmp_path / "secret.txt")
    assert resolve_inside(root, "images/a.png") == (root / "images" / "a.png").resolve()
    assert resolve_inside(root, "") == root.resolve()
    for bad in ("../secret.txt", "%2e%2e/secret.txt", "%2E%2E%2Fsecret.txt", "images/../../secret.txt",
                "..%5csecret.txt", "a/%00b", "link", "c:/windows"):
        with pytest.raises(DatasetError):
            resolve_inside(root, bad)
    # double encoding decodes once only: a literal folder named "%2e%2e" inside the root
    assert resolve_inside(root, "%252e%252e/x").is_relative_to(root.resolve())


def test_status_and_scene_filters(app: ViewerApp, dataset_files: DatasetFiles) -> None:
    files = dataset_files
    status = _json(app, "/api/status")
    assert status["counts"] == {"scenes": len(files.scenes), "instructions": len(files.instructions),
                                "episodes": len(files.episodes)}
    assert {f["name"]: f["state"] for f in status["files"]} == {
        "info.json": "ok", "scenes.json": "ok", "instructions.json": "ok", "episodes": "ok"}
    everything = _json(app, "/api/scenes")
    indices = [s["image_index"] for s in files.scenes]
    assert everything["matched"] == len(indices) and everything["options"]["split"] == ["test", "train"]
    families = {q["family"] for q in files.instructions}
    assert set(everything["options"]["family"]) == families
    for family in families:
        expected = [i for i in indices if any(q["family"] == family for q in files.instructions_of(i))]
        assert [s["index"] for s in _json(app, "/api/scenes", {"family": family})["scenes"]] == expected, family
        for split in ("train", "test"):
            both = _json(app, "/api/scenes", {"family": family, "split": split})
            assert [s["index"] for s in both["scenes"]] == [
                i for i in expected if files.scenes[i]["split"] == split], (family, split)
    for outcome in ("success", "failure", "none"):
        matched = _json(app, "/api/scenes", {"success": outcome})
        assert [s["index"] for s in matched["scenes"]] == [i for i in indices if outcome in files.outcomes(i)]
    # the rejected path makes its scene a failure
    assert _json(app, "/api/scenes", {"success": "failure"})["matched"] >= 1
    colour = files.scenes[0]["objects"][0]["colour"]
    coloured = _json(app, "/api/scenes", {"colour": colour})
    assert [s["index"] for s in coloured["scenes"]] == [
        i for i in indices if any(o["colour"] == colour for o in files.scenes[i]["objects"])]
    page = _json(app, "/api/scenes", {"offset": "1", "limit": "1"})
    assert [s["index"] for s in page["scenes"]] == indices[1:2]
    assert app.handle("/api/scenes", {"bogus": "1"}).status == 400
    with pytest.raises(DatasetError, match="valid"):
        filter_scene_summaries([], {"shape": "cube"})


def test_scene_detail_images_and_raw_pixels(app: ViewerApp, dataset_files: DatasetFiles) -> None:
    scene = dataset_files.scenes[0]
    stem = scene["image_filename"].removesuffix(".png")
    detail = _json(app, "/api/scenes/0")
    assert detail["scene"]["objects"] == scene["objects"]
    assert detail["images"] == {"rgb": True, "depth": True, "segmentation": True}
    assert [q["instruction_index"] for q in detail["instructions"]] == [
        q["instruction_index"] for q in dataset_files.instructions_of(0)]
    assert [q["family"] for q in detail["instructions"]] == [q["family"] for q in dataset_files.instructions_of(0)]
    for modality in ("rgb", "depth", "segmentation"):
        response = app.handle(f"/api/scenes/0/image/{modality}", {})
        assert response.status == 200 and response.content_type == "image/png"
        assert response.body[:8] == b"\x89PNG\r\n\x1a\n"
    stored = (dataset_files.root / "images" / f"{stem}.png").read_bytes()
    assert app.handle("/api/scenes/0/image/rgb", {}).body == stored
    thumb = app.handle("/api/scenes/0/thumb", {})
    assert thumb.status == 200 and thumb.body[:2] == b"\xff\xd8"
    ids = app.handle("/api/scenes/0/ids", {})
    w, h = int(ids.headers["X-Width"]), int(ids.headers["X-Height"])
    pixels = np.frombuffer(ids.body, np.dtype(ids.headers["X-Dtype"]).newbyteorder("<")).reshape(h, w)
    truth = np.asarray(Image.open(dataset_files.root / "segmentation" / f"{stem}.png"))
    np.testing.assert_array_equal(pixels, truth)
    offset = scene["segmentation_ids"]["object_offset"]
    assert set(np.unique(pixels)) & {offset + k for k in range(len(scene["objects"]))}  # objects are in view
    depth = app.handle("/api/scenes/0/depth_mm", {})
    assert depth.headers["X-Dtype"] == "uint16"
    millimetres = np.frombuffer(depth.body, "<u2").reshape(h, w)
    np.testing.assert_array_equal(millimetres, np.asarray(Image.open(dataset_files.root / "depth" / f"{stem}.png")))
    assert app.handle(f"/api/scenes/{len(dataset_files.scenes) + 7}", {}).status == 404
    assert app.handle("/api/scenes/x", {}).status == 400
    assert app.handle("/api/scenes/0/image/normals", {}).status == 404


def test_instruction_and_episode_routes(app: ViewerApp, dataset_files: DatasetFiles) -> None:
    files = dataset_files
    entry, stem = files.episodes[0], files.stems[0]
    q = _json(app, f"/api/instructions/{entry['instruction_index']}")
    assert q["instruction"] == files.instructions[entry["instruction_index"]]
    assert q["scene"]["image_index"] == entry["scene_index"]
    assert [e["episode"] for e in q["episodes"]] == [stem] and q["episodes"][0]["success"] is True
    assert q["rejections"] == []
    listing = _json(app, "/api/episodes")
    assert [e["episode"] for e in listing["episodes"]] == files.stems
    assert [e["num_frames"] for e in listing["episodes"]] == [e["num_frames"] for e in files.episodes]
    # a generated dataset keeps successful paths only; the failed ones are the journal's rejections
    failed = _json(app, "/api/episodes", {"success": "failure"})
    assert failed["episodes"] == []
    assert [(r["scene_index"], r["slot"], r["reason"], r["message"]) for r in failed["rejections"]] == [
        (r["scene_index"], r["slot"], r["reason"], r["message"]) for r in files.rejections]
    rejected = files.rejections[0]
    candidate = files.candidate(rejected["scene_index"], rejected["slot"])
    first = failed["rejections"][0]
    assert first["instruction"] == candidate["instruction"] and first["family"] == candidate["family"]
    assert first["program_sequence"] == candidate["program_sequence"]
    assert first["instruction_index"] is None  # a candidate, not one of the dataset's instructions
    scene = _json(app, f"/api/scenes/{rejected['scene_index']}")
    assert [r["reason"] for r in scene["rejections"]] == [
        r["reason"] for r in files.rejections if r["scene_index"] == rejected["scene_index"]]
    assert _json(app, "/api/episodes", {"success": "success"})["rejections"] == []
    family = entry["family"]
    assert [e["episode"] for e in _json(app, "/api/episodes", {"family": family})["episodes"]] == [
        s for s, e in zip(files.stems, files.episodes, strict=True) if e["family"] == family]

    detail = _json(app, f"/api/episodes/{stem}")
    frames = DatasetReader(files.root).frames(0, ["steering", "time"])
    assert detail["num_frames"] == entry["num_frames"] == len(detail["series"]["time"])
    np.testing.assert_allclose(detail["series"]["steering"], frames["steering"], atol=1e-5)
    assert detail["cameras"] == {c: sorted(files.info["config"]["render"]["modalities"])
                                 for c in files.info["config"]["render"]["cameras"]}
    camera = files.info["config"]["render"]["cameras"][0]
    frame = app.handle(f"/api/episodes/{stem}/frame/3", {"camera": camera, "modality": "depth"})
    assert frame.status == 200 and frame.body[:4] == b"\x89PNG"
    rgb = app.handle(f"/api/episodes/{stem}/frame/3", {"camera": camera, "modality": "rgb"})
    stored = np.asarray(DatasetReader(files.root).image(0, camera, "rgb", 3))
    np.testing.assert_array_equal(np.asarray(Image.open(io.BytesIO(rgb.body))), stored)
    jpeg = app.handle(f"/api/episodes/{stem}/frame/3", {"format": "jpeg"})
    assert jpeg.content_type == "image/jpeg"
    assert app.handle(f"/api/episodes/{stem}/frame/{entry['num_frames']}", {}).status == 404
    assert app.handle("/api/episodes/s000077_00", {}).status == 404
    assert app.handle("/api/episodes/..%2f..", {}).status == 400


def test_failed_episode_is_listed_as_a_failure(dataset_copy: Path, dataset_files: DatasetFiles) -> None:
    stem, entry = dataset_files.stems[0], dataset_files.episodes[0]
    write_failed_episode(dataset_copy, stem, "object 1 dropped")
    app = ViewerApp(open_dataset(dataset_copy, render=False))
    detail = _json(app, f"/api/episodes/{stem}")  # opening the file tells the listing its verdict
    assert detail["success"] is False and detail["failure_reason"] == "object 1 dropped"
    failed = _json(app, "/api/episodes", {"success": "failure"})
    assert [e["episode"] for e in failed["episodes"]] == [stem]
    assert entry["scene_index"] in [s["index"] for s in _json(app, "/api/scenes", {"success": "failure"})["scenes"]]


def test_partial_dataset_gives_states_not_errors(dataset_copy: Path, dataset_files: DatasetFiles) -> None:
    root = dataset_copy
    last = dataset_files.scenes[-1]
    stem = last["image_filename"].removesuffix(".png")
    i = last["image_index"]
    complete = (root / "scenes.json").read_bytes()
    (root / "scenes.json").write_bytes(complete[: len(complete) // 2])  # half written
    (root / "instructions.json").unlink()
    (root / "candidates.json").unlink()
    (root / "info.json").unlink()
    shutil.rmtree(root / "episodes")
    (root / "journal.jsonl").unlink()
    os.remove(root / "images" / f"{stem}.png")
    app = ViewerApp(DatasetIndex(root))
    status = _json(app, "/api/status")
    states = {f["name"]: f["state"] for f in status["files"]}
    assert states == {"info.json": "missing", "scenes.json": "partial", "instructions.json": "missing",
                      "episodes": "missing"}
    assert status["counts"]["scenes"] == len(dataset_files.scenes)  # from the complete per-scene files
    assert _json(app, "/api/scenes")["matched"] == len(dataset_files.scenes)
    # no path attempted yet: every scene is without an outcome
    assert _json(app, "/api/scenes", {"success": "none"})["matched"] == len(dataset_files.scenes)
    missing = app.handle(f"/api/scenes/{i}/image/rgb", {})
    assert missing.status == 404 and b"not written yet" in missing.body
    assert app.handle(f"/api/scenes/{i}/thumb", {}).status == 404
    assert _json(app, f"/api/scenes/{i}")["images"]["rgb"] is False
    assert app.handle("/api/instructions/0", {}).status == 404
    first = dataset_files.scenes[0]["image_filename"]
    segmentation = root / "segmentation" / first
    segmentation.write_bytes(segmentation.read_bytes()[:40])  # truncated
    assert app.handle("/api/scenes/0/ids", {}).status == 404
    # the file completes: the next request sees it
    shutil.rmtree(root / "scenes")
    (root / "scenes.json").write_bytes(complete)
    assert _json(app, "/api/status")["files"][1]["state"] == "ok"


def test_not_a_dataset(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="no such dataset folder"):
        DatasetIndex(tmp_path / "nope")
    with pytest.raises(DatasetError, match="not a samplehd dataset"):
        DatasetIndex(tmp_path)


def test_http_server_refuses_paths_outside_the_dataset(serve: Callable[[Path], str], dataset_copy: Path) -> None:
    viewer_url = serve(dataset_copy)
    (dataset_copy.parent / "outside.txt").write_text("secret")
    for path in ("/files/../outside.txt", "/files/%2e%2e/outside.txt", "/files/%2E%2E%2Foutside.txt",
                 "/files/images/..%2f..%2foutside.txt", "/static/../server.py", "/static/%2e%2e/app.py",
                 "/files/..%5coutside.txt"):
        status, _, body = _get(viewer_url, path)
        assert status in (403, 404), path
        assert b"secret" not in body
    status, headers, body = _get(viewer_url, "/files/scenes.json")
    assert status == 200 and json.loads(body)["scenes"]
    assert "sandbox" in headers["Content-Security-Policy"]
    status, headers, _ = _get(viewer_url, "/")
    assert "default-src 'self'" in headers["Content-Security-Policy"]
    status, _, _ = _get(viewer_url, "/files/scenes.json", method="POST")
    assert status == 405
    status, headers, body = _get(viewer_url, "/", method="HEAD")
    assert status == 200 and body == b"" and headers["Content-Type"].startswith("text/html")
    status, _, body = _get(viewer_url, "/static/app.js")
    assert status == 200 and b"import" in body
    # dataset files are never served as code
    (dataset_copy / "evil.html").write_text("<script>alert(1)</script>")
    status, headers, _ = _get(viewer_url, "/files/evil.html")
    assert status == 200 and headers["Content-Type"] == "application/octet-stream"
    assert headers["Content-Disposition"].startswith("attachment") and "sandbox" in headers["Content-Security-Policy"]


def test_http_server_refuses_foreign_host_names(viewer_url: str) -> None:
    parts = urlsplit(viewer_url)
    conn = http.client.HTTPConnection(parts.hostname, parts.port, timeout=10)
    conn.request("GET", "/api/status", headers={"Host": "attacker.example:80"})
    response = conn.getresponse()
    assert response.status == 403 and b"loopback" in response.read()
    conn.close()
    for host in (f"localhost:{parts.port}", f"127.0.0.1:{parts.port}"):
        conn = http.client.HTTPConnection(parts.hostname, parts.port, timeout=10)
        conn.request("GET", "/api/status", headers={"Host": host})
        assert conn.getresponse().status == 200
        conn.close()


def test_page_assets_load_nothing_from_the_internet() -> None:
    from samplehd.viewer.app import STATIC_DIR

    for asset in STATIC_DIR.iterdir():
        text = asset.read_text()
        assert "http://" not in text.replace("http://www.w3.org/2000/svg", "") and "https://" not in text, asset


def test_colour_maps() -> None:
    depth = np.array([[0.0, 1.0], [2.0, np.nan]])
    colours = colourise_depth(depth)
    assert colours.shape == (2, 2, 3) and (colours[0, 0] == 0).all() and (colours[1, 1] == 0).all()
    assert not (colours[0, 1] == colours[1, 0]).all()
    seg = colourise_segmentation(np.array([[0, 1, 2, 3, 4]]))
    assert len({tuple(c) for c in seg[0]}) == 5
    _, dtype = raw_array_bytes(np.array([[0, 300]]))
    assert dtype == "uint16"


def test_cli_view_rejects_missing_dataset(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from samplehd.cli import main

    assert main(["view", str(tmp_path / "absent")]) == 2
    assert "no such dataset folder" in capsys.readouterr().err
    assert main(["view", str(tmp_path)]) == 2


@pytest.mark.parametrize("stop", ["SIGINT", "SIGTERM"])
def test_cli_view_serves_until_interrupted(tiny_dataset: Path, dataset_files: DatasetFiles, stop: str) -> None:
    """Ctrl-C (SIGINT, as a foreground process at a terminal gets it) and SIGTERM both stop the server
    cleanly. The child starts with SIGINT's default action: a test run in the background of a script
    inherits SIGINT ignored, which Python keeps."""
    import signal
    import subprocess
    import sys
    import time

    def foreground() -> None:
        signal.signal(signal.SIGINT, signal.SIG_DFL)

    proc = subprocess.Popen([sys.executable, "-m", "samplehd", "view", str(tiny_dataset), "--port", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=foreground)
    try:
        assert proc.stdout is not None
        lines = [proc.stdout.readline(), proc.stdout.readline()]
        counts = f"{len(dataset_files.scenes)} scenes, {len(dataset_files.instructions)} instructions"
        assert counts in lines[0], lines
        url = lines[1].split("serving on ", 1)[1].split()[0]
        assert url.startswith("http://127.0.0.1:")
        status, _, body = _get(url, "/api/status")
        assert status == 200 and json.loads(body)["counts"]["scenes"] == len(dataset_files.scenes)
    finally:
        proc.send_signal(getattr(signal, stop))
        deadline = time.monotonic() + 60  # a loaded machine may be slow to shut down
        while proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0
    assert proc.stdout.read().strip() == "stopped"


def test_state_renderer_refuses_bad_requests_before_rendering() -> None:
    from samplehd.viewer.state_render import StateRenderer

    renderer = StateRenderer()
    with pytest.raises(DatasetError, match="has no 'spec'"):
        renderer.render({"image_index": 3}, {}, "scene", "rgb")
    with pytest.raises(DatasetError, match="valid cameras"):
        renderer.render({"spec": {}}, {}, "ceiling", "rgb")
    renderer.close()


@pytest.mark.parametrize("damage", ["truncated", "missing", "grown"])
def test_damaged_episode_is_shown_as_damage(dataset_copy: Path, dataset_files: DatasetFiles, damage: str) -> None:
    """A finished dataset with a damaged episode file: the Dataset page's episodes row says
    ``damaged`` (not ``ok``, not "still being written") and the episode is listed as a failure."""
    info = json.loads((dataset_copy / "info.json").read_text())
    entry = info["episodes"][-1]
    path, stem = dataset_copy / entry["file"], Path(entry["file"]).stem
    if damage == "truncated":
        path.write_bytes(path.read_bytes()[: entry["size"] // 2])
    elif damage == "missing":
        path.unlink()
    else:
        path.write_bytes(path.read_bytes() + b"\0" * 16)
    app = ViewerApp(open_dataset(dataset_copy, render=False))
    states = {f["name"]: f for f in _json(app, "/api/status")["files"]}
    assert states["episodes"]["state"] == "damaged", states["episodes"]
    assert entry["file"] in states["episodes"]["detail"] and "validate" in states["episodes"]["detail"]
    row = next(e for e in _json(app, "/api/episodes")["episodes"] if e["episode"] == stem)
    assert row["success"] is False and row["failure_reason"].startswith("damaged"), row

"""The viewer's server without a browser: routes, filters, images, containment, partial datasets."""

from __future__ import annotations

import http.client
import json
import os
import shutil
from pathlib import Path
from urllib.parse import urlsplit

import numpy as np
import pytest
from PIL import Image
from viewer_fakes import FakeEpisodeStore, make_fake_dataset

from samplehd.errors import DatasetError
from samplehd.viewer import DatasetIndex, ViewerApp, filter_scene_summaries, resolve_inside
from samplehd.viewer.imaging import colourise_depth, colourise_segmentation, raw_array_bytes


def _get(url: str, path: str, method: str = "GET") -> tuple[int, dict[str, str], bytes]:
    """Send ``path`` verbatim (no client-side normalisation of ``..``)."""
    parts = urlsplit(url)
    conn = http.client.HTTPConnection(parts.hostname, parts.port, timeout=10)
    conn.request(method, path)
    response = conn.getresponse()
    body = response.read()
    conn.close()
    return response.status, dict(response.getheaders()), body


@pytest.fixture()
def app(fake_dataset: Path) -> ViewerApp:
    index = DatasetIndex(fake_dataset)
    index.episodes = FakeEpisodeStore(index)
    return ViewerApp(index)


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


def test_status_and_scene_filters(app: ViewerApp) -> None:
    status = json.loads(app.handle("/api/status", {}).body)
    assert status["counts"] == {"scenes": 4, "instructions": 10, "episodes": 5}
    everything = json.loads(app.handle("/api/scenes", {}).body)
    assert everything["matched"] == 4 and everything["options"]["split"] == ["test", "train"]
    assert set(everything["options"]["family"]) == {"place", "stack", "pick_up"}
    stacked = json.loads(app.handle("/api/scenes", {"family": "pick_up"}).body)
    assert [s["index"] for s in stacked["scenes"]] == [1, 3]
    both = json.loads(app.handle("/api/scenes", {"family": "pick_up", "split": "test"}).body)
    assert [s["index"] for s in both["scenes"]] == [3]
    failed = json.loads(app.handle("/api/scenes", {"success": "failure"}).body)
    assert [s["index"] for s in failed["scenes"]] == [0, 2]  # a failed episode; a rejected path
    none = json.loads(app.handle("/api/scenes", {"success": "none"}).body)
    assert [s["index"] for s in none["scenes"]] == [3]
    red = json.loads(app.handle("/api/scenes", {"colour": "red"}).body)
    assert all("red" in s["colour"] for s in red["scenes"]) and red["matched"] >= 1
    page = json.loads(app.handle("/api/scenes", {"offset": "1", "limit": "2"}).body)
    assert [s["index"] for s in page["scenes"]] == [1, 2]
    assert app.handle("/api/scenes", {"bogus": "1"}).status == 400
    with pytest.raises(DatasetError, match="valid"):
        filter_scene_summaries([], {"shape": "cube"})


def test_scene_detail_images_and_raw_pixels(app: ViewerApp, fake_dataset: Path) -> None:
    detail = json.loads(app.handle("/api/scenes/0", {}).body)
    assert len(detail["scene"]["objects"]) == 3 and detail["images"] == {"rgb": True, "depth": True,
                                                                         "segmentation": True}
    assert [q["family"] for q in detail["instructions"]] == ["place", "stack"]
    for modality in ("rgb", "depth", "segmentation"):
        response = app.handle(f"/api/scenes/0/image/{modality}", {})
        assert response.status == 200 and response.content_type == "image/png"
        assert response.body[:8] == b"\x89PNG\r\n\x1a\n"
    thumb = app.handle("/api/scenes/0/thumb", {})
    assert thumb.status == 200 and thumb.body[:2] == b"\xff\xd8"
    ids = app.handle("/api/scenes/0/ids", {})
    w, h = int(ids.headers["X-Width"]), int(ids.headers["X-Height"])
    pixels = np.frombuffer(ids.body, np.uint8).reshape(h, w)
    truth = np.asarray(Image.open(fake_dataset / "segmentation" / "SHD_train_000000.png"))
    np.testing.assert_array_equal(pixels, truth)
    depth = app.handle("/api/scenes/0/depth_mm", {})
    assert depth.headers["X-Dtype"] == "uint16"
    assert app.handle("/api/scenes/9", {}).status == 404
    assert app.handle("/api/scenes/x", {}).status == 400
    assert app.handle("/api/scenes/0/image/normals", {}).status == 404


def test_instruction_and_episode_routes(app: ViewerApp) -> None:
    q = json.loads(app.handle("/api/instructions/1", {}).body)
    assert q["instruction"]["family"] == "stack" and q["scene"]["image_index"] == 0
    assert q["episodes"][0]["episode"] == "s000000_01" and q["episodes"][0]["success"] is False
    listing = json.loads(app.handle("/api/episodes", {"success": "failure"}).body)
    assert [e["episode"] for e in listing["episodes"]] == ["s000000_01"]
    assert listing["rejections"][0]["instruction"].startswith("Stack") and listing["rejections"][0]["slot"] == 1
    rejected = json.loads(app.handle("/api/instructions/6", {}).body)
    assert rejected["episodes"] == [] and rejected["rejections"][0]["reason"] == "no_feasible_grasp"
    assert json.loads(app.handle("/api/episodes", {"success": "success"}).body)["rejections"] == []
    detail = json.loads(app.handle("/api/episodes/s000000_00", {}).body)
    assert len(detail["series"]["steering"][0]) == 7
    frame = app.handle("/api/episodes/s000000_00/frame/3", {"camera": "operator", "modality": "depth"})
    assert frame.status == 200 and frame.body[:4] == b"\x89PNG"
    jpeg = app.handle("/api/episodes/s000000_00/frame/3", {"format": "jpeg"})
    assert jpeg.content_type == "image/jpeg"
    assert app.handle("/api/episodes/s000000_00/frame/999", {}).status == 404
    assert app.handle("/api/episodes/s000077_00", {}).status == 404
    assert app.handle("/api/episodes/..%2f..", {}).status == 400


def test_partial_dataset_gives_states_not_errors(tmp_path: Path) -> None:
    root = make_fake_dataset(tmp_path / "growing", num_scenes=3)
    (root / "scenes.json").write_text('{"info": {}, "scenes": [{"split": "tr')  # half written
    (root / "instructions.json").unlink()
    os.remove(root / "images" / "SHD_train_000002.png")
    app = ViewerApp(DatasetIndex(root))
    status = json.loads(app.handle("/api/status", {}).body)
    states = {f["name"]: f["state"] for f in status["files"]}
    assert states == {"info.json": "missing", "scenes.json": "partial", "instructions.json": "missing",
                      "episodes": "missing"}
    assert status["counts"]["scenes"] == 3  # from the complete per-scene files
    assert json.loads(app.handle("/api/scenes", {}).body)["matched"] == 3
    missing = app.handle("/api/scenes/2/image/rgb", {})
    assert missing.status == 404 and b"not written yet" in missing.body
    assert app.handle("/api/scenes/2/thumb", {}).status == 404
    assert json.loads(app.handle("/api/scenes/2", {}).body)["images"]["rgb"] is False
    assert app.handle("/api/instructions/0", {}).status == 404
    (root / "segmentation" / "SHD_train_000001.png").write_bytes(b"\x89PNG\r\n\x1a\n truncated")
    assert app.handle("/api/scenes/1/ids", {}).status == 404
    # the file completes: the next request sees it
    shutil.rmtree(root / "scenes")
    make_fake_dataset(tmp_path / "complete", num_scenes=3)
    shutil.copy(tmp_path / "complete" / "scenes.json", root / "scenes.json")
    assert json.loads(app.handle("/api/status", {}).body)["files"][1]["state"] == "ok"


def test_not_a_dataset(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="no such dataset folder"):
        DatasetIndex(tmp_path / "nope")
    with pytest.raises(DatasetError, match="not a samplehd dataset"):
        DatasetIndex(tmp_path)


def test_http_server_refuses_paths_outside_the_dataset(viewer_url: str, fake_dataset: Path) -> None:
    (fake_dataset.parent / "outside.txt").write_text("secret")
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
    (fake_dataset / "evil.html").write_text("<script>alert(1)</script>")
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


def test_cli_view_serves_until_interrupted(fake_dataset: Path) -> None:
    import signal
    import subprocess
    import sys
    import time

    proc = subprocess.Popen([sys.executable, "-m", "samplehd", "view", str(fake_dataset), "--port", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        lines = [proc.stdout.readline(), proc.stdout.readline()]
        assert "4 scenes, 10 instructions" in lines[0], lines
        url = lines[1].split("serving on ", 1)[1].split()[0]
        assert url.startswith("http://127.0.0.1:")
        status, _, body = _get(url, "/api/status")
        assert status == 200 and json.loads(body)["counts"]["scenes"] == 4
    finally:
        proc.send_signal(signal.SIGINT)
        deadline = time.monotonic() + 10
        while proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0


def test_state_renderer_refuses_bad_requests_before_rendering() -> None:
    from samplehd.viewer.state_render import StateRenderer

    renderer = StateRenderer()
    with pytest.raises(DatasetError, match="has no 'spec'"):
        renderer.render({"image_index": 3}, {}, "scene", "rgb")
    with pytest.raises(DatasetError, match="valid cameras"):
        renderer.render({"spec": {}}, {}, "ceiling", "rgb")
    renderer.close()

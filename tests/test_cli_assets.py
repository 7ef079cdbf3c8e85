"""``samplehd assets import|list|preview|remove`` through the CLI entry point."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

from samplehd.cli import main


@pytest.fixture(autouse=True)
def private_registry(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    from samplehd.catalogue.registry import refresh

    monkeypatch.setenv("SAMPLEHD_REGISTRY_DIR", str(tmp_path / "registry"))
    monkeypatch.setenv("SAMPLEHD_CACHE_DIR", str(tmp_path / "cache"))
    refresh()
    yield
    refresh()


def test_import_list_remove(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mesh = tmp_path / "brick.stl"
    trimesh.creation.box((50.0, 30.0, 100.0)).export(mesh)
    assert (
        main(["assets", "import", str(mesh), "--name", "brick", "--scale", "0.001", "--material", "plastic,rubber"])
        == 0
    )
    out = capsys.readouterr().out
    assert "imported brick: 5.0 x 3.0 x 10.0 cm, 1 convex pieces" in out
    assert main(["assets", "list"]) == 0
    out = capsys.readouterr().out
    assert "brick" in out and "plastic,rubber" in out and "wine_glass" in out
    assert main(["assets", "remove", "brick"]) == 0
    assert "removed brick" in capsys.readouterr().out
    assert main(["assets", "list", "--json"]) == 0
    assert "brick" not in capsys.readouterr().out


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["assets", "import", "missing.obj", "--name", "x"], "missing.obj: no such mesh file"),
        (["assets", "preview", "teapot", "--out", "x.png"], "unknown object class 'teapot'"),
        (["assets", "preview", "knife", "--out", "x.png", "--colour", "transparent"], "no menu entry"),
        (["assets", "preview", "mug", "--out", "x.png", "--size", "huge"], "unknown size 'huge'"),
        (["assets", "remove", "nothing"], "no imported class named 'nothing'"),
    ],
)
def test_bad_input_exits_2_with_one_line(argv: list[str], expected: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert expected in err and "\n" not in err and "Traceback" not in err


@pytest.mark.render
def test_preview_writes_a_png(tmp_path: Path) -> None:
    out = tmp_path / "mug.png"
    assert (
        main(["assets", "preview", "mug", "--out", str(out), "--colour", "red", "--width", "160", "--height", "120"])
        == 0
    )
    img = np.asarray(Image.open(out))
    assert img.shape == (120, 160, 3)
    red = (img[..., 0] > 120) & (img[..., 1] < 60) & (img[..., 2] < 60)
    assert red.sum() > 200  # the red mugs are in the picture

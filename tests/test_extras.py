"""Optional features sit behind extras; a missing one is one line naming the extra (exit 2)."""

from __future__ import annotations

import sys
from importlib.resources import files
from pathlib import Path

import pytest

from samplehd.cli import main
from samplehd.errors import MissingExtraError, require_extra
from samplehd.workers import Backend


def test_require_extra_names_the_extra() -> None:
    with pytest.raises(MissingExtraError) as exc:
        require_extra("samplehd_no_such_module.sub", "mesh", "samplehd assets import")
    assert str(exc.value) == ("samplehd assets import needs samplehd_no_such_module, which is not installed: "
                              "pip install 'samplehd[mesh]'")


def test_export_lerobot_without_pyarrow(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "pyarrow", None)  # what an install without the extra looks like
    assert main(["export", "lerobot", str(tmp_path), "--out", str(tmp_path / "lr")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("pip install 'samplehd[lerobot]'") and "\n" not in err
    assert not (tmp_path / "lr").exists()


def test_assets_import_without_trimesh(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "trimesh", None)
    monkeypatch.delitem(sys.modules, "samplehd.catalogue.importer", raising=False)
    assert main(["assets", "import", str(tmp_path / "x.obj"), "--name", "x"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("pip install 'samplehd[mesh]'") and "\n" not in err


def test_ray_backend_without_ray(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(MissingExtraError, match=r"pip install 'samplehd\[ray\]'"):
        list(Backend("ray").map(abs, [1]))


def test_the_package_is_typed() -> None:
    assert files("samplehd").joinpath("py.typed").is_file()

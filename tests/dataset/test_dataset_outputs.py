"""The one output-path rule (samplehd.dataset.outputs): which folders count as datasets, and what
an output may not be."""

from __future__ import annotations

from pathlib import Path

import pytest

from samplehd.dataset.outputs import check_outputs, dataset_root_of, inside_dataset
from samplehd.errors import ConfigError, DatasetError

LAYOUTS = {"samplehd": ("info.json", "episodes"), "sample-hd export": ("info.json", "sequences"),
           "lerobot export": ("meta/info.json", "data")}


@pytest.mark.parametrize("layout", list(LAYOUTS))
def test_each_dataset_layout_is_protected(tmp_path: Path, layout: str) -> None:
    file, folder = LAYOUTS[layout]
    root = tmp_path / "ds"
    (root / folder).mkdir(parents=True)
    (root / file).parent.mkdir(parents=True, exist_ok=True)
    (root / file).write_text("{}")
    assert dataset_root_of(root / folder / "x" / "y.json") == root.resolve()
    for out in (root, root / "new.json", root / folder / "deeper" / "out"):
        with pytest.raises(ConfigError, match="dataset"):
            check_outputs({"--out": out})
    check_outputs({"--out": root / "stats"}, in_place=root)  # the command that updates it may write there


def test_an_info_json_alone_is_no_dataset(tmp_path: Path) -> None:
    (tmp_path / "project").mkdir()
    (tmp_path / "project" / "info.json").write_text("{}")
    assert dataset_root_of(tmp_path / "project" / "out.json") is None
    check_outputs({"--out": tmp_path / "project" / "out.json"})


@pytest.mark.parametrize(("outputs", "inputs", "fragment"), [
    ({"--out": Path("a.json")}, {"--instructions": Path("a.json")}, "input"),
    ({"--out": Path("sub/../a.json")}, {"--instructions": Path("a.json")}, "input"),
    ({"--out": Path("x.png"), "--depth": Path("./x.png")}, {}, "same file"),
    ({"--out": Path("n" * 300 + ".json")}, {}, "bytes"),
    ({"--out": Path("sub") / ("n" * 300) / "x.json"}, {}, "bytes"),
    ({"--out": Path("/".join(["d" * 200] * 25))}, {}, "path is"),
])
def test_outputs_over_inputs_or_each_other_are_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                       outputs: dict[str, Path], inputs: dict[str, Path],
                                                       fragment: str) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    with pytest.raises(ConfigError, match=fragment) as info:
        check_outputs(outputs, inputs)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("relative", ["../outside.h5", "/etc/passwd", "episodes/../../x.h5", "", None, 3])
def test_paths_read_from_a_dataset_stay_inside_it(tmp_path: Path, relative: object) -> None:
    with pytest.raises(DatasetError, match="info.json episodes"):
        inside_dataset(tmp_path, relative, "info.json episodes[0].file")
    assert inside_dataset(tmp_path, "episodes/s000000_00.h5", "x") == tmp_path / "episodes" / "s000000_00.h5"

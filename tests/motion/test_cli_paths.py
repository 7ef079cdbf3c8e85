"""`samplehd paths` and `samplehd replay` end to end on a one-scene dataset."""

from __future__ import annotations

import json

import numpy as np
import pytest

from samplehd.cli import main
from samplehd.dataset.container import read_episode
from samplehd.dataset.layout import episode_name
from samplehd.dataset.render import RenderConfig
from samplehd.scene.spec import SceneSpec, compile_scene
from samplehd.world.seeding import episode_seed


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    from samplehd.bench.paths import _bench_scene
    from samplehd.world.layout import DIRECTIONS

    root = tmp_path_factory.mktemp("ds")
    scene = _bench_scene()
    (root / "scenes.json").write_text(json.dumps({"info": {}, "scenes": [
        {"image_index": 0, "directions": {k: list(v) for k, v in DIRECTIONS.items()}, "spec": scene.to_dict()}]}))
    entry = {"image_index": 0, "instruction_index": 0, "instruction": "Put the red can on the food box.",
             "family": "stack", "task": {"type": "stack", "objects": [1], "subject": 0, "relation": None},
             "program": [], "program_sequence": "stack scene filter_name[soda_can] scene filter_name[food_box]"}
    bad = dict(entry, instruction_index=1, task={"type": "stack", "objects": [1], "subject": 1, "relation": None})
    (root / "instructions.json").write_text(json.dumps({"info": {}, "instructions": [entry, bad]}))
    return root


def test_paths_then_replay(dataset, tmp_path, capsys):
    out = tmp_path / "paths"
    rc = main(["paths", "--scenes", str(dataset), "--instructions", str(dataset / "instructions.json"),
               "--out", str(out), "--cameras", "operator", "--modalities", "rgb,depth,segmentation",
               "--width", "64", "--height", "36"])
    assert rc == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["attempted"] == 2 and summary["succeeded"] == 1
    assert summary["by_family"]["stack"] == {"attempted": 2, "succeeded": 1, "first_try": 1}
    assert sum(summary["rejections"].values()) == 1
    assert "stack" in capsys.readouterr().out
    # the same HDF5 episode files as `samplehd generate`, named and seeded by the dataset's rule
    files = sorted(p.name for p in (out / "episodes").iterdir())
    assert files == [episode_name(0, 0)]
    ep = read_episode(out / "episodes" / files[0], images="load")
    assert ep.success and ep.family == "stack" and ep.seed == episode_seed(0, 0, 0)
    imgs = ep.images["operator"]
    assert imgs["rgb"].shape == (ep.num_frames, 36, 64, 3) and imgs["rgb"].dtype == np.uint8
    assert imgs["depth"].shape == (ep.num_frames, 36, 64) and imgs["segmentation"].shape == (ep.num_frames, 36, 64)
    # its images are the states rendered again
    again = RenderConfig("fast", 64, 36, ("operator",)).images(compile_scene(SceneSpec.from_dict(ep.info["scene"]))[0],
                                                            ep.frames)
    assert np.array_equal(again["operator"]["rgb"], imgs["rgb"])
    results = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    assert sorted(r["success"] for r in results) == [False, True]
    video = tmp_path / "e.mp4"
    assert main(["replay", str(out / "episodes" / files[0]), "--out", str(video),
                 "--width", "64", "--height", "36"]) == 0
    assert video.stat().st_size > 1000


def test_bad_input_is_exit_2(dataset, tmp_path, capsys):
    assert main(["paths", "--scenes", str(tmp_path), "--instructions", str(dataset / "instructions.json"),
                 "--out", str(tmp_path / "o")]) == 2
    assert main(["paths", "--scenes", str(dataset), "--instructions", str(dataset / "instructions.json"),
                 "--out", str(tmp_path / "o"), "--modalities", "rgb,normals"]) == 2
    assert main(["replay", str(tmp_path / "missing.h5"), "--out", str(tmp_path / "x.mp4")]) == 2
    err = capsys.readouterr().err
    assert "error:" in err and "normals" in err

"""Grounding a keypose policy with the parser and the perception model (``evaluate --grounding DIR``):
which object to move next, which cells of the policy's map its grasp is sought in, the decisions it
records, and the one-line refusals."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")

from samplehd.learn.keypose.grounding import (  # noqa: E402
    GROUND_RADIUS,
    RELEASED_RADIUS,
    grounded_cells,
    next_to_move,
    still_to_move,
    unsaid_value,
)
from samplehd.learn.topdown import GRID_CHANNELS, HEIGHT_SCALE, TopDownGrid  # noqa: E402

FACTOR = 2


def _grid_with(blocks: list[tuple[float, float, float, float, float]]) -> tuple[np.ndarray, TopDownGrid]:
    """A grid image with raised blocks (x0, x1, y0, y1 [m], height [m]), every cell seen."""
    grid = TopDownGrid()
    image = np.zeros((GRID_CHANNELS, grid.rows, grid.cols), np.float32)
    image[4] = 1.0
    centres = grid.world(*np.meshgrid(np.arange(grid.rows), np.arange(grid.cols), indexing="ij"))
    for x0, x1, y0, y1, h in blocks:
        inside = (centres[..., 0] >= x0) & (centres[..., 0] <= x1) & (centres[..., 1] >= y0) & (centres[..., 1] <= y1)
        image[3][inside] = h / HEIGHT_SCALE
    return image, grid.coarse(FACTOR)


def test_the_next_object_to_move_is_the_first_not_standing_where_one_was_let_go() -> None:
    moved = [(0.10, 0.00), (0.20, 0.10), (0.30, -0.10)]
    assert next_to_move(moved, []) == 0
    assert next_to_move(moved, [(0.10 + RELEASED_RADIUS / 2, 0.0)]) == 1  # a tower's middle object, set down
    assert next_to_move(moved, [(0.10 + RELEASED_RADIUS * 1.5, 0.0)]) == 0  # let go elsewhere
    assert next_to_move(moved, [(0.10, 0.0), (0.20, 0.10), (0.30, -0.10)]) is None
    assert next_to_move([], []) is None
    assert still_to_move(moved, [(0.20, 0.10)]) == [0, 2]  # what is left, in order


@pytest.mark.parametrize(("program", "instruction", "unsaid"), [
    ("pick_up scene filter_size[medium] filter_name[knife]", "Grab the medium-sized knife and hold it up.", None),
    ("pick_up scene filter_name[scissors]", "Pick up the scissors.", None),
    ("place[right] scene filter_name[plate] scene filter_name[fork]", "Move both the plate and the fork over to the "
     "right part.", None),
    # remove: the destination goes unsaid, the part cleared is said
    ("place[left] scene filter_table[right]", "Empty the right part of the table.", None),
    ("place[front] scene filter_table[back]", "Move everything on the back half to the front side.", None),
    # parses gone wrong on held-out phrasings: a part said once used twice, a part never said, a class
    ("place[back] scene filter_table[back] filter_size[medium]", "Take all medium-sized plastic objects to the back "
     "half of the table.", "back"),
    ("place[back] scene filter_table[front] filter_name[glass] scene filter_table[back] filter_name[spoon]",
     "Take the glass and the blue spoon to the back half of the table.", "front"),
    ("stack_three scene filter_name[soda_can] scene filter_name[plate] scene filter_name[chopping_board]",
     "Build a tower with the chopping board at the bottom, the plate in the middle and the mug on top.", "soda_can"),
])
def test_grounding_stands_aside_where_the_program_uses_a_value_the_instruction_does_not_say(
        program: str, instruction: str, unsaid: str | None) -> None:
    assert unsaid_value(program.split(), instruction) == unsaid


def test_the_grasp_is_sought_on_the_raised_cells_at_the_perceived_object() -> None:
    # two objects 20 cm apart, and a long one whose far end lies beyond the radius
    image, coarse = _grid_with([(0.00, 0.05, 0.00, 0.05, 0.08), (0.20, 0.25, 0.00, 0.05, 0.03),
                                (-0.30, -0.27, -0.40, -0.10, 0.02)])
    centres = coarse.world(*np.meshgrid(np.arange(coarse.rows), np.arange(coarse.cols), indexing="ij"))
    cells = grounded_cells(image, (0.025, 0.025), coarse, FACTOR)
    assert cells is not None and cells.sum() >= 4
    xy = centres[cells]
    assert (xy[:, 0] < 0.1).all()  # the first object's cells, none of the second's
    other = grounded_cells(image, (0.21, 0.03), coarse, FACTOR)
    assert other is not None and (centres[other][:, 0] > 0.15).all()
    long = grounded_cells(image, (-0.285, -0.25), coarse, FACTOR)
    assert long is not None
    assert (np.hypot(centres[long][:, 0] + 0.285, centres[long][:, 1] + 0.25) <= GROUND_RADIUS).all()
    assert np.ptp(centres[long][:, 1]) < 0.3 - 0.01  # cut to the radius, not the whole object
    # a position with no raised cell within the radius: no grounding (the network chooses alone)
    assert grounded_cells(image, (-0.2, 0.4), coarse, FACTOR) is None
    # the nearest of two objects both within the radius
    image, coarse = _grid_with([(0.00, 0.03, 0.00, 0.03, 0.05), (0.08, 0.11, 0.00, 0.03, 0.05)])
    near = grounded_cells(image, (0.065, 0.015), coarse, FACTOR)
    assert near is not None and (coarse.world(*np.nonzero(near))[:, 0] > 0.055).all()
    # a mug's inside, which the camera does not see into, is the mug's: an enclosed hole is filled
    image, coarse = _grid_with([(0.00, 0.08, 0.00, 0.08, 0.09)])
    centres = coarse.world(*np.meshgrid(np.arange(coarse.rows), np.arange(coarse.cols), indexing="ij"))
    inside = (np.abs(centres[..., 0] - 0.04) < 0.02) & (np.abs(centres[..., 1] - 0.04) < 0.02)
    fine = np.kron(inside, np.ones((FACTOR, FACTOR), bool))
    image[4][fine] = 0.0  # not seen
    mug = grounded_cells(image, (0.04, 0.04), coarse, FACTOR)
    assert mug is not None and mug[inside].all()


@pytest.fixture(scope="module")
def grounded_models(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A keypose policy and a parser and perception model, each trained a few steps on the same small
    SHOP-VRB dataset of pick_up episodes with scene images."""
    from samplehd.cli import main
    from samplehd.dataset.config import GenerateConfig, preset_config
    from samplehd.dataset.generate import generate_dataset

    root = tmp_path_factory.mktemp("grounding")
    data = root / "ds"
    generate_dataset(data, GenerateConfig.from_dict({
        "num_scenes": 2, "seed": 1, "test_every": 2, "scene": {"min_objects": 3, "max_objects": 3},
        "instructions": {"per_scene": 2, "families": ["pick_up"]},
        "render": {"mode": "none", "width": 160, "height": 90}}, base=preset_config("small")))
    policy, models = root / "keypose", root / "ns"
    for argv in (["train", "policy", "--action", "keypose", "--dataset", str(data), "--out", str(policy),
                  "--steps", "2", "--batch", "2"],
                 ["train", "parser", "--dataset", str(data), "--out", str(models / "parser"), "--steps", "2"],
                 ["train", "perception", "--dataset", str(data), "--out", str(models / "perception"), "--steps", "2"]):
        assert main([*argv, "--quiet"]) == 0
    return policy, models


def test_a_grounded_keypose_policy_records_what_grounding_found_per_decision(grounded_models: tuple[Path, Path],
                                                                           tmp_path: Path) -> None:
    from samplehd.cli import main

    policy, models = grounded_models
    report = tmp_path / "grounded.json"
    assert main(["evaluate", "--policy", "bc", "--models", str(policy), "--grounding", str(models), "--families",
                 "pick_up", "--episodes", "1", "--max-episode-steps", "80", "--out", str(report)]) == 0
    result = json.loads(report.read_text())
    assert result["grounding"] == str(models)
    diagnosis = result["records"][0]["diagnosis"]
    found = diagnosis["grounding"]
    assert len(found) == len(diagnosis["decisions"]) >= 1
    for g in found:  # the parser's program, the objects it moves as perceived, the one chosen or why not
        assert set(g) >= {"program", "objects", "targets"}
        assert bool(g["program"]) is not diagnosis["exclusion"]  # an unheard noun: exclusion's, unparsed
        assert len(g["targets"]) <= len(g["objects"]) and (g["targets"] or g["why"])
    # without --grounding the report and the records say nothing of it
    plain = tmp_path / "plain.json"
    assert main(["evaluate", "--policy", "bc", "--models", str(policy), "--families", "pick_up", "--episodes", "1",
                 "--max-episode-steps", "5", "--out", str(plain)]) == 0
    result = json.loads(plain.read_text())
    assert "grounding" not in result and "grounding" not in result["records"][0]["diagnosis"]


def test_grounding_refuses_what_it_cannot_ground_in_one_line(grounded_models: tuple[Path, Path], tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    from samplehd.cli import main

    policy, models = grounded_models
    out = tmp_path / "r.json"
    cases = [
        (["--policy", "oracle", "--grounding", str(models)], "--grounding"),
        (["--policy", "bc", "--models", str(policy), "--grounding", str(tmp_path / "none")], "parser"),
        (["--policy", "bc", "--models", str(policy), "--grounding", str(models / "parser")], "parser"),
    ]
    for argv, names in cases:
        assert main(["evaluate", *argv, "--episodes", "1", "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and names in err, err
    assert not out.exists()

"""The grasp on an object the instruction names: the phrase of what to move, the objects a named class
fits, and a grasp moved onto them only where the grasp map chose another object."""

from __future__ import annotations

import numpy as np
import pytest

from samplehd.learn.keypose.configuration import KeyposeVocabulary
from samplehd.learn.keypose.exclusion import SeenObject
from samplehd.learn.keypose.naming import NAMED_FIT, moved_phrase, named_cells, table_part
from samplehd.learn.topdown import TopDownGrid

VOCABULARY = KeyposeVocabulary(
    words=("pick", "up", "lift", "the", "red", "blue", "small", "large", "mug", "bowl", "put", "in", "on", "left",
           "side", "of", "table", ".", "off", "place", "metal", "wooden", "and", "plate", "stack", "a", "make",
           "from", "bottom", ",", "chopping", "board", "everything", "that", "is", "move", "part", "right", "at",
           "back", "front", "to"),
    name=("bowl", "mug", "plate", "chopping_board"), color=("blue", "red"), material=("metal", "wooden"),
    size=("large", "small"))
# a map of 8 x 10 cells of 12.8 cm over the grid's area: rows 0-3 lie at the back, 5-7 at the front,
# columns 0-3 on the left, 6-9 on the right (samplehd.world.layout.table_parts_of)
MAP = TopDownGrid(cell=0.128, rows=8, cols=10)


def _object(row: int, fit: dict[str, float], color: str = "red") -> SeenObject:
    cells = np.zeros((MAP.rows, MAP.cols), bool)
    cells[row, 1:3] = True
    return SeenObject(cells, fit, color, "wooden", "small")


def test_the_phrase_of_what_to_move_ends_before_where_it_goes() -> None:
    assert moved_phrase("Lift the bowl off the table.") == "lift the bowl"
    assert moved_phrase("Put the red mug in the bowl.") == "put the red mug"
    assert moved_phrase("Pick up the mug.") == "pick up the mug ."
    assert moved_phrase("Lift the chopping board at the back off the table.") == "lift the chopping board"
    assert moved_phrase("Move everything that is on the left part to the right side.") == "move everything that is"
    # a tower's first object moved: the one in the middle, the second of a list from the bottom up
    assert moved_phrase("Build a tower with the chopping board at the back at the bottom, the red plate in the "
                        "middle and the glass on top.") == "the red plate"
    bottom_up = "Make a stack of the chopping board, the plate and the bowl, from the bottom up."
    assert moved_phrase(bottom_up) == "the plate"
    tower = "Make a stack of the plate on the right, the plate on the left and the glass, from the bottom up."
    assert moved_phrase(tower) == "the plate" and table_part(tower) == "left"
    assert moved_phrase("Stack the plate on the chopping board and then the mug on the plate.") == "stack the plate"


def test_the_grasp_is_sought_on_the_objects_a_named_class_fits() -> None:
    mug = _object(0, {"bowl": 0.1, "mug": 0.8, "plate": 0.05, "chopping_board": 0.05})
    bowl = _object(3, {"bowl": 0.7, "mug": 0.2, "plate": 0.05, "chopping_board": 0.05})
    blue_mug = _object(6, {"bowl": 0.2, "mug": 0.6, "plate": 0.1, "chopping_board": 0.1}, color="blue")
    objects = [mug, bowl, blue_mug]
    cells = named_cells("Put the mug in the bowl.", VOCABULARY, objects, MAP)
    assert cells is not None
    assert cells[0, 1] and cells[6, 1] and not cells[3, 1]  # both mugs, not the container
    assert cells[1, 1] and not cells[2, 1]  # widened by one cell
    red = named_cells("Put the red mug in the bowl.", VOCABULARY, objects, MAP)
    assert red is not None and red[0, 1] and not red[6, 1]  # the named colour, where an object has it
    small = named_cells("Put the small mug in the bowl.", VOCABULARY, objects, MAP)
    assert small is not None and small[0, 1] and small[6, 1]  # both are small
    # where no object has a named class as its best, those it fits well enough
    plate = named_cells("Lift the plate off the table.", VOCABULARY, objects, MAP)
    assert plate is None  # no object gives "plate" NAMED_FIT
    objects[2] = _object(6, {"bowl": 0.3, "mug": 0.35, "plate": NAMED_FIT + 0.05, "chopping_board": 0.05})
    plate = named_cells("Lift the plate off the table.", VOCABULARY, objects, MAP)
    assert plate is not None and plate[6, 1] and not plate[0, 1] and not plate[3, 1]


def test_a_table_part_said_after_the_object_to_move_chooses_among_its_class() -> None:
    assert table_part("Lift the chopping board at the back off the table.") == "back"
    assert table_part("Pick up the mugs that are on the left.") == "left"
    assert table_part("Put the mug on the left in the bowl.") == "left"
    assert table_part("Put the mug on the left side of the table.") is None  # a destination
    assert table_part("Put the mug in the bowl at the back.") is None  # the container's part
    board = {"bowl": 0.05, "mug": 0.05, "plate": 0.1, "chopping_board": 0.8}
    objects = [_object(1, board), _object(6, board)]
    back = named_cells("Lift the chopping board at the back off the table.", VOCABULARY, objects, MAP)
    front = named_cells("Lift the chopping board at the front off the table.", VOCABULARY, objects, MAP)
    assert back is not None and back[1, 1] and not back[6, 1]
    assert front is not None and front[6, 1] and not front[1, 1]
    # a part no object of the class lies in leaves them all
    right = named_cells("Lift the chopping board on the right off the table.", VOCABULARY, objects, MAP)
    assert right is not None and right[1, 1] and right[6, 1]


def test_no_rule_where_the_instruction_names_no_known_class_to_move() -> None:
    objects = [_object(0, {"bowl": 0.1, "mug": 0.9, "plate": 0.0, "chopping_board": 0.0})]
    assert named_cells("Move everything that is on the left part to the right side.", VOCABULARY, objects, MAP) is None
    assert named_cells("Pick up the food box.", VOCABULARY, objects, MAP) is None  # an unheard noun: exclusion's case
    assert named_cells("Pick up the mug.", KeyposeVocabulary(), objects, MAP) is None  # a policy that knows no class
    assert named_cells("Pick up the mug.", VOCABULARY, [], MAP) is None


def test_a_grasp_on_another_object_is_sought_again_on_the_named_ones_and_only_then() -> None:
    torch = pytest.importorskip("torch")
    from samplehd.envs.tokens import encode_instruction, instruction_vocabulary
    from samplehd.learn.keypose.inference import decide_on, predict_decisions
    from samplehd.learn.keypose.modeling import KeyposeNet
    from samplehd.learn.keypose.processing import FACTOR
    from samplehd.learn.topdown import GRID_CHANNELS, TopDownGrid

    torch.manual_seed(0)
    net = KeyposeNet(len(instruction_vocabulary()), GRID_CHANNELS, 8).eval()
    grid = TopDownGrid()
    coarse = grid.coarse(FACTOR)
    view = torch.rand(1, GRID_CHANNELS, grid.rows, grid.cols)
    tokens = torch.as_tensor(encode_instruction("Pick up the red mug.", 32)[None])
    with torch.no_grad():
        free = predict_decisions(net, view, tokens, grid)[0]
        row, col = np.rint(coarse.cell_of(np.asarray(free.grasp[:2]))).astype(int)
        on = np.zeros((coarse.rows, coarse.cols), bool)
        on[max(row - 2, 0):row + 3, max(col - 2, 0):col + 3] = True
        kept, moved = decide_on(net, view, tokens, grid, [], on)
        assert not moved and kept == free  # the grasp map's choice lies on a named object: it stands
        assert decide_on(net, view, tokens, grid, [], None) == (free, False)
        elsewhere = np.zeros_like(on)
        far = (row + coarse.rows // 2) % coarse.rows
        elsewhere[far, 3:7] = True
        again, moved = decide_on(net, view, tokens, grid, [], elsewhere)
    assert moved and again.grasp != free.grasp
    r, c = np.rint(coarse.cell_of(np.asarray(again.grasp[:2]))).astype(int)
    assert elsewhere[r, c]

"""Task normalisation of the language executor's task dicts."""

from __future__ import annotations

import pytest

from samplehd.errors import PlanningError
from samplehd.tasks.task import Task, family_of_program, parse_task


def test_executor_forms():
    assert parse_task({"type": "place", "objects": [2], "subject": "left"}) == Task("place", (2,), part="left")
    remove = parse_task({"type": "place", "objects": [1, 3], "subject": "left"}, family="remove")
    assert remove == Task("remove", (1, 3), part="right") and remove.destination_part == "left"
    assert parse_task({"type": "stack", "objects": [1], "subject": 0}) == Task("stack", (1,), reference=0)
    assert parse_task({"type": "put", "objects": [4], "subject": 2}).support_of(4) == 2
    rel = parse_task({"type": "place_relative", "objects": [1], "subject": 3, "relation": "behind"})
    assert rel == Task("place_relative", (1,), reference=3, direction="behind")
    three = parse_task({"type": "stack_three", "objects": [5, 6], "subject": 7})
    assert three.objects == (5, 6) and three.support_of(5) == 7 and three.support_of(6) == 5
    assert parse_task({"type": "stack_three", "objects": [6, 5, 7]}) == three
    assert parse_task({"type": "pick_up", "objects": [0], "subject": None}).involved == (0,)


def test_sample_hd_bracket_types_and_round_trip():
    assert parse_task({"type": "place[front]", "objects": [1]}).part == "front"
    t = parse_task({"type": "place_relative[left]", "objects": [1], "subject": 0})
    assert t.direction == "left" and Task.from_dict(t.to_dict()) == t


@pytest.mark.parametrize("bad", [
    {"type": "juggle", "objects": [1]},
    {"type": "place", "objects": [], "subject": "left"},
    {"type": "place", "objects": [1], "subject": "middle"},
    {"type": "stack", "objects": [1], "subject": "left"},
    {"type": "place_relative", "objects": [1], "subject": 2, "relation": "above"},
])
def test_bad_tasks(bad):
    with pytest.raises(PlanningError):
        parse_task(bad)


def test_sample_hd_forms_come_from_the_family():
    remove = parse_task({"type": "place", "objects": [2], "subject": "left"}, family="remove")
    assert remove.to_sample_hd() == {"name": "place", "objectInt": [2], "subjectString": ["left"], "subjectInt": -1}
    assert remove.to_sample_hd_task() == {"type": "remove", "object": [2], "subject": "right"}  # the cleared part
    place = parse_task({"type": "place", "objects": [0, 1], "subject": "front"})
    assert place.to_sample_hd_task() == {"type": "place", "object": [0, 1], "subject": "front"}
    stack = parse_task({"type": "stack", "objects": [1], "subject": 0})
    assert stack.to_sample_hd() == {"name": "stack", "objectInt": [1], "subjectString": [], "subjectInt": 0}
    assert stack.to_sample_hd_task() == {"type": "stack", "object": [1], "subject": 0}


def test_a_flat_program_names_its_family_through_the_registry():
    """A place of everything on one table part is a remove (its family claims it); other places and other
    actions stay what their action says."""
    assert family_of_program("place", ["place[back]", "scene", "filter_table[front]"]) == "remove"
    assert family_of_program("place", ["place[back]", "scene", "filter_name[fork]"]) == "place"
    assert family_of_program("place", ["place[back]", "scene", "filter_table[front]", "filter_name[fork]"]) == "place"
    assert family_of_program("stack", ["stack", "scene", "filter_table[front]"]) == "stack"

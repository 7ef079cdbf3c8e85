"""Programs in both formats execute to the recorded task; SAMPLE-HD's examples; clear errors."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from samplehd.language.executor import ProgramError, execute, execute_nodes, execute_sequence, parse_token
from samplehd.language.generator import GenerationResult, generate_instructions
from samplehd.language.scene import Scene, parse_scene
from samplehd.language.synthetic import synthetic_scene
from samplehd.tasks.task import Task


def _obj(name: str, colour: str, xy: tuple[float, float], parts: list[str]) -> dict:
    return {
        "name": name,
        "colour": colour,
        "material": "ceramic",
        "size": "medium",
        "table_part": parts,
        "3d_coords": [xy[0], xy[1], 0.8],
        "bbox": {"extents": [0.1, 0.1, 0.1]},
    }


@pytest.fixture()
def kitchen() -> Scene:
    return parse_scene(
        {
            "objects": [
                _obj("mug", "red", (0.1, 0.2), ["right"]),  # 0
                _obj("plate", "white", (0.1, -0.2), ["left"]),  # 1
                _obj("baking_tray", "black", (0.25, 0.0), ["front"]),  # 2
                _obj("mug", "blue", (-0.1, 0.25), ["right", "back"]),  # 3
            ]
        }
    )


def test_sample_hd_examples(kitchen: Scene) -> None:
    assert execute("place[left] scene filter_colour[red] filter_name[mug]", kitchen) == Task("place", (0,), "left")
    assert execute(
        "stack scene filter_colour[white] filter_name[plate] scene filter_name[baking_tray]", kitchen
    ) == Task("stack", (1,), reference=2)
    # SAMPLE-HD's "remove right": everything on the right goes to the left
    assert execute("place[left] scene filter_table[right]", kitchen) == Task("place", (0, 3), "left")


def test_node_format_matches_flat_format(kitchen: Scene) -> None:
    nodes = [
        {"type": "scene", "inputs": [], "value_inputs": []},
        {"type": "filter_table_part", "inputs": [0], "value_inputs": ["right"]},
        {"type": "remove", "inputs": [1], "value_inputs": ["right"]},
    ]
    assert execute_nodes(nodes, kitchen) == execute_sequence("place[left] scene filter_table[right]", kitchen)
    relate = [
        {"type": "scene", "inputs": [], "value_inputs": []},
        {"type": "filter_name", "inputs": [0], "value_inputs": ["plate"]},
        {"type": "unique", "inputs": [1], "value_inputs": []},
        {"type": "relate", "inputs": [2], "value_inputs": ["right"]},
        {"type": "filter_color", "inputs": [3], "value_inputs": ["red"]},
        {"type": "unique", "inputs": [4], "value_inputs": []},
        {"type": "pick_up", "inputs": [5], "value_inputs": []},
    ]
    flat = "pick_up scene filter_name[plate] filter_relate[right] filter_colour[red]"
    assert execute(relate, kitchen) == execute(flat, kitchen) == Task("pick_up", (0,))


def test_new_families_in_flat_format(kitchen: Scene) -> None:
    task = execute("place_relative[behind] scene filter_colour[red] scene filter_name[plate]", kitchen)
    assert task == Task("place_relative", (0,), reference=1, direction="behind")
    tower = execute(
        "stack_three scene filter_colour[red] scene filter_name[plate] scene filter_name[baking_tray]", kitchen
    )
    assert tower == Task("stack_three", (1, 0), reference=2)  # plate first, then the mug on it
    assert tower.involved == (1, 0, 2)


@pytest.mark.parametrize(
    ("program", "message"),
    [
        ("", "empty program"),
        ("fly scene", "unknown task"),
        ("place scene", "needs [value]"),
        ("place[middle] scene", "unknown table part"),
        ("stack scene filter_name[mug] scene filter_name[plate]", "expected one object"),
        ("pick_up filter_name[mug]", "must start with 'scene'"),
        ("pick_up scene filter_shape[mug]", "unknown token"),
        ("pick_up scene filter_name[plate] filter_relate[up]", "unknown relation"),
        ("place[left] scene filter_name[spoon]", "empty set"),
        ("put scene filter_name[plate] scene filter_name[plate]", "distinct"),
    ],
)
def test_malformed_flat_programs(kitchen: Scene, program: str, message: str) -> None:
    with pytest.raises(ProgramError, match=message.replace("[", r"\[")):
        execute_sequence(program, kitchen)


def test_malformed_node_programs(kitchen: Scene) -> None:
    with pytest.raises(ProgramError, match="unknown function"):
        execute_nodes([{"type": "filter_shape", "inputs": [], "value_inputs": ["mug"]}], kitchen)
    with pytest.raises(ProgramError, match="earlier nodes"):
        execute_nodes([{"type": "unique", "inputs": [0], "value_inputs": []}], kitchen)
    with pytest.raises(ProgramError, match="no action"):
        execute_nodes([{"type": "scene", "inputs": [], "value_inputs": []}], kitchen)


def _check(scene: Scene, result: GenerationResult) -> None:
    for inst in result.instructions:
        nodes_task = execute(list(inst.program), scene)
        flat_task = execute(" ".join(inst.program_sequence), scene)
        assert nodes_task == flat_task == inst.task
        assert nodes_task.involved == inst.targets
        assert len(set(inst.targets)) == len(inst.targets)


def test_every_program_executes_to_its_targets(generated: list) -> None:
    assert sum(len(r.instructions) for _, r in generated) > 300
    for scene, result in generated:
        _check(scene, result)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 10))
def test_programs_execute_property(seed: int, n: int) -> None:
    rng = np.random.default_rng(seed)
    scene = parse_scene(synthetic_scene(rng, n))
    _check(scene, generate_instructions(scene, rng, per_scene=8))


def test_task_round_trip() -> None:
    t = Task("place_relative", (3,), reference=1, direction="left")
    assert Task.from_dict(t.to_dict()) == t
    assert Task("place", (0, 2), "left").to_sample_hd() == {
        "name": "place",
        "objectInt": [0, 2],
        "subjectString": ["left"],
        "subjectInt": -1,
    }
    assert Task("stack", (1,), reference=4).to_sample_hd()["subjectInt"] == 4


def test_error_messages_name_the_node_or_token(kitchen: Scene) -> None:
    # locations are formatted only when an error is raised: the message still names where it is
    with pytest.raises(ProgramError, match=r"^node 0 \(unique\): inputs must be indices of earlier nodes, got \[0\]$"):
        execute_nodes([{"type": "unique", "inputs": [0], "value_inputs": []}], kitchen)
    scene_node = {"type": "scene", "inputs": [], "value_inputs": []}
    with pytest.raises(ProgramError, match=r"^node 1 \(filter_table_part\): unknown table part 'middle'; valid: "):
        execute_nodes([scene_node, {"type": "filter_table_part", "inputs": [0], "value_inputs": ["middle"]}], kitchen)
    with pytest.raises(ProgramError, match=r"^token 3 \(filter_relate\[up\]\): unknown relation 'up'; valid: "):
        execute_sequence("pick_up scene filter_name[plate] filter_relate[up]", kitchen)
    with pytest.raises(ProgramError, match=r"^task place\[middle\]: unknown table part 'middle'"):
        execute_sequence("place[middle] scene", kitchen)


def test_parsed_tokens_are_reused_and_malformed_ones_still_fail() -> None:
    assert parse_token("filter_colour[red]") == ("filter_colour", "red")
    assert parse_token("filter_colour[red]") == ("filter_colour", "red")
    assert parse_token("scene") == ("scene", None)
    for bad in ("filter_colour[red", "Scene", "filter[a][b]"):
        with pytest.raises(ProgramError, match="malformed token"):
            parse_token(bad)

"""Templates as data: shipped ones load; user templates add; malformed ones fail on one clear line."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from samplehd.cli import main
from samplehd.errors import TemplateError
from samplehd.language.generator import generate_instructions
from samplehd.language.synthetic import synthetic_scene
from samplehd.language.templates import DEFAULT_TEMPLATE_DIR, Template, load_templates

GOOD: dict[str, Any] = {
    "family": "pick_up",
    "templates": [
        {
            "name": "raise_up",
            "text": ["Raise <R1> [up] [high].", "Hoist <R1>.", "{pick_up} <R1>."],
            "params": [{"name": "R1", "type": "object"}],
            "constraints": [{"type": "graspable", "params": ["R1"]}, {"type": "reachable", "params": ["R1"]}],
            "nodes": [{"type": "object", "side_inputs": ["R1"]}, {"type": "pick_up", "inputs": [0]}],
            "sequence": ["pick_up", "<R1>"],
        }
    ],
}


def _write(tmp_path: Path, data: Any, name: str = "mine.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(data) if not isinstance(data, str) else data)
    return path


def test_shipped_templates_round_trip() -> None:
    for t in load_templates():
        assert Template.from_dict(t.to_dict()) == t


def test_user_templates_are_added_and_used(tmp_path: Path) -> None:
    path = _write(tmp_path, GOOD)
    templates = load_templates(tmp_path)
    assert templates[-1].name == "raise_up" and templates[-1].filename == "mine.json"
    only = load_templates(path, include_default=False)
    rng = np.random.default_rng(0)
    texts = [
        i.text
        for _ in range(10)
        for i in generate_instructions(synthetic_scene(rng, 4), rng, only, per_scene=3).instructions
    ]
    assert texts and all(t.split()[0] in {"Raise", "Hoist", "Pick", "Lift", "Grab"} for t in texts)


def _broken(path: list[Any], value: Any) -> dict[str, Any]:
    data = copy.deepcopy(GOOD)
    target = data
    for key in path[:-1]:
        target = target[key]
    if value is _DELETE:
        del target[path[-1]]
    else:
        target[path[-1]] = value
    return data


_DELETE = object()
T = ["templates", 0]


@pytest.mark.parametrize(
    ("data", "field", "hint"),
    [
        (_broken(["family"], ""), "family", "non-empty"),
        (_broken(["templates"], []), "templates", "non-empty"),
        (_broken([*T, "text"], []), "text", "non-empty list"),
        (_broken([*T, "text", 0], "Raise <R2>."), "text[0]", "<R2> is not a parameter"),
        (_broken([*T, "text", 0], "Raise [up <R1>."), "text[0]", "'[' without ']'"),
        (_broken([*T, "text", 0], "{hoist} <R1>."), "text[0]", "unknown synonym group"),
        (_broken([*T, "text", 0], "Raise <R1:opposite>."), "text[0]", "not valid"),
        (_broken([*T, "params", 0, "type"], "thing"), "params[0].type", "valid: object"),
        (_broken([*T, "constraints", 0, "type"], "heavy"), "constraints[0].type", "valid: "),
        (_broken([*T, "constraints", 0, "params"], ["R9"]), "constraints[0].params", "not a parameter"),
        (_broken([*T, "constraints", 1], {"type": "stackable_on", "params": ["R1"]}), "constraints[1].params", "takes"),
        (_broken([*T, "nodes", 1, "type"], "lift"), "nodes[1].type", "unknown function"),
        (_broken([*T, "nodes", 1, "inputs"], [3]), "nodes[1].inputs", "earlier nodes"),
        (_broken([*T, "nodes"], [{"type": "object", "side_inputs": ["R1"]}]), "nodes[0]", "must be an action"),
        (_broken([*T, "sequence", 0], "hoist"), "sequence[0]", "not a task token"),
        (_broken([*T, "sequence"], ["pick_up"]), "sequence", "missing from the sequence"),
        (_broken([*T, "colour"], "red"), "colour", "unknown field"),
        (_broken([*T, "params"], _DELETE), "params", "expected a list"),
    ],
)
def test_malformed_template_fails_on_one_line(tmp_path: Path, data: dict, field: str, hint: str) -> None:
    path = _write(tmp_path, data)
    with pytest.raises(TemplateError) as info:
        load_templates(path, include_default=False)
    message = str(info.value)
    assert "\n" not in message
    assert str(path) in message
    assert f"{field}:" in message
    assert hint in message
    if field not in ("family", "templates"):
        assert "template 'raise_up'" in message


def test_bad_json_and_duplicate_names(tmp_path: Path) -> None:
    with pytest.raises(TemplateError, match="invalid JSON at line"):
        load_templates(_write(tmp_path, "{oops"), include_default=False)
    dup = copy.deepcopy(GOOD)
    dup["templates"][0]["name"] = "place_one"
    with pytest.raises(TemplateError, match="already defined in place.json"):
        load_templates(_write(tmp_path, dup, "dup.json"))
    with pytest.raises(TemplateError, match="no such"):
        load_templates(tmp_path / "missing.json")


def test_cli_reports_bad_template_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scenes = tmp_path / "scenes.json"
    scenes.write_text(json.dumps({"info": {}, "scenes": [synthetic_scene(np.random.default_rng(0), 3)]}))
    bad = _write(tmp_path, _broken([*T, "nodes", 1, "type"], "lift"), "bad.json")
    code = main(["instructions", "--scenes", str(scenes), "--out", str(tmp_path / "i.json"), "--templates", str(bad)])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert err.count("\n") == 0 and "bad.json" in err and "nodes[1].type" in err


def test_shipped_template_files_are_the_families() -> None:
    names = sorted(p.stem for p in DEFAULT_TEMPLATE_DIR.glob("*.json"))
    assert names == sorted(["place", "stack", "put", "remove", "pick_up", "place_relative", "stack_three"])

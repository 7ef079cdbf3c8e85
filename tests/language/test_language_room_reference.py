"""Speed-ups of instruction generation keep its outputs: room decisions and instructions are compared
with a reference recorded before them (``data/room_reference.json``).

The reference holds, for seeded synthetic scenes of 3 to 20 objects, every room decision of a fixed
list of questions (``room_in_part`` for single objects, pairs and triples, ``room_opposite``,
``free_beside``) as a bit string, and the SHA-256 of the instructions generated per scene and of an
instruction file. Regenerate it only for a change meant to alter outputs:
``python tests/language/test_language_room_reference.py --write``.
"""

from __future__ import annotations

import hashlib
import json
import sys
from itertools import combinations
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from samplehd.language.constraints import CONSTRAINTS, ConstraintContext
from samplehd.language.generator import TemplateBalancer, generate_instructions
from samplehd.language.scene import Scene, parse_scene
from samplehd.language.synthetic import synthetic_scene, synthetic_scenes_file
from samplehd.world.layout import TABLE_PARTS

REFERENCE = Path(__file__).parent / "data" / "room_reference.json"
RELATIONS = ("left", "right", "front", "behind")
# (objects per scene, scenes): the default run checks the first few of each; the slow one all
SETS = ((3, 40), (5, 40), (10, 20), (20, 8))
QUICK = 6


def _scenes(n_objects: int, count: int) -> list[Scene]:
    rng = np.random.default_rng([7, n_objects])
    return [parse_scene(synthetic_scene(rng, n_objects, image_index=i)) for i in range(count)]


def room_decisions(scene: Scene) -> str:
    """Every answer to a fixed list of room questions on one scene, as a string of 0 and 1."""
    ctx = ConstraintContext(scene)
    n = len(scene.objects)
    bits = []
    for part in TABLE_PARTS:
        outside = [i for i in range(n) if part not in scene.objects[i].table_part]
        groups = [[i] for i in outside] + [list(p) for p in combinations(outside, 2)][:8]
        groups += [list(t) for t in combinations(outside, 3)][:3]
        for group in groups:
            bits.append(CONSTRAINTS["room_in_part"].check(ctx, [*group, part]))
        bits.append(CONSTRAINTS["room_opposite"].check(ctx, [part]))
    for x in range(min(n, 5)):
        for y in range(min(n, 6)):
            if x != y:
                for rel in RELATIONS:
                    bits.append(CONSTRAINTS["free_beside"].check(ctx, [x, y, rel]))
    return "".join("1" if b else "0" for b in bits)


def _digest(data: Any) -> str:
    return hashlib.sha256(json.dumps(data, sort_keys=True, ensure_ascii=False).encode()).hexdigest()[:16]


def instruction_digests(scenes: list[Scene], seed: int) -> list[str]:
    """SHA-256 (16 hex digits) of each scene's generated instructions, one balancer shared."""
    balancer = TemplateBalancer("templates")
    return [
        _digest(generate_instructions(s, np.random.default_rng([seed, k]), per_scene=5, balancer=balancer).to_dict())
        for k, s in enumerate(scenes)
    ]


def instruction_file_digest(n_scenes: int) -> str:
    from samplehd.language.instruction_file import generate_instruction_file

    scenes = synthetic_scenes_file(np.random.default_rng(11), n_scenes, 3, 5)["scenes"]
    doc = generate_instruction_file(scenes, seed=2, per_scene=5)
    doc["info"].pop("samplehd_version", None)
    return _digest(doc)


def record() -> dict[str, Any]:
    out: dict[str, Any] = {"sets": {}}
    for n_objects, count in SETS:
        scenes = _scenes(n_objects, count)
        out["sets"][str(n_objects)] = {
            "rooms": [room_decisions(s) for s in scenes],
            "instructions": instruction_digests(scenes, seed=n_objects),
        }
    out["file_300"] = instruction_file_digest(300)
    return out


@pytest.fixture(scope="module")
def reference() -> dict[str, Any]:
    return json.loads(REFERENCE.read_text())


def _check(reference: dict[str, Any], limit: int | None) -> None:
    for n_objects, count in SETS:
        want = reference["sets"][str(n_objects)]
        scenes = _scenes(n_objects, count)[:limit]
        got_rooms = [room_decisions(s) for s in scenes]
        for k, (got, exp) in enumerate(zip(got_rooms, want["rooms"], strict=False)):
            assert got == exp, f"{n_objects} objects, scene {k}: room decisions differ"
        got_inst = instruction_digests(scenes, seed=n_objects)
        assert got_inst == want["instructions"][: len(got_inst)], f"{n_objects} objects: instructions differ"


def test_room_decisions_and_instructions_match_the_reference(reference: dict[str, Any]) -> None:
    _check(reference, QUICK)
    # some questions must have each answer, or the comparison could not catch much
    bits = "".join(reference["sets"]["5"]["rooms"])
    assert 0.05 < bits.count("0") / len(bits) < 0.95


@pytest.mark.slow
def test_every_reference_scene_and_an_instruction_file_match(reference: dict[str, Any]) -> None:
    _check(reference, None)
    assert instruction_file_digest(300) == reference["file_300"]


if __name__ == "__main__" and "--write" in sys.argv:
    REFERENCE.write_text(json.dumps(record(), indent=1) + "\n")
    print(f"wrote {REFERENCE}")

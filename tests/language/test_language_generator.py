"""Rejection-based generation: constraints hold, determinism, no duplicates, balance."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from samplehd.errors import ConfigError
from samplehd.language.constraints import CONSTRAINTS, ConstraintContext, default_reachable
from samplehd.language.generator import Instruction, TemplateBalancer, generate_instructions
from samplehd.language.instruction_file import assign_splits, generate_instruction_file, parse_split_ratio
from samplehd.language.scene import Scene
from samplehd.language.templates import default_templates
from samplehd.world.layout import OPPOSITE_PART

FAMILIES = {"place", "stack", "put", "remove", "pick_up", "place_relative", "stack_three"}


def _holds(name: str, ctx: ConstraintContext, *args: object) -> bool:
    return CONSTRAINTS[name].check(ctx, list(args))


def _check_constraints(scene: Scene, inst: Instruction) -> None:
    ctx = ConstraintContext(scene)
    task = inst.task
    objs = [scene.objects[i] for i in task.objects]
    assert all(o.graspable for o in objs)
    assert all(default_reachable(o.coords) for o in objs)
    if task.type == "place":
        assert all(task.subject not in o.table_part for o in objs)
        assert _holds("room_in_part", ctx, task.objects, task.subject)
        if inst.family == "remove":
            cleared = OPPOSITE_PART[task.subject]
            assert set(task.objects) == {o.index for o in scene.objects if cleared in o.table_part}
    elif task.type == "stack":
        assert _holds("stackable_on", ctx, task.objects[0], task.subject)
    elif task.type == "put":
        base = scene.objects[task.subject]
        assert base.container and 0.5 * float(np.hypot(*objs[0].footprint)) < base.opening_radius
    elif task.type == "place_relative":
        assert task.objects[0] not in scene.relationships[task.relation][task.subject]
        assert _holds("free_beside", ctx, task.objects[0], task.subject, task.relation)
    elif task.type == "stack_three":
        middle, top = task.objects
        assert _holds("stackable_on", ctx, middle, task.subject)
        assert _holds("stackable_on", ctx, top, middle)
    else:
        assert task.type == "pick_up" and task.subject is None


def test_constraints_hold(generated: list) -> None:
    for scene, result in generated:
        for inst in result.instructions:
            _check_constraints(scene, inst)


def test_every_family_is_generated(generated: list) -> None:
    families = Counter(i.family for _, r in generated for i in r.instructions)
    assert set(families) == FAMILIES


def test_no_duplicate_tasks_per_scene(generated: list) -> None:
    for _, result in generated:
        keys = [(i.task.type, i.task.objects, i.task.subject, i.task.relation) for i in result.instructions]
        assert len(keys) == len(set(keys))
        texts = [i.text for i in result.instructions]
        assert len(texts) == len(set(texts))


def test_rejections_are_counted_by_reason(generated: list) -> None:
    total: Counter[str] = Counter()
    for _, result in generated:
        total.update(result.rejections)
    for reason in ("stackable_on", "fits_in", "not_in_part", "graspable" if total["graspable"] else "reachable"):
        assert total[reason] > 0, reason


def test_same_seed_same_instructions(scenes: list[Scene]) -> None:
    def run(seed: int) -> list[dict]:
        return [
            i.to_dict()
            for s in scenes[:20]
            for i in generate_instructions(s, np.random.default_rng(seed), per_scene=4).instructions
        ]

    assert run(5) == run(5)
    assert run(5) != run(6)


def test_reachable_callable_is_respected(scenes: list[Scene]) -> None:
    def nothing(_xyz: object) -> bool:
        return False

    for scene in scenes[:10]:
        result = generate_instructions(scene, np.random.default_rng(0), reachable=nothing)
        assert result.instructions == ()


def test_family_filter(scenes: list[Scene]) -> None:
    for scene in scenes[:20]:
        for inst in generate_instructions(scene, np.random.default_rng(1), families=["put", "stack"]).instructions:
            assert inst.family in {"put", "stack"}
    with pytest.raises(ConfigError, match="valid: "):
        generate_instructions(scenes[0], np.random.default_rng(1), families=["juggle"])
    with pytest.raises(ConfigError, match="balance"):
        TemplateBalancer("objects")


def test_instruction_round_trip(generated: list) -> None:
    from samplehd.language.generator import GenerationResult

    inst = generated[0][1].instructions[0]
    assert Instruction.from_dict(inst.to_dict()) == inst
    result = generated[1][1]
    assert GenerationResult.from_dict(result.to_dict()) == result


@pytest.mark.parametrize("balance", ["templates", "families"])
def test_balance_is_near_uniform(scene_dicts: list[dict], balance: str) -> None:
    doc = generate_instruction_file(scene_dicts, seed=3, per_scene=4, balance=balance)
    counts = doc["info"]["counts"][balance]
    # stack_three needs a rare combination of objects; the others must come out within a few of each other
    rest = [v for k, v in counts.items() if "stack_three" not in k]
    assert max(rest) - min(rest) <= max(3, 0.1 * max(rest)), counts
    assert len(doc["instructions"]) == sum(counts.values())
    assert [e["instruction_index"] for e in doc["instructions"]] == list(range(len(doc["instructions"])))


def test_scenes_may_arrive_one_by_one(scene_dicts: list[dict]) -> None:
    # dataset generation feeds scenes as the workers finish them: same file as from the list
    subset = scene_dicts[:12]
    ratio = {"train": 0.75, "test": 0.25}
    whole = generate_instruction_file(subset, seed=5, per_scene=3, split_ratio=ratio)
    arriving = generate_instruction_file(iter(subset), seed=5, per_scene=3, split_ratio=ratio, total=len(subset))
    assert arriving == whole


def test_split_ratio() -> None:
    assert parse_split_ratio("train=3,test=1") == {"train": 0.75, "test": 0.25}
    with pytest.raises(ConfigError, match="NAME=FRACTION"):
        parse_split_ratio("train:0.9")
    labels = assign_splits(101, {"train": 0.9, "test": 0.1}, np.random.default_rng(0))
    assert Counter(labels) == {"train": 91, "test": 10}


def test_shipped_templates_cover_families_with_paraphrases() -> None:
    templates = default_templates()
    assert {t.family for t in templates} == FAMILIES
    for t in templates:
        assert len(t.text) >= 3, t.name


def test_ik_reachability_is_no_looser_than_the_annulus(scenes: list[Scene]) -> None:
    from samplehd.world.layout import LAYOUT
    from samplehd.world.reach import IKReachable, make_reachable

    ik = IKReachable()
    for x, y in [(0.0, 0.0), (0.2, 0.3), (-0.15, 0.0), (0.3, 0.4), (0.1, -0.35)]:
        xyz = (x, y, LAYOUT.table_height + 0.05)
        assert not ik(xyz) or LAYOUT.in_reach((x, y))
    assert ik((0.1, 0.0, LAYOUT.table_height + 0.05))
    result = generate_instructions(scenes[3], np.random.default_rng(0), reachable=make_reachable("ik"))
    for inst in result.instructions:
        assert all(ik(scenes[3].objects[i].coords) for i in inst.task.objects)
    with pytest.raises(ConfigError, match="valid: annulus, ik"):
        make_reachable("arm")


def test_shuffling_a_list_draws_the_order_permutation_draws() -> None:
    """The search orders a parameter's candidates with ``shuffle`` on a list, which must give the order
    ``permutation`` gives from the same state (and leave the same state), or seeded instructions change."""
    a, b = np.random.default_rng(11), np.random.default_rng(11)
    for n in [*range(0, 40), 97, 250]:
        order = list(range(n))
        b.shuffle(order)
        assert order == a.permutation(n).tolist()
        assert a.bit_generator.state == b.bit_generator.state


def test_a_scene_leaves_no_memo_for_the_collector(scenes: list[Scene]) -> None:
    """What a scene's search memoised is freed by reference counting when its instructions are made: nothing
    is left for the cyclic collector to find (the memo's spots refer back to it)."""
    import gc

    from samplehd.world.free_spot import FreeSpots

    def live_spot_tests() -> int:
        return sum(isinstance(o, FreeSpots) for o in gc.get_objects())

    busy = max(scenes, key=lambda s: len(s.objects))
    # once first: compiling the free-spot loops in this process may keep the stack of that first call
    generate_instructions(busy, np.random.default_rng(3), per_scene=5)
    gc.collect()
    before = live_spot_tests()
    gc.disable()
    try:
        made = generate_instructions(busy, np.random.default_rng(3), per_scene=5)
        assert made.instructions
        assert live_spot_tests() == before
    finally:
        gc.enable()

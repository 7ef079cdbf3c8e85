"""The order in which the planner picks several moved objects (``paths.planner.order``): the rule, its
validation, the presets, and real paths that follow it (same seed, same frames)."""

from __future__ import annotations

import numpy as np
import pytest

from samplehd.errors import ConfigError
from samplehd.motion.order import EFFECTOR_POINT_OFFSET, effector_point, next_object, pick_order
from samplehd.robot.constants import HOME_QPOS
from samplehd.robot.kinematics import fk_flange, fk_tcp
from samplehd.world.planner_config import PICK_ORDERS, PlannerConfig


def test_next_object_and_whole_order() -> None:
    pos = np.array([[0.3, 0.0, 0.0], [0.1, 0.0, 0.0], [0.2, 0.0, 0.0], [0.1, 0.0, 0.0]])
    here = np.zeros(3)
    assert next_object("instruction", [2, 0, 1]) == 2
    assert next_object("nearest", [2, 0, 1], here, pos) == 1
    assert next_object("nearest", [3, 1], here, pos) == 3  # a tie goes to the one listed first (np.argmin)
    # Greedy per approach: the effector is elsewhere at the second approach's start.
    assert pick_order("nearest", [0, 1, 2], [here, np.array([0.35, 0.0, 0.0]), here], pos) == [1, 0, 2]
    assert pick_order("instruction", [2, 0, 1]) == [2, 0, 1]
    with pytest.raises(ValueError, match="valid: instruction, nearest"):
        next_object("farthest", [0], here, pos)
    with pytest.raises(ValueError, match="needs"):
        next_object("nearest", [0, 1])
    with pytest.raises(ValueError, match="no object"):
        next_object("instruction", [])


def test_effector_point_is_sample_hd_effector_end() -> None:
    """0.09 m beyond the flange on the tool axis (SAMPLE-HD's utils/robot.py effector_transform)."""
    from samplehd.export.unity_frame import UNITY_EFFECTOR_OFFSET

    for q in (HOME_QPOS, HOME_QPOS + np.array([0.3, -0.2, 0.4, 0.1, 0.5, -0.7])):
        flange, tcp = fk_flange(q), fk_tcp(q)
        assert np.allclose(effector_point(tcp[:3, 3], tcp[:3, :3]), flange[:3, 3] + 0.09 * flange[:3, 2], atol=1e-12)
    assert EFFECTOR_POINT_OFFSET == UNITY_EFFECTOR_OFFSET == 0.09


def test_order_is_validated_and_presets_choose_it() -> None:
    from samplehd.dataset.config import GenerateConfig, preset_config

    assert PlannerConfig().order == "instruction" and PICK_ORDERS == ("instruction", "nearest")
    for bad in ("closest", 1, None, ["nearest"]):
        with pytest.raises(ConfigError) as exc:
            PlannerConfig(order=bad)
        msg = str(exc.value)
        assert "\n" not in msg and msg.startswith("paths.planner.order=") and "instruction, nearest" in msg
    with pytest.raises(ConfigError, match=r"^cfg.json: paths.planner.order='closest'"):
        GenerateConfig.from_dict({"paths": {"planner": {"order": "closest"}}}, where="cfg.json")
    assert preset_config("tiny").paths.planner.order == "instruction"
    assert preset_config("small").paths.planner.order == "instruction"
    shd = preset_config("sample-hd")
    assert shd.paths.planner.order == "nearest"
    # A config that sets other planner (or checker) fields keeps the preset's order; one that sets it wins.
    mine = GenerateConfig.from_dict({"paths": {"planner": {"rrt_iterations": 100}, "checker": {"window": 2.0}}},
                                    base=shd)
    assert mine.paths.planner.order == "nearest" and mine.paths.planner.rrt_iterations == 100
    assert mine.paths.checker.window == 2.0 and mine.paths.checker.fall_angle == shd.paths.checker.fall_angle
    back = GenerateConfig.from_dict({"paths": {"planner": {"order": "instruction"}}}, base=shd)
    assert back.paths.planner.order == "instruction"


def _path(scene, order: str, seed: int = 0):
    from samplehd.motion.assist import compile_scene_with_assist
    from samplehd.record.paths import PathConfig, plan_and_execute

    model, data = compile_scene_with_assist(scene)
    task = {"type": "place", "objects": [0, 1], "subject": "front"}  # "the red objects": box, then can
    return plan_and_execute(scene, task, np.random.default_rng(seed), PathConfig(planner=PlannerConfig(order=order)),
                            compiled=(model, data))


def _approaches(ep) -> list[int]:
    idx = ep.frames["subtask_index"]
    return [t for t in range(ep.num_frames)
            if ep.subtasks[idx[t]] == "GripperMoveAvoid" and (t == 0 or idx[t - 1] != idx[t])]


@pytest.fixture(scope="module")
def nearest_episode(scene):
    return _path(scene, "nearest")


def test_paths_follow_the_order(scene, nearest_episode) -> None:
    ep = _path(scene, "instruction")
    assert ep.success and [int(ep.frames["target_object"][t]) for t in _approaches(ep)] == [0, 1]
    ep = nearest_episode
    assert ep.success
    starts = _approaches(ep)
    got = [int(ep.frames["target_object"][t]) for t in starts]
    # The rule restated from the recorded frames: at each approach's first frame, the remaining object
    # whose frame-0 position is nearest the point 0.09 m beyond the flange (FK of the recorded joints).
    base = np.array([-0.40, 0.0, 0.75])
    remaining, want = [0, 1], []
    for t in starts:
        flange = fk_flange(ep.frames["joint_pos"][t])
        tip = base + flange[:3, 3] + 0.09 * flange[:3, 2]
        d = [np.linalg.norm(ep.frames["object_pos"][0][i] - tip) for i in remaining]
        want.append(remaining.pop(int(np.argmin(d))))
    assert got == want == [1, 0]  # the can is nearer the arm's home than the box


def test_nearest_order_is_deterministic(scene, nearest_episode) -> None:
    again = _path(scene, "nearest")
    assert sorted(again.frames) == sorted(nearest_episode.frames)
    for k, a in nearest_episode.frames.items():
        assert np.array_equal(a, again.frames[k]), k


def test_only_sets_are_reordered(scene) -> None:
    """place/remove move a set; stack_three's objects are its order (middle, then top) and stay so."""
    from samplehd.motion.assist import compile_scene_with_assist
    from samplehd.motion.execute import scene_facts
    from samplehd.record.paths import PathConfig, _new_rollout
    from samplehd.tasks.task import parse_task

    model, data = compile_scene_with_assist(scene)
    config = PathConfig(planner=PlannerConfig(order="nearest"))
    ro, _ = _new_rollout(model, data, scene, np.random.default_rng(0), config, scene_facts(scene), None)
    place = parse_task({"type": "place", "objects": [0, 1], "subject": "front"})
    remove = parse_task({"type": "place", "objects": [0, 1], "subject": "right"}, family="remove")
    stack3 = parse_task({"type": "stack_three", "objects": [0, 1], "subject": 2})
    assert ro.next_object(place, [0, 1]) == 1 and ro.next_object(remove, [0, 1]) == 1
    assert ro.next_object(place, [0]) == 0
    assert stack3.objects == (0, 1) and ro.next_object(stack3, [0, 1]) == 0

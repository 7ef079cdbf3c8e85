"""The success checker on hand-made success and failure states of every family (real physics)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from samplehd.tasks.checker import CheckerConfig, check_success
from samplehd.tasks.task import Task, parse_task

TABLE = 0.75


@pytest.fixture(scope="module")
def scene():
    from samplehd.catalogue import ObjectInstance
    from samplehd.scene.spec import SceneObject, SceneSpec

    up = (1.0, 0.0, 0.0, 0.0)
    objs = (
        SceneObject(ObjectInstance("food_box", "flat", "red", "plastic", "medium"), (0.0, -0.25, TABLE), up),
        SceneObject(ObjectInstance("soda_can", "standard", "red", "metal", "medium"), (-0.05, 0.10, TABLE), up),
        SceneObject(ObjectInstance("bowl", "round", "white", "ceramic", "medium"), (0.20, -0.08, TABLE), up),
        SceneObject(ObjectInstance("mug", "straight", "blue", "ceramic", "medium"), (0.22, -0.32, TABLE), up),
        SceneObject(ObjectInstance("chopping_board", "rectangular", "brown", "wooden", "medium"),
                    (0.12, 0.26, TABLE), up),
    )
    for o in objs:
        o.instance.validate()
    return SceneSpec(index=0, seed=0, objects=objs)


@pytest.fixture(scope="module")
def compiled(scene):
    from samplehd.scene.spec import compile_scene

    return compile_scene(scene)


def _state(compiled, scene, moves: dict[int, tuple[float, float, float]]):
    """Fresh data with the scene's poses and some objects moved (upright)."""
    from samplehd.motion.execute import initial_state
    from samplehd.robot.controller import ControlConfig
    from samplehd.scene.spec import object_qpos_addresses

    model, data0 = compiled
    data = mujoco.MjData(model)
    mujoco.mj_copyData(data, model, data0)
    initial_state(model, data, ControlConfig())
    adr = object_qpos_addresses(model, len(scene.objects))
    for i, o in enumerate(scene.objects):
        data.qpos[adr[i]:adr[i] + 7] = (*o.pos, *o.quat)
    for i, p in moves.items():
        data.qpos[adr[i]:adr[i] + 7] = (*p, 1.0, 0.0, 0.0, 0.0)
    mujoco.mj_forward(model, data)
    return model, data


def _height(scene, i: int) -> float:
    from samplehd.catalogue import object_facts

    return float(object_facts(scene.objects[i].instance).height)


def _check(compiled, scene, task, moves, family=None):
    model, data = _state(compiled, scene, moves)
    return check_success(model, data, scene, parse_task(task, family))


def test_place(compiled, scene):
    ok = _check(compiled, scene, {"type": "place", "objects": [1], "subject": "left"}, {1: (-0.08, -0.10, TABLE)})
    assert ok.success, ok.reason
    bad = _check(compiled, scene, {"type": "place", "objects": [1], "subject": "left"}, {})
    assert not bad.success and "not in part left" in bad.reason
    band = _check(compiled, scene, {"type": "place", "objects": [1], "subject": "left"}, {1: (-0.08, -0.01, TABLE)})
    assert not band.success  # the neutral band belongs to neither half


def test_remove(compiled, scene):
    # Clear the right part (can and board are there): the executor writes it as a place to the left.
    task = {"type": "place", "objects": [1, 4], "subject": "left"}
    ok = _check(compiled, scene, task, {1: (0.0, -0.08, TABLE), 4: (-0.02, -0.5, TABLE)}, family="remove")
    assert ok.success, ok.reason
    assert parse_task(task, "remove").part == "right"
    bad = _check(compiled, scene, task, {1: (0.0, -0.08, TABLE)}, family="remove")
    assert not bad.success and "object 4" in bad.reason


def test_stack(compiled, scene):
    task = {"type": "stack", "objects": [1], "subject": 0}
    ok = _check(compiled, scene, task, {1: (0.0, -0.25, TABLE + _height(scene, 0) + 0.0005)})
    assert ok.success, ok.reason
    beside = _check(compiled, scene, task, {1: (0.0, -0.10, TABLE)})
    assert not beside.success and "does not touch" in beside.reason
    # Floating above the base: falls onto it within the window, so it is not stable.
    drop = _check(compiled, scene, task, {1: (0.0, -0.25, TABLE + _height(scene, 0) + 0.08)})
    assert not drop.success


def test_put(compiled, scene):
    from samplehd.catalogue import object_facts

    floor = object_facts(scene.objects[2].instance).opening.floor_height
    task = {"type": "put", "objects": [1], "subject": 2}
    ok = _check(compiled, scene, task, {1: (0.20, -0.08, TABLE + floor + 0.001)})
    assert ok.success, ok.reason
    bad = _check(compiled, scene, task, {1: (0.05, -0.08, TABLE)})
    assert not bad.success and "footprint" in bad.reason


def test_place_relative(compiled, scene):
    task = {"type": "place_relative", "objects": [1], "subject": 3, "relation": "left"}
    ok = _check(compiled, scene, task, {1: (0.22, -0.45, TABLE)})
    assert ok.success, ok.reason
    bad = _check(compiled, scene, task, {1: (0.22, -0.18, TABLE)})
    assert not bad.success and "not left of" in bad.reason


def test_stack_three(compiled, scene):
    task = {"type": "stack_three", "objects": [0, 1], "subject": 4}
    t = parse_task(task)
    assert t.objects == (0, 1) and t.reference == 4
    zb = TABLE + _height(scene, 4)
    ok = _check(compiled, scene, task, {0: (0.12, 0.26, zb + 0.0005), 1: (0.12, 0.26, zb + _height(scene, 0) + 0.001)})
    assert ok.success, ok.reason
    half = _check(compiled, scene, task, {0: (0.12, 0.26, zb + 0.0005), 1: (-0.05, 0.0, TABLE)})
    assert not half.success and "object 1" in half.reason


def test_pick_up_failures(compiled, scene):
    task = {"type": "pick_up", "objects": [1], "subject": None}
    on_table = _check(compiled, scene, task, {})
    assert not on_table.success and "above the table" in on_table.reason
    # Floating with nothing holding it: it falls during the window.
    floating = _check(compiled, scene, task, {1: (-0.05, 0.10, TABLE + 0.2)})
    assert not floating.success


def test_disturbed_and_fallen(compiled, scene):
    from samplehd.scene.spec import object_qpos_addresses

    model, data = _state(compiled, scene, {1: (-0.08, -0.10, TABLE)})
    adr = object_qpos_addresses(model, len(scene.objects))
    # Knock the mug over (lying on its side) and push the bowl 5 cm.
    data.qpos[adr[3]:adr[3] + 7] = (0.22, -0.32, TABLE + 0.05, np.sqrt(0.5), np.sqrt(0.5), 0.0, 0.0)
    data.qpos[adr[2]:adr[2] + 3] = (0.25, -0.08, TABLE)
    mujoco.mj_forward(model, data)
    r = check_success(model, data, scene, Task("place", (1,), part="left"))
    assert r.success, r.reason
    assert 3 in r.fallen and 2 in r.disturbed and 1 not in r.disturbed


def test_checker_leaves_state_untouched(compiled, scene):
    model, data = _state(compiled, scene, {})
    before = data.qpos.copy()
    check_success(model, data, scene, {"type": "place", "objects": [1], "subject": "left"}, CheckerConfig(window=0.2))
    assert np.array_equal(before, data.qpos)


def test_config_validation():
    from samplehd.errors import ConfigError

    with pytest.raises(ConfigError):
        CheckerConfig(window=-1.0)
    with pytest.raises(ConfigError):
        CheckerConfig.from_dict({"nope": 1})
    assert CheckerConfig.from_dict(CheckerConfig().to_dict()) == CheckerConfig()


def test_the_window_is_the_steps_one_by_one(compiled, scene):
    """The checker's window runs in MuJoCo's own loop: the same bits as stepping once per call."""
    from samplehd.physics import wake_all
    from samplehd.tasks.checker import _simulate_window

    model, data = _state(compiled, scene, {0: (0.05, -0.2, TABLE + 0.03)})  # the box falls 3 cm
    end = _simulate_window(model, data, 0.3)
    ref = mujoco.MjData(model)
    mujoco.mj_copyData(ref, model, data)
    wake_all(ref)
    for _ in range(150):
        mujoco.mj_step(model, ref)
    mujoco.mj_forward(model, ref)
    assert end.time == ref.time > data.time
    for field in ("qpos", "qvel", "act", "xpos"):
        assert getattr(end, field).tobytes() == getattr(ref, field).tobytes(), field

"""Spots that leave room for the objects still to come to the same table part (place, remove)."""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import dataclasses

import mujoco
import numpy as np
import pytest

from samplehd.catalogue import ObjectInstance
from samplehd.motion.execute import scene_facts
from samplehd.motion.planner import destination_candidates, leaves_room
from samplehd.scene.spec import SceneObject, SceneSpec, compile_scene
from samplehd.tasks.task import Task
from samplehd.world.bodies import SceneBodies
from samplehd.world.layout import LAYOUT
from samplehd.world.planner_config import PlannerConfig

TABLE = 0.75  # [m]
UP = (1.0, 0.0, 0.0, 0.0)
# the bowl and the food box go to the left part, where the mug stands
TASK = Task("place", (1, 2), part="left")


@pytest.fixture(scope="module")
def scene():
    objs = (
        SceneObject(ObjectInstance("mug", "shopvrb1", "red", "ceramic", "medium"), (0.05, -0.15, TABLE), UP),
        SceneObject(ObjectInstance("bowl", "shopvrb1", "white", "ceramic", "medium"), (0.05, 0.05, TABLE), UP),
        SceneObject(ObjectInstance("food_box", "shopvrb1", "yellow", "plastic", "small"), (0.12, 0.05, TABLE), UP),
    )
    spec = SceneSpec(index=0, seed=0, objects=objs)
    model, data = compile_scene(spec, robot_look="primitive")
    return model, data, SceneBodies(model, len(objs)), scene_facts(spec)


def _spots(layout):
    lo, hi = layout.part_bounds("left")
    return [np.array((x, y)) for x in np.arange(lo[0] + 0.03, hi[0] - 0.03 + 1e-9, 0.03)
            for y in np.arange(lo[1] + 0.03, hi[1] - 0.03 + 1e-9, 0.03)]


def test_a_spot_beside_an_object_still_to_be_picked_up_is_refused(scene) -> None:
    model, data, bodies, facts = scene
    cfg = PlannerConfig()
    # 11 cm from the food box's centre: its footprint 4 cm from the bowl's, closer than GRASP_ROOM
    assert not leaves_room(data, bodies, facts, 1, (np.array((0.12, -0.06)), 0.0), [2], TASK, cfg)
    assert leaves_room(data, bodies, facts, 1, (np.array((0.2, -0.3)), 0.0), [2], TASK, cfg)
    # nothing to come: any spot
    assert leaves_room(data, bodies, facts, 1, (np.array((0.12, -0.06)), 0.0), [], TASK, cfg)


def test_room_left_is_room_the_planner_finds(scene) -> None:
    """In a part narrowed to a few spots for the bowl: where the bowl leaves room, the planner's own
    search finds a free spot for the food box once the bowl stands there, and some spots leave none."""
    model, data, bodies, facts = scene
    cfg = PlannerConfig()
    layout = dataclasses.replace(LAYOUT, workspace_min=(-0.05, -0.3))
    answers = [(xy, leaves_room(data, bodies, facts, 1, (xy, 0.0), [2], TASK, cfg, layout)) for xy in _spots(layout)]
    assert 0 < sum(ok for _, ok in answers) < len(answers)
    moved = mujoco.MjData(model)
    adr = int(model.jnt_qposadr[model.body_jntadr[bodies.object_body[1]]])
    for xy, ok in answers:
        if not ok:
            continue
        moved.qpos[:] = data.qpos
        moved.qpos[adr:adr + 2] = xy
        mujoco.mj_kinematics(model, moved)
        rng = np.random.default_rng(0)
        strict = dataclasses.replace(cfg, spot_samples=4000)
        assert destination_candidates(moved, bodies, facts, 2, TASK, rng, strict, layout, relaxed=True), xy

"""A disturbed episode replays bit for bit: its rollout executes the steering vectors it records as the
environment does, so the replay of those vectors reproduces every recorded state and the outcome.

The scene and instruction are those of ``samplehd generate --preset tiny --scenes 25 --render none --seed 11
--disturb 1 --disturb-kinds missed_grasp`` (scene 15, slot 1): a thin metal plate grasped again after a
missed grasp, whose replay from the planner's joint targets used to push the plate elsewhere and end in a
failure the recording did not have.
"""

from __future__ import annotations

import numpy as np
import pytest

SCENE = {
    "index": 15, "seed": 3025959953,
    "objects": [
        {"instance": {"class_name": "plate", "variant": "dinner", "colour": "purple", "material": "ceramic",
                      "size": "large"},
         "pos": [-0.007316177856315063, -0.29325009311230354, 0.7498785800188466],
         "quat": [0.9258635958430509, -3.217690305664216e-09, 1.5637320896977033e-09, -0.3778579123064327]},
        {"instance": {"class_name": "mug", "variant": "tapered", "colour": "blue", "material": "ceramic",
                      "size": "medium"},
         "pos": [0.1744260529632382, 0.07683027295435173, 0.7498775480874847],
         "quat": [0.8578628922019584, 0.00020114839146801675, 0.00030485300487635437, 0.5138785116998581]},
        {"instance": {"class_name": "plate", "variant": "soup", "colour": "yellow", "material": "metal",
                      "size": "small"},
         "pos": [0.22515308779861218, 0.27048283569888004, 0.7498767202087706],
         "quat": [0.9852091572700791, 0.0001246401119457454, 0.00019396605852586304, -0.17135595488103492]},
    ],
    "camera": {"name": "scene", "pos": [1.26851559177009, -0.013916647147936112, 1.6029399042641166],
               "target": [-0.04454808097134258, 0.03860844168094749, 0.93], "fovy": 45.0},
}
DIRECTIONS = {"left": [0.0, -1.0, 0.0], "right": [0.0, 1.0, 0.0], "front": [1.0, 0.0, 0.0],
              "behind": [-1.0, 0.0, 0.0], "above": [0.0, 0.0, 1.0], "below": [0.0, 0.0, -1.0]}
TASK = {"type": "pick_up", "objects": [2], "subject": None, "relation": None}
SEED = 2282998897


@pytest.fixture(scope="module")
def regrasped():
    from samplehd.motion.assist import compile_scene_with_assist
    from samplehd.record.disturbances import DisturbanceConfig, draw_disturbance
    from samplehd.record.paths import plan_and_execute
    from samplehd.scene.spec import SceneSpec

    scene = SceneSpec.from_dict(SCENE)
    drawn = draw_disturbance(DisturbanceConfig(probability=1.0, kinds=("missed_grasp",)), SEED)
    compiled = compile_scene_with_assist(scene, 0.002, "primitive")
    return plan_and_execute(scene, TASK, np.random.default_rng(SEED), family="pick_up", seed=SEED,
                            directions=DIRECTIONS, compiled=compiled, disturbance=drawn)


def test_a_regrasp_after_a_missed_grasp_replays_bit_for_bit(regrasped):
    from samplehd.envs.tabletop import TabletopEnv

    ep = regrasped
    label = ep.info["disturbance"]
    assert label["failure"] == "grasp_missed" and label["outcome"] == "recovered" and ep.success
    assert ep.subtasks.count("CloseGripper") >= 2  # the missed grasp, then re-grasps of the plate
    frames = ep.frames
    env = TabletopEnv(obs_mode="state", control_mode="steering", max_episode_steps=None)
    try:
        instruction = {"instruction": "Take hold of the metal plate and lift it up.", "task": TASK}
        env.reset(options={"scene": SCENE, "instruction": instruction, "episode": ep})
        data, success = env.unwrapped.data, False
        for t in range(ep.num_frames - 1):
            *_, info = env.step(frames["steering"][t])
            success = success or bool(info["success"])
            assert data.qpos.tobytes() == frames["qpos"][t + 1].tobytes(), f"frame {t + 1} differs"
            # the weld of step t (its rule runs before its physics) is the one frame t records
            assert int(env.unwrapped.assist.active) == int(frames["grasped_object"][t]), f"frame {t}"
    finally:
        env.close()
    assert success == ep.success

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


# A recorded failure: ``samplehd generate --preset tiny --scenes 50 --render none --seed 11 --workers 2 --disturb 1
# --disturb-kinds short_release``, episode 80 (scene 40, slot 0). The wine glass is let go short of the pan and
# re-grasped; it ends in the pan on its side, where no grasp of the planner reaches it: the recovery fails. The
# checker's predicate holds (the glass is in the pan), so the environment reports success while the dataset,
# which rejects a fall, records a failure; the replay judges the final state by the dataset's rule and agrees.
FALLEN_SCENE = {
    "index": 40, "seed": 3469068474,
    "objects": [
        {"instance": {"class_name": "wine_glass", "variant": "shopvrb2", "colour": "red", "material": "glass",
                      "size": "small"},
         "pos": [-0.09433562854014285, 0.24729172922571477, 0.749949385110453],
         "quat": [0.9684346258250618, 1.8270204894653134e-05, 0.00012992025047174879, -0.249267643889055]},
        {"instance": {"class_name": "plate", "variant": "shopvrb2", "colour": "purple", "material": "plastic",
                      "size": "medium"},
         "pos": [0.2657791551340256, -0.11275945858324354, 0.749954394390255],
         "quat": [0.08089110642401459, -1.0790334418429323e-05, 4.346936627963835e-07, -0.996722944847202]},
        {"instance": {"class_name": "pan", "variant": "shopvrb2", "colour": "metallic", "material": "metal",
                      "size": "small"},
         "pos": [0.2288681523794344, 0.21266721422641552, 0.7499499760873896],
         "quat": [0.5026201625511729, -0.00010608207392983432, 2.6435179849983905e-05, 0.8645073511803166]},
    ],
    "camera": {"name": "scene", "pos": [1.4139449046323807, 0.09851183754930382, 1.471360836321821],
               "target": [-0.027778470363229515, 0.006802818984182988, 0.93], "fovy": 45.0},
}
FALLEN_TASK = {"type": "put", "objects": [0], "subject": 2, "relation": None}
FALLEN_SEED = 3960300523


def test_a_failed_recovery_with_a_fall_replays_to_its_recorded_failure():
    from samplehd.envs.replay_check import final_outcome
    from samplehd.envs.tabletop import TabletopEnv
    from samplehd.motion.assist import compile_scene_with_assist
    from samplehd.record.disturbances import DisturbanceConfig, draw_disturbance
    from samplehd.record.paths import plan_and_execute
    from samplehd.scene.spec import SceneSpec

    scene = SceneSpec.from_dict(FALLEN_SCENE)
    drawn = draw_disturbance(DisturbanceConfig(probability=1.0, kinds=("short_release",)), FALLEN_SEED)
    ep = plan_and_execute(scene, FALLEN_TASK, np.random.default_rng(FALLEN_SEED), family="put", seed=FALLEN_SEED,
                          directions=DIRECTIONS, compiled=compile_scene_with_assist(scene, 0.002, "primitive"),
                          disturbance=drawn)
    label = ep.info["disturbance"]
    assert not ep.success and label["outcome"] == "failed", label
    assert ep.info["check"]["success"] and ep.info["check"]["fallen"] == [0]  # in the pan, on its side
    env = TabletopEnv(obs_mode="state", control_mode="steering", max_episode_steps=None)
    try:
        instruction = {"instruction": "Put the wine glass into the pan.", "task": FALLEN_TASK}
        env.reset(options={"scene": FALLEN_SCENE, "instruction": instruction, "episode": ep})
        any_step = False
        for t in range(ep.num_frames - 1):
            *_, info = env.step(ep.frames["steering"][t])
            any_step = any_step or bool(info["success"])
            assert env.unwrapped.data.qpos.tobytes() == ep.frames["qpos"][t + 1].tobytes(), f"frame {t + 1} differs"
        assert any_step  # what the replay used to count: a success the recording never had
        assert final_outcome(env) == ep.success
        assert final_outcome(env, reject_fallen=False)
    finally:
        env.close()

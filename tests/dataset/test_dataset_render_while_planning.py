"""Images rendered while the path is planned (``RenderConfig.images_while_planning``): the same bytes as images
rendered from the finished episode's states, the frames of a failed attempt dropped, the planner's errors raised
in the caller, and no thread left behind."""

from __future__ import annotations

import dataclasses
import threading

import numpy as np
import pytest

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

pytestmark = pytest.mark.render

CAMERAS = ("operator",)


def _threads_left() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name.startswith(("samplehd-plan", "samplehd-frames"))]


def _chunks(images):
    return {c: {m: list(v.chunks) for m, v in mods.items()} for c, mods in images.items()}


@pytest.fixture(scope="module")
def planned():
    """A real episode of a two-object scene (real planner and physics), its model and its render settings."""
    import mujoco

    from samplehd.catalogue import ObjectInstance
    from samplehd.dataset.render import RenderConfig
    from samplehd.motion.assist import compile_scene_with_assist
    from samplehd.record.paths import plan_and_execute
    from samplehd.scene.spec import SceneObject, SceneSpec
    from samplehd.world.layout import LAYOUT

    up, t = (1.0, 0.0, 0.0, 0.0), LAYOUT.table_height
    scene = SceneSpec(index=0, seed=0, objects=(
        SceneObject(ObjectInstance("soda_can", "standard", "red", "metal", "medium"), (0.05, 0.12, t), up),
        SceneObject(ObjectInstance("bowl", "round", "white", "ceramic", "medium"), (0.20, -0.05, t), up),
    ))
    model, data = compile_scene_with_assist(scene)
    task = {"type": "place", "objects": [0], "subject": "left"}

    start = mujoco.MjData(model)
    mujoco.mj_copyData(start, model, data)

    def plan(on_state=None):  # from the scene's first state each time (the planner leaves data at its last)
        mujoco.mj_copyData(data, model, start)
        return plan_and_execute(scene, task, np.random.default_rng(0), compiled=(model, data), on_state=on_state)

    return plan, model, RenderConfig("fast", 32, 24, CAMERAS), plan()


def test_images_while_planning_are_those_of_the_finished_episode(planned):
    plan, model, render, episode = planned
    got = render.images_while_planning(model, plan)
    assert got.episode.success and got.plan_cpu_seconds > 0
    np.testing.assert_array_equal(got.episode.frames["qpos"], episode.frames["qpos"])
    want = render.images(model, got.episode.frames, deflated=True)
    assert _chunks(got.images) == _chunks(want)  # every frame of every stream, in order, byte for byte
    assert len(got.images["operator"]["rgb"]) == got.episode.num_frames
    assert not _threads_left()


def test_the_frames_of_a_failed_attempt_are_dropped(planned):
    plan, model, render, episode = planned
    frames = episode.frames

    def feed(on_state, attempt, order):
        for k in order:
            on_state(attempt, frames["qpos"][k], frames["qvel"][k], frames["act"][k], frames["time"][k])

    def plan_with_a_failed_attempt(on_state):
        feed(on_state, 0, range(len(frames["qpos"]) - 1, -1, -2))  # attempt 0: other states, then it failed
        feed(on_state, 1, range(len(frames["qpos"])))
        return episode

    # Keyframes (every 3rd frame): the frames the renderer after planning picks.
    every = dataclasses.replace(render, every=3)
    got = every.images_while_planning(model, plan_with_a_failed_attempt)
    want = every.images(model, frames, deflated=True)
    for m, v in got.images["operator"].items():
        assert v.frames.tolist() == want["operator"][m].frames.tolist() == list(range(0, len(frames["qpos"]), 3))
        assert v.images.chunks == want["operator"][m].images.chunks
    assert not _threads_left()


def test_an_error_of_the_planner_is_raised_here_and_rendering_stops(planned):
    from samplehd.record.paths import PathRejected

    plan, model, render, episode = planned
    frames = episode.frames
    drawn = []

    def rejected(on_state):
        for k in range(5):
            on_state(0, frames["qpos"][k], frames["qvel"][k], frames["act"][k], frames["time"][k])
        raise PathRejected("checker_failed", "instruction 0: nothing placed (test)", [], None)

    with pytest.raises(PathRejected, match="nothing placed") as caught:
        render.images_while_planning(model, rejected)
    assert caught.value.reason == "checker_failed"
    assert not _threads_left()
    # A planner that records more states than the episode it returns holds: refused, not written.
    from samplehd.errors import RenderError

    def short(on_state):
        for k in range(3):
            drawn.append(k)
            on_state(0, frames["qpos"][k], frames["qvel"][k], frames["act"][k], frames["time"][k])
        return dataclasses.replace(episode, frames={k: v[:2] for k, v in frames.items()})

    with pytest.raises(RenderError, match="rendered 3 states"):
        render.images_while_planning(model, short)
    assert not _threads_left()


def test_an_error_of_the_renderer_stops_the_planner_and_leaves_no_thread(planned):
    from samplehd.errors import DatasetError

    plan, model, render, episode = planned
    frames = episode.frames
    recorded = []

    def endless(on_state):  # records until told to stop
        k = 0
        while True:
            qpos = frames["qpos"][0] if k < 3 else np.zeros(model.nq + 1)  # the 4th state fits another model
            recorded.append(k)
            on_state(0, qpos, frames["qvel"][0], frames["act"][0], frames["time"][0])
            k += 1

    with pytest.raises(DatasetError, match="nq="):
        render.images_while_planning(model, endless)
    assert len(recorded) >= 4
    assert not _threads_left()

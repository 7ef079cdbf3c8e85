"""Rendering recorded states: every frame written into its slot of the streams equals a render of that state."""

import mujoco
import numpy as np
import pytest

from samplehd.render.image_spec import ImageSpec
from samplehd.render.renderer import MODALITIES, SceneRenderer
from samplehd.render.states import pose_state, render_states, set_state

pytestmark = pytest.mark.render


def test_render_states_equals_one_render_per_state(world):
    model, data = world
    qpos = np.stack([data.qpos + d for d in (0.0, 0.3, -0.4)])
    qpos[:, 6:] = data.qpos[6:]  # move the arm only
    frames = {"qpos": qpos, "qvel": np.zeros((3, model.nv))}
    got = render_states(model, frames, ImageSpec(64, 48, "fast", ("operator", "wrist"), MODALITIES), indices=[2, 0])
    d = mujoco.MjData(model)
    with SceneRenderer(model, 64, 48, "fast") as r:
        for i, k in enumerate((2, 0)):
            set_state(model, d, qpos[k], frames["qvel"][k])
            for cam in ("operator", "wrist"):
                for m, want in r.render(d, cam, MODALITIES).items():
                    assert got[cam][m].shape == (2, *want.shape) and got[cam][m].dtype == want.dtype
                    np.testing.assert_array_equal(got[cam][m][i], want, err_msg=f"{cam} {m} frame {k}")
    assert not np.array_equal(got["operator"]["rgb"][0], got["operator"]["rgb"][1])
    empty = render_states(model, frames, ImageSpec(64, 48, "fast", ("operator",), ("depth",)), indices=[])
    assert empty["operator"]["depth"].shape == (0, 48, 64) and empty["operator"]["depth"].dtype == np.float32


POSE_FIELDS = ("xpos", "xquat", "xmat", "xipos", "ximat", "geom_xpos", "geom_xmat", "site_xpos", "site_xmat",
               "cam_xpos", "cam_xmat", "light_xpos", "light_xdir", "subtree_com", "wrap_xpos", "wrap_obj",
               "ten_wrapadr", "ten_wrapnum", "ten_length")


def _scene_with_objects():
    from samplehd.catalogue import ObjectInstance
    from samplehd.motion.assist import compile_scene_with_assist
    from samplehd.scene.spec import SceneObject, SceneSpec
    from samplehd.world.layout import LAYOUT

    up, t = (1.0, 0.0, 0.0, 0.0), LAYOUT.table_height
    return compile_scene_with_assist(SceneSpec(index=0, seed=0, objects=(
        SceneObject(ObjectInstance("soda_can", "standard", "red", "metal", "medium"), (0.05, 0.12, t), up),
        SceneObject(ObjectInstance("bowl", "round", "white", "ceramic", "medium"), (0.20, -0.05, t), up),
    )))


def test_pose_state_gives_the_poses_of_mj_forward_bit_for_bit_and_the_same_images():
    model, data = _scene_with_objects()
    states = []
    for arm, obj in ((0.0, 0.0), (0.4, 0.03), (-0.5, -0.07)):
        q = data.qpos.copy()
        q[:6] += arm  # the arm (tendon-driven fingers follow their joints)
        q[-7:-4] += obj  # the last object's free joint: moved and tilted
        q[-3] += obj
        states.append(q)
    full, poses = mujoco.MjData(model), mujoco.MjData(model)
    # A frame's pixels depend a little on the renderer's previous frame (a fresh renderer's first frame, and hd
    # after a change of state): each way renders the same sequence with a renderer of its own.
    with SceneRenderer(model, 96, 64, "hd") as a, SceneRenderer(model, 96, 64, "hd") as b:
        for q in states:
            set_state(model, full, q, np.zeros(model.nv))
            pose_state(model, poses, q, np.zeros(model.nv))
            for f in POSE_FIELDS:
                np.testing.assert_array_equal(getattr(poses, f), getattr(full, f), err_msg=f)
            for cam in ("operator", "wrist"):
                want = a.render(full, cam, MODALITIES)
                for m, got in b.render(poses, cam, MODALITIES).items():
                    np.testing.assert_array_equal(got, want[m], err_msg=f"{cam} {m}")
    assert full.ncon > 0 and poses.ncon == 0  # the collision stage did not run


def test_a_renderer_whose_scene_is_full_makes_it_larger_and_draws_everything(world, tmp_path, monkeypatch):
    model, shared = world
    data = mujoco.MjData(model)  # the full scene's warning is counted in this MjData, not the shared one
    mujoco.mj_copyData(data, model, shared)
    monkeypatch.chdir(tmp_path)  # and MuJoCo logs it to MUJOCO_LOG.TXT here
    with SceneRenderer(model, 64, 48, "fast") as r:
        want = r.render(data, "operator", MODALITIES)
        r._scene = mujoco.MjvScene(model, maxgeom=4)  # room for 4 of the world's geoms
        got = r.render(data, "operator", MODALITIES)
        assert r._scene.maxgeom > r._scene.ngeom > 4
    for m in MODALITIES:
        np.testing.assert_array_equal(got[m], want[m], err_msg=m)


def _arm_states(model, data, n):
    qpos = np.stack([data.qpos + 0.1 * d for d in range(n)])
    qpos[:, 6:] = data.qpos[6:]  # move the arm only
    return {"qpos": qpos, "qvel": np.zeros((n, model.nv))}


def _frames_left():
    import threading

    return [t for t in threading.enumerate() if t.name.startswith("samplehd-frames")]


def test_on_frame_beside_the_render_loop_sees_every_frame_in_order_on_another_thread(world):
    import threading
    import time

    from samplehd.render.renderer import IMAGE_DTYPES
    from samplehd.render.states import OVERLAP_BUFFERS, _group_frames

    model, data = world
    frames = _arm_states(model, data, 30)
    # Frames go to the helper in groups, and the groups' buffers take turns: 30 frames reuse the first group's.
    group = _group_frames(ImageSpec(64, 48, "fast", ("operator", "wrist"), MODALITIES), IMAGE_DTYPES)
    assert 1 < group and OVERLAP_BUFFERS * group < 30 and 30 % group  # and the last group is a short one
    want = render_states(model, frames, ImageSpec(64, 48, "fast", ("operator", "wrist"), MODALITIES))
    got: dict[str, dict[str, list[np.ndarray]]] = {c: {m: [] for m in MODALITIES} for c in ("operator", "wrist")}
    threads = set()

    def keep(cam, images):
        if not threads:  # a slow first call: the renderer, at the first group's buffers again, must wait
            time.sleep(1.0)
        threads.add(threading.get_ident())
        for m, a in images.items():
            got[cam][m].append(a.copy())

    assert render_states(model, frames, ImageSpec(64, 48, "fast", ("operator", "wrist"), MODALITIES), on_frame=keep,
                         overlap=True) == {}
    assert threads and threading.get_ident() not in threads
    for cam in got:
        for m in MODALITIES:
            np.testing.assert_array_equal(np.stack(got[cam][m]), want[cam][m], err_msg=f"{cam} {m}")
    # One frame per hand-over, as a caller may ask: the same frames in the same order.
    one: list[np.ndarray] = []
    render_states(model, frames, ImageSpec(64, 48, "fast", ("operator", "wrist"), ("rgb",)), overlap=True,
                  overlap_group=1,
                  on_frame=lambda cam, images: one.append(images["rgb"].copy()) if cam == "wrist" else None)
    np.testing.assert_array_equal(np.stack(one), want["wrist"]["rgb"])
    with pytest.raises(ValueError, match="overlap_group 0"):
        render_states(model, frames, ImageSpec(64, 48, "fast", ("operator",), ("rgb",)), on_frame=lambda c, i: None,
                      overlap=True, overlap_group=0)
    assert not _frames_left()


def test_an_error_beside_the_render_loop_is_raised_and_leaves_no_thread(world):
    model, data = world
    frames = _arm_states(model, data, 9)
    calls = []

    def fail_at_third(cam, images):
        calls.append(cam)
        if len(calls) == 3:
            raise OSError("disk full (test)")

    with pytest.raises(OSError, match="disk full"):
        render_states(model, frames, ImageSpec(32, 24, "fast", ("operator",), ("rgb",)), on_frame=fail_at_third,
                      overlap=True)
    assert not _frames_left()
    # An error of the render loop itself (a state of another model) while calls are pending: also no thread left.
    from samplehd.errors import DatasetError

    bad = {"qpos": list(frames["qpos"]) + [np.zeros(model.nq + 1)], "qvel": list(frames["qvel"]) * 2}
    with pytest.raises(DatasetError, match="nq="):
        render_states(model, bad, ImageSpec(32, 24, "fast", ("operator",), ("rgb",)), on_frame=lambda c, i: None,
                      overlap=True)
    assert not _frames_left()


def test_live_states_render_the_attempt_that_became_the_episode_and_nothing_of_an_abandoned_one(world):
    import threading
    import time

    from samplehd.render.states import LiveStates, Superseded, render_live

    model, data = world
    frames = _arm_states(model, data, 12)
    wrong = _arm_states(model, data, 12)
    wrong["qpos"] = wrong["qpos"][::-1].copy()  # another rollout: the arm swings the other way
    want = render_states(model, frames, ImageSpec(48, 32, "fast", ("operator",), ("rgb", "segmentation")))
    live = LiveStates()
    drawn: list[dict[str, list[np.ndarray]]] = []

    def on_attempt():
        drawn.append({"rgb": [], "segmentation": []})
        mine = drawn[-1]
        return lambda cam, images: [mine[m].append(a.copy()) for m, a in images.items()]

    def record():
        for states, last in ((wrong, False), (frames, True)):
            live.restart()
            for k in range(len(states["qpos"])):
                live.put(states["qpos"][k], states["qvel"][k], None, None)
                time.sleep(0.02 if not last else 0.001)
            deadline = time.monotonic() + 60.0
            while not last and not (drawn and drawn[0]["rgb"]) and time.monotonic() < deadline:
                time.sleep(0.01)  # the renderer is into the first attempt before it is abandoned
        live.finish(success=True)

    recorder = threading.Thread(target=record)
    recorder.start()
    count = render_live(model, live, on_attempt, ImageSpec(48, 32, "fast", ("operator",), ("rgb", "segmentation")))
    recorder.join()
    assert count == 12 and len(drawn) == 2 and drawn[0]["rgb"]  # the first attempt was being drawn
    for m in ("rgb", "segmentation"):
        np.testing.assert_array_equal(np.stack(drawn[-1][m]), want["operator"][m], err_msg=m)
    assert not _frames_left()
    # A rollout that ends without an episode: nothing is returned, and a reader of its states learns so.
    failed = LiveStates()
    failed.restart()
    failed.put(frames["qpos"][0], frames["qvel"][0], None, None)
    failed.finish(success=False)
    failed.finish(success=True)  # only the first finish counts
    assert render_live(model, failed, on_attempt, ImageSpec(48, 32, "fast", ("operator",), ("rgb",))) is None
    with pytest.raises(Superseded):
        list(failed.states(1))
    assert not _frames_left()

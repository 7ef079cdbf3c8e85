"""The path-traced ``photo`` preset: pixel alignment with GL depth/segmentation, determinism, looks, errors.

Images are tiny (the path tracer runs on the CPU); the whole module takes a few seconds after Mitsuba's
first kernel compile.
"""

from __future__ import annotations

import numpy as np
import pytest

from samplehd.errors import RenderError

pytest.importorskip("mitsuba", reason="the photo preset needs samplehd[photo]")

W, H = 96, 54


@pytest.fixture(scope="module")
def scene_world():
    """A sampled scene with glass, metal, a food box and a can: (model, data)."""
    from samplehd.scene.config import SceneConfig
    from samplehd.scene.sampler import sample_scene
    from samplehd.scene.spec import compile_scene

    # a wooden board, a food box, a soda can, a metal pan: seed 25 of the procedural shapes, named, as the
    # tests below lift object 1, the food box
    res = sample_scene(0, 25, SceneConfig(catalogue="procedural"))
    return compile_scene(res.scene)


@pytest.fixture(scope="module")
def photo(scene_world):
    from samplehd.render.renderer import SceneRenderer

    model, _ = scene_world
    r = SceneRenderer(model, W, H, "photo")
    yield r
    r.close()


@pytest.mark.parametrize("camera", ["scene", "wrist"])
def test_path_traced_geometry_lines_up_with_gl_depth_and_segmentation(scene_world, photo, camera):
    """What the path tracer hits at each pixel centre is what GL draws there: ids on ≥ 99.5 % of the pixels,
    depth within 1 mm where both see a surface (the depth and ids the photo preset returns are GL's)."""
    model, data = scene_world
    gl = photo.render(data, camera, ("rgb", "depth", "segmentation"))
    depth, seg = photo.photo_geometry()
    assert (seg == gl["segmentation"]).mean() >= 0.995
    both = np.isfinite(depth) & (gl["depth"] < 25.0)
    assert both.mean() > 0.9
    assert (np.abs(depth - gl["depth"])[both] < 1e-3).mean() >= 0.995
    assert len(np.unique(gl["segmentation"])) >= 3  # background, table, robot/objects: a real check


def test_photo_returns_gl_depth_and_segmentation_exactly(scene_world, photo):
    from samplehd.render.renderer import SceneRenderer

    model, data = scene_world
    got = photo.render(data, "scene", ("rgb", "depth", "segmentation"))
    with SceneRenderer(model, W, H, "fast") as fast:
        want = fast.render(data, "scene", ("depth", "segmentation"))
    np.testing.assert_array_equal(got["segmentation"], want["segmentation"])
    np.testing.assert_array_equal(got["depth"], want["depth"])
    assert got["rgb"].shape == (H, W, 3) and got["rgb"].dtype == np.uint8


def test_same_state_same_image_and_a_lit_unclipped_picture(scene_world, photo):
    model, data = scene_world
    a = photo.render(data, "scene")["rgb"]
    b = photo.render(data, "scene")["rgb"]
    # Same seed: the path tracer is deterministic; the denoiser may differ by a few levels across threads.
    assert np.abs(a.astype(int) - b.astype(int)).max() <= 3
    lum = a.mean(axis=2)
    assert 60 < lum.mean() < 200  # neither black nor blown out
    assert (lum < 5).mean() < 0.02 and (lum > 250).mean() < 0.02


def test_objects_move_with_the_state(scene_world, photo):
    import mujoco

    model, data = scene_world
    before = photo.render(data, "scene")["rgb"]
    moved = mujoco.MjData(model)
    moved.qpos[:] = data.qpos
    jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "object_1_joint")
    moved.qpos[model.jnt_qposadr[jid] + 2] += 0.25  # lift the food box 25 cm
    mujoco.mj_forward(model, moved)
    after = photo.render(moved, "scene", ("rgb", "segmentation"))
    assert np.abs(after["rgb"].astype(int) - before.astype(int)).mean() > 1.0
    # The lifted box is drawn where GL now sees it.
    depth, seg = photo.photo_geometry()
    assert (seg == after["segmentation"]).mean() >= 0.995


def test_random_look_is_drawn_from_the_seed_and_recorded():
    from samplehd.render.photo import default_look, random_look

    assert random_look(5) == random_look(5)
    assert random_look(5) != random_look(6)
    d = random_look(5).to_dict()
    assert d["randomised"] is True and 2700 <= d["colour_temperature"] <= 6500
    assert default_look().to_dict()["randomised"] is False


def test_bad_photo_options_are_one_line_errors():
    from samplehd.render.photo import PhotoOptions

    for spp in (0, -1, 2.5, True):
        with pytest.raises(RenderError, match=r"photo spp=.* valid: an integer 1\.\.4096") as err:
            PhotoOptions(spp=spp)
        assert "\n" not in str(err.value)


def test_unknown_preset_names_photo_among_the_valid():
    from samplehd.render.renderer import get_preset

    with pytest.raises(RenderError, match="valid: fast, hd, photo"):
        get_preset("photoreal")


def test_missing_llvm_says_what_to_install(monkeypatch):
    from samplehd.render.photo import runtime

    assert runtime.find_llvm(("/nonexistent",)) is None
    assert runtime._llvm_version("/usr/lib/x86_64-linux-gnu/libLLVM-19.so.1") == 19
    assert runtime._llvm_version("/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1") == 19
    assert runtime._llvm_version("/usr/lib/llvm-15/lib/libLLVM-15.so") == 15
    monkeypatch.setenv("SAMPLEHD_PHOTO_VARIANT", "vulkan")
    with pytest.raises(RenderError, match="PHOTO_VARIANT='vulkan' is invalid; valid: llvm_ad_rgb, cuda_ad_rgb"):
        runtime.photo_backend()


def test_env_observes_path_traced_rgb_with_gl_segmentation():
    from samplehd.envs.tabletop import TabletopEnv

    env = TabletopEnv(scene={"min_objects": 2, "max_objects": 2}, num_scenes=1, scene_seed=7, obs_mode="rgbd_seg",
                      cameras=("scene",), width=W, height=H, render_preset="photo")
    try:
        obs, _ = env.reset(seed=1)
        assert obs["scene_rgb"].shape == (H, W, 3) and obs["scene_rgb"].mean() > 30
        assert set(np.unique(obs["scene_segmentation"])) >= {0, 1, 2}
        assert env.observation_space.contains(obs)
    finally:
        env.close()


def test_env_rejects_an_unknown_preset_naming_photo():
    from samplehd.envs.config import EnvConfig
    from samplehd.errors import ConfigError

    with pytest.raises(ConfigError, match="render_preset.*valid: fast, hd, photo"):
        EnvConfig(render_preset="raytraced")


def test_a_fresh_renderer_gives_the_same_image(scene_world, photo):
    """Same scene and state in new renderers (new Mitsuba scenes): the same path-traced radiance, bit for bit
    (the lights' order, which decides the light a random number picks, must not vary), and the same picture
    within the denoiser's tolerance."""
    from samplehd.render.photo import PhotoTracer
    from samplehd.render.renderer import SceneRenderer

    model, data = scene_world
    a = photo.render(data, "scene")["rgb"].astype(int)
    with SceneRenderer(model, W, H, "photo") as fresh:
        b = fresh.render(data, "scene")["rgb"].astype(int)
    d = np.abs(a - b)
    assert d.max() <= 2, (d.max(), d.mean())
    raws = [PhotoTracer(model).radiance(data, 0, W, H) for _ in range(3)]
    assert all(np.array_equal(raws[0], r) for r in raws[1:])


_NOT_A_PRESET = "invalid choice: 'ultra' (choose from 'fast', 'hd', 'photo')"


@pytest.mark.parametrize("argv, msg", [
    (["render", "--preset", "ultra"], _NOT_A_PRESET),
    (["scenes", "--num", "1", "--render-preset", "ultra"], _NOT_A_PRESET),
    (["scenes", "--num", "1", "--preset", "photo", "--photo-look", "sunny"],
     "--photo-look 'sunny' is invalid; valid: fixed, random"),
])
def test_bad_preset_and_photo_options_on_the_command_line(tmp_path, capsys, argv, msg):
    from samplehd.cli import main

    out = tmp_path / "out"
    target = ["--out", str(out / "x.png")] if argv[0] == "render" else ["--out", str(out)]
    try:
        code = main([*argv, *target])
    except SystemExit as exc:  # argparse refuses a name outside the preset list before the command runs
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert msg in err and len(err.splitlines()) == 1, err
    assert not out.exists()  # nothing written


def test_the_gpu_finish_gives_the_cpu_finish_image(scene_world, photo):
    """Clamp → denoise → tone curve as the GPU path runs it (torch tensors handed to Open Image Denoise),
    here on the CPU tensors of the CPU variant: the same picture as the NumPy path, within a level or two."""
    torch = pytest.importorskip("torch", reason="the GPU finish hands frames over as torch tensors")
    from samplehd.render.photo.renderer import _finish_on_gpu

    model, data = scene_world
    want = photo.render(data, "scene")["rgb"]
    tracer = photo._tracer
    got = _finish_on_gpu(tracer.scene.render_tensor(tracer.options.spp, tracer.options.seed), tracer.options, torch)
    assert got.shape == want.shape and got.dtype == np.uint8
    assert np.abs(got.astype(int) - want.astype(int)).max() <= 3
    assert want.std() > 10  # a picture, not a flat field


def test_a_replayed_gpu_frame_is_a_fresh_trace(scene_world, photo):
    """On the GPU the trace is recorded once and replayed: after the arm moves, the replay gives exactly what
    tracing the posed scene anew gives. (Runs where the CUDA variant is in use.)"""
    import mujoco

    from samplehd.render.photo.runtime import photo_backend

    if photo_backend() != "cuda_ad_rgb":
        pytest.skip("the trace is replayed only on an NVIDIA GPU")
    model, data = scene_world
    photo.render(data, "scene")
    scene = photo._tracer.scene
    camera = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "scene")
    moved = mujoco.MjData(model)
    moved.qpos[:] = data.qpos
    for _ in range(3):
        moved.qpos[:6] += 0.1
        mujoco.mj_forward(model, moved)
        scene.pose(moved, camera, W, H)
        replay = np.asarray(scene.render_tensor(1, 0))
        fresh = np.asarray(scene.mi.render(scene.scene, spp=1, seed=0))
        np.testing.assert_array_equal(replay, fresh)

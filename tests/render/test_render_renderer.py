import mujoco
import numpy as np
import pytest

from samplehd.errors import RenderError
from samplehd.render.image_spec import ImageSpec
from samplehd.render.renderer import (
    SEG_BACKGROUND,
    SEG_ROBOT,
    SEG_TABLE,
    SceneRenderer,
    camera_intrinsics,
    project_points,
)
from samplehd.render.renderer_cache import RendererCache
from samplehd.world.layout import LAYOUT

pytestmark = pytest.mark.render


@pytest.fixture(scope="module")
def fast_images(world):
    model, data = world
    with SceneRenderer(model, 320, 180, "fast") as r:
        return r.render(data, "operator", ("rgb", "depth", "segmentation"))


def test_shapes_and_types(fast_images):
    assert fast_images["rgb"].shape == (180, 320, 3) and fast_images["rgb"].dtype == np.uint8
    assert fast_images["depth"].shape == (180, 320) and fast_images["depth"].dtype == np.float32
    assert fast_images["segmentation"].dtype == np.int32


def test_segmentation_sees_table_robot_background(fast_images):
    ids = set(np.unique(fast_images["segmentation"]).tolist())
    assert {SEG_BACKGROUND, SEG_TABLE, SEG_ROBOT} <= ids


def test_depth_is_metric_at_table_centre(world, fast_images):
    model, data = world
    # The pixel where the workspace centre projects must see the table at the projected depth.
    c = LAYOUT.workspace_center
    u, v, z = project_points(model, data, "operator", 320, 180, np.array([[c[0], c[1] + 0.25, LAYOUT.table_height]]))[0]
    assert fast_images["segmentation"][int(v), int(u)] == SEG_TABLE
    assert fast_images["depth"][int(v), int(u)] == pytest.approx(z, abs=0.01)


def test_one_pass_depth_equals_segmentation_pass_depth(world, fast_images):
    model, data = world
    with SceneRenderer(model, 320, 180, "fast") as r:
        depth_rgb_pass = r.render(data, "operator", ("rgb", "depth"))["depth"]
    np.testing.assert_allclose(depth_rgb_pass, fast_images["depth"], atol=1e-5)


def test_hd_segmentation_has_only_valid_ids_despite_msaa(world):
    model, data = world
    with SceneRenderer(model, 320, 180, "hd") as r:
        out = r.render(data, "operator", ("rgb", "segmentation"))
    assert set(np.unique(out["segmentation"]).tolist()) <= {SEG_BACKGROUND, SEG_TABLE, SEG_ROBOT}
    assert out["rgb"].std() > 10


def test_render_is_deterministic(world, fast_images):
    model, data = world
    with SceneRenderer(model, 320, 180, "fast") as r:
        again = r.render(data, "operator", ("rgb",))["rgb"]
    np.testing.assert_array_equal(again, fast_images["rgb"])


def test_wrist_camera_renders(world):
    model, data = world
    with SceneRenderer(model, 160, 90, "fast") as r:
        assert r.render(data, "wrist", ("rgb",))["rgb"].shape == (90, 160, 3)


def test_unknown_camera_lists_valid_names(world):
    model, data = world
    with SceneRenderer(model, 64, 64, "fast") as r:
        with pytest.raises(RenderError, match="unknown camera 'nope'; valid: operator"):
            r.render(data, "nope")


def test_bad_preset_modality_and_resolution(world):
    model, data = world
    with pytest.raises(RenderError, match="unknown render preset 'ultra'; valid: fast, hd"):
        SceneRenderer(model, 64, 64, "ultra")
    with pytest.raises(RenderError, match="resolution"):
        SceneRenderer(model, 0, 64)
    with SceneRenderer(model, 64, 64) as r, pytest.raises(RenderError, match="valid: rgb, depth, segmentation"):
        r.render(data, "operator", ("normals",))


def test_intrinsics_match_projection(world):
    model, data = world
    k = camera_intrinsics(model, "operator", 640, 360)
    assert k[0, 2] == 320 and k[1, 2] == 180
    cam_pos = data.cam_xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "operator")]
    fwd = -data.cam_xmat[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "operator")].reshape(3, 3)[:, 2]
    u, v, z = project_points(model, data, "operator", 640, 360, cam_pos + 2.0 * fwd)[0]
    assert (u, v, z) == pytest.approx((320, 180, 2.0))


def test_a_larger_buffer_renders_the_same_images_at_each_size(world, fast_images):
    model, data = world
    with SceneRenderer(model, 160, 90, "fast", buffer_size=(320, 180)) as r:
        small = r.render(data, "operator", ("segmentation", "depth"))
        r.resize(320, 180)
        full = r.render(data, "operator", ("depth", "segmentation"))
        with pytest.raises(RenderError, match="exceeds this renderer's buffer 320x180"):
            r.resize(640, 360)
    assert small["segmentation"].shape == (90, 160)
    with SceneRenderer(model, 160, 90, "fast") as r:
        np.testing.assert_array_equal(r.render(data, "operator", ("segmentation",))["segmentation"],
                                      small["segmentation"])
    np.testing.assert_array_equal(full["segmentation"], fast_images["segmentation"])
    np.testing.assert_array_equal(full["depth"], fast_images["depth"])


def test_renderer_cache_reuses_a_renderer_only_for_the_same_model_and_preset(world):
    model, data = world
    with RendererCache(buffer_size=(320, 180)) as cache:
        a = cache.get(model, ImageSpec(160, 90, "fast"))
        assert cache.get(model, ImageSpec(320, 180, "fast")) is a and (a.width, a.height) == (320, 180)
        b = cache.get(model, ImageSpec(320, 180, "hd"))  # another preset: a new renderer, the old one freed
        assert b is not a and a._ctx is None
        c = cache.get(model, ImageSpec(400, 200, "hd"))  # larger than the buffer
        assert c is not b and c.buffer_size == (400, 200)
        assert c.render(data, "operator", ("rgb",))["rgb"].shape == (200, 400, 3)
    assert c._ctx is None


def test_a_renderer_still_renders_new_states_after_another_renderer_is_closed(world):
    """Closing one renderer must not leave another reading back a stale frame."""
    import mujoco

    model, data = world
    keep = SceneRenderer(model, 64, 48, "fast")
    try:
        before = keep.render(data, "operator", ("segmentation",))["segmentation"]
        with SceneRenderer(model, 64, 48, "fast") as other:
            other.render(data, "operator", ("segmentation",))
        moved = mujoco.MjData(model)
        moved.qpos[:] = data.qpos
        moved.qpos[:6] += 0.6  # swing the arm
        mujoco.mj_forward(model, moved)
        after = keep.render(moved, "operator", ("segmentation",))["segmentation"]
        with SceneRenderer(model, 64, 48, "fast") as fresh:
            want = fresh.render(moved, "operator", ("segmentation",))["segmentation"]
        np.testing.assert_array_equal(after, want)
        assert (after != before).any()
    finally:
        keep.close()


def test_rendering_into_given_arrays_gives_the_same_images(world, fast_images):
    model, data = world
    out = {"rgb": np.zeros((180, 320, 3), np.uint8), "depth": np.zeros((180, 320), np.float32),
           "segmentation": np.zeros((180, 320), np.int32)}
    with SceneRenderer(model, 320, 180, "fast") as r:
        got = r.render(data, "operator", ("rgb", "depth", "segmentation"), out=out)
        assert all(got[m] is out[m] for m in out)
        for m, want in fast_images.items():
            np.testing.assert_array_equal(out[m], want)
        wrong = r"out\['depth'\]: needs a \(180, 320\) float32 array, got \(180, 320\) float64"
        with pytest.raises(RenderError, match=wrong):
            r.render(data, "operator", ("depth",), out={"depth": np.zeros((180, 320))})
        with pytest.raises(RenderError, match=r"out\['rgb'\]: needs a \(180, 320, 3\) uint8 array, got nothing"):
            r.render(data, "operator", ("rgb",), out={})
        for dtype in (np.uint8, np.uint16):  # the dtypes episode files store segmentation in
            seg = np.zeros((180, 320), dtype)
            r.render(data, "operator", ("segmentation",), out={"segmentation": seg})
            np.testing.assert_array_equal(seg, fast_images["segmentation"])
        wrong = r"out\['segmentation'\]: needs a \(180, 320\) int32 or uint8 or uint16 array, got \(180, 320\) int16"
        with pytest.raises(RenderError, match=wrong):
            r.render(data, "operator", ("segmentation",), out={"segmentation": np.zeros((180, 320), np.int16)})


def test_segmentation_ids_decode_all_three_colour_bytes(world):
    """The id pass encodes scene geom index + 1 as r + 256 g + 65536 b (0: nothing drawn); each pixel gets
    its geom's class, rows flipped to run from the top (any colour, the blue byte included)."""
    model, data = world
    with SceneRenderer(model, 16, 8, "fast") as r:
        r.render(data, "operator", ("segmentation",))  # fills the scene's geoms
        n = r._scene.ngeom
        rng = np.random.default_rng(0)
        idcolor = rng.integers(0, 256, (8, 16, 3), dtype=np.uint8)
        idcolor[..., 1] = rng.integers(0, 2, (8, 16))
        idcolor[..., 2] = 0
        idcolor[0, :4] = [(1, 0, 0), (n % 256, n // 256, 0), (0, 0, 0), (1, 0, 1)]  # first, last, none, past all
        seg = np.full((8, 16), -1, np.int32)
        r._segment_ids(idcolor, seg)
        geoms = r._scene.geoms
        table = np.array([SEG_BACKGROUND] + [r._lut[geoms[i].objid] for i in range(n)], np.int32)
        code = idcolor[..., 0].astype(np.int64) + (idcolor[..., 1].astype(np.int64) << 8) + (
            idcolor[..., 2].astype(np.int64) << 16)
        np.testing.assert_array_equal(seg, table[np.minimum(code, n)][::-1])
        assert seg[7, 2] == SEG_BACKGROUND and seg[7, 3] == table[n]  # past every geom: clipped to the last


def test_gl_device_names_vendor_and_renderer():
    from samplehd.render.renderer import gl_device

    vendor, renderer = gl_device().split(", ", 1)
    assert vendor and renderer and "?" not in (vendor, renderer)

import mujoco
import numpy as np
import pytest

from samplehd.errors import ConfigError
from samplehd.scene.mjcf import export_mjcf
from samplehd.scene.world import CameraSpec, WorldConfig, build_world
from samplehd.world.layout import LAYOUT, table_parts_of


def _name(model, objtype, i):
    return mujoco.mj_id2name(model, objtype, i)


def test_world_has_named_parts(world):
    model, data = world
    geoms = {_name(model, mujoco.mjtObj.mjOBJ_GEOM, i) for i in range(model.ngeom)}
    assert {"floor", "table_top", "backdrop_wall", "backdrop_countertop"} <= geoms
    cams = {_name(model, mujoco.mjtObj.mjOBJ_CAMERA, i) for i in range(model.ncam)}
    assert {"operator", "wrist"} <= cams
    assert model.opt.timestep == pytest.approx(0.002)
    joints = [_name(model, mujoco.mjtObj.mjOBJ_JOINT, i) for i in range(model.njnt)]
    for j in ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
              "wrist_3_joint"):
        assert j in joints


def test_table_top_at_layout_height(world):
    model, data = world
    gid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "table_top")
    top = data.geom_xpos[gid][2] + model.geom_size[gid][2]
    assert top == pytest.approx(LAYOUT.table_height)


def test_world_settles_without_contacts_with_robot_at_rest(world):
    model, _ = world
    data = mujoco.MjData(model)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_step(model, data, 500)
    assert np.all(np.isfinite(data.qpos))


def _mjb(model) -> bytes:
    buf = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buf)
    return buf.tobytes()


def test_build_is_deterministic():
    assert _mjb(build_world().compile()) == _mjb(build_world().compile())


def test_bad_world_config_is_one_line_error():
    with pytest.raises(ConfigError, match="timestep"):
        WorldConfig(timestep=0.5)
    with pytest.raises(ConfigError, match="world.sleep"):
        WorldConfig(sleep="yes")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="fovy"):
        CameraSpec("c", (1, 0, 1), (0, 0, 0), fovy=0.0)


def test_table_parts_with_neutral_band():
    c = LAYOUT.workspace_center
    assert table_parts_of((c[0], c[1])) == []
    assert table_parts_of((c[0] + 0.1, c[1] - 0.2)) == ["left", "front"]
    assert table_parts_of((c[0] - 0.1, c[1] + 0.2)) == ["right", "back"]


def test_export_mjcf_opens_in_mujoco(tmp_path):
    path = export_mjcf(build_world(), tmp_path / "world.xml")
    model = mujoco.MjModel.from_xml_path(str(path))
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "tcp") >= 0
    assert model.ntex >= 3


def test_export_mjcf_writes_meshes_beside_the_xml(tmp_path):
    """The robot's and the objects' meshes go to .msh files in ``<stem>_assets/`` (the XML stays small), and
    the loaded model has the compiled meshes bit for bit."""
    from samplehd.catalogue import ObjectInstance
    from samplehd.scene.world import PlacedObject

    mug = PlacedObject(ObjectInstance("mug", "shopvrb1", "red", "ceramic", "medium"), (0.1, 0.1, LAYOUT.table_height),
                       (1.0, 0.0, 0.0, 0.0))
    spec = build_world([mug])
    ref = spec.copy().compile()
    path = export_mjcf(spec, tmp_path / "world.xml")
    meshes = sorted((tmp_path / "world_assets").glob("*.msh"))
    assert len(meshes) == ref.nmesh and path.stat().st_size < 100_000
    assert 'file="world_assets/' in path.read_text() and str(tmp_path) not in path.read_text()
    model = mujoco.MjModel.from_xml_path(str(path))
    for field in ("mesh_vert", "mesh_face", "mesh_normal", "mesh_texcoord", "mesh_facetexcoord", "mesh_graph"):
        np.testing.assert_array_equal(getattr(model, field), getattr(ref, field), err_msg=field)

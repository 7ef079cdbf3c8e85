"""MuJoCo's sleeping islands in the worlds: resting objects sleep, their contacts stay visible to the
task code, and everything that lets go of an object (the gripper opening, the grasp weld switching
off, the checker's settling window) wakes it so that it does not stay asleep in the air."""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import mujoco
import numpy as np
import pytest

from samplehd.motion.assist import GraspAssist, compile_scene_with_assist
from samplehd.motion.execute import initial_state
from samplehd.physics import awake_contacts, wake_all
from samplehd.robot.constants import HOME_QPOS
from samplehd.robot.controller import ControlConfig, RobotController
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import sample_scene
from samplehd.scene.spec import SceneSpec, compile_scene, object_qpos_addresses
from samplehd.tasks.checker import _simulate_window
from samplehd.world.bodies import SceneBodies, contact_pairs, object_body_name
from samplehd.world.seeding import scene_seed

_SLEEP = int(mujoco.mjtEnableBit.mjENBL_SLEEP)


@pytest.fixture(scope="module")
def scene() -> SceneSpec:
    """A sampled scene (settled poses on the table). Procedural: the helpers need object 0 of this seed's
    scene to fall asleep within 100 steps held by its weld, which the shop-vrb scene's object 0 does not."""
    return sample_scene(0, scene_seed(7, 0), SceneConfig(catalogue="procedural")).scene


def _object_trees(model: mujoco.MjModel, n: int) -> np.ndarray:
    return np.array([model.body_treeid[model.body(object_body_name(i)).id] for i in range(n)])


def _fresh(scene: SceneSpec) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The compiled scene with the arm at home and the gripper open (sleep enabled)."""
    model, data = compile_scene(scene)
    assert model.opt.enableflags & _SLEEP, "worlds are built with sleep enabled by default"
    initial_state(model, data, ControlConfig())
    return model, data


def _step_until_objects_sleep(model: mujoco.MjModel, data: mujoco.MjData, trees: np.ndarray,
                              max_steps: int = 1000) -> None:
    for _ in range(max_steps):
        if np.all(data.tree_asleep[trees] >= 0):
            return
        mujoco.mj_step(model, data)
    pytest.fail(f"objects did not fall asleep in {max_steps} steps: tree_asleep={data.tree_asleep}")


def _hovering_asleep(scene: SceneSpec, i: int, lift: float = 0.10) -> tuple[mujoco.MjModel, mujoco.MjData, float]:
    """Object ``i`` held still ``lift`` above its rest pose by its grasp weld, then the weld switched
    off by hand (no wake): the object counted down to sleep while held and is asleep in the air.

    Returns (model with the grasp welds, data, the object's z while held)."""
    model, data = compile_scene_with_assist(scene)
    initial_state(model, data, ControlConfig())
    n = len(scene.objects)
    adr = object_qpos_addresses(model, n)
    data.qpos[adr[i] + 2] += lift
    mujoco.mj_forward(model, data)
    assist = GraspAssist(model, n)
    assert assist.attach(data, i)
    mujoco.mj_step(model, data, 100)
    z_held = float(data.qpos[adr[i] + 2])
    data.eq_active[assist.eq[i]] = 0
    mujoco.mj_step(model, data)
    tree = _object_trees(model, n)[i]
    assert data.tree_asleep[tree] >= 0, "a still object released without waking is asleep"
    return model, data, z_held


def test_resting_objects_sleep_and_contact_pairs_still_sees_the_table(scene: SceneSpec) -> None:
    model, data = _fresh(scene)
    n = len(scene.objects)
    trees = _object_trees(model, n)
    _step_until_objects_sleep(model, data, trees)
    mujoco.mj_step(model, data)  # the step after falling asleep runs no collisions for them
    assert np.all(data.tree_asleep[trees] >= 0)
    assert data.ntree_awake < model.ntree
    bodies = SceneBodies(model, n)
    table = bodies.table_body

    # Sleeping bodies have no contacts in data.contact ...
    raw = {(int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])) for c in data.contact[: data.ncon]}
    for b in bodies.object_body:
        assert (table, int(b)) not in raw and (int(b), table) not in raw

    # ... but contact_pairs reports every object on the table, as on the same state without sleep.
    asleep_before = data.tree_asleep.copy()
    ncon_before = data.ncon
    pairs = contact_pairs(model, data)
    for b in bodies.object_body:
        assert (min(table, int(b)), max(table, int(b))) in pairs

    awake_model, _ = compile_scene(scene)
    awake_model.opt.enableflags &= ~_SLEEP
    awake = mujoco.MjData(awake_model)
    awake.qpos[:] = data.qpos
    awake.act[:] = data.act
    awake.ctrl[:] = data.ctrl
    mujoco.mj_forward(awake_model, awake)
    assert awake.ntree_awake == awake_model.ntree
    assert pairs == contact_pairs(awake_model, awake)

    # The contacts were computed on a copy: the sleeping data is untouched.
    assert awake_contacts(model, data) is not data
    np.testing.assert_array_equal(data.tree_asleep, asleep_before)
    assert data.ncon == ncon_before


def test_awake_contacts_returns_the_data_itself_when_all_is_awake(scene: SceneSpec) -> None:
    model, data = _fresh(scene)
    assert data.ntree_awake == model.ntree
    assert awake_contacts(model, data) is data


_FLOATING_BOX = """
<mujoco>
  <option timestep="0.002"><flag sleep="enable"/></option>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="box" pos="0 0 0.3">
      <freejoint/>
      <geom type="box" size="0.03 0.03 0.03" mass="0.2"/>
    </body>
  </worldbody>
  <equality><weld name="hold" body1="box"/></equality>
</mujoco>
"""


@pytest.mark.parametrize("wake", [False, True])
def test_body_asleep_in_the_air_falls_only_after_wake_all(wake: bool) -> None:
    model = mujoco.MjModel.from_xml_string(_FLOATING_BOX)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 100)  # held still by the weld: counts down and sleeps in the air
    assert data.tree_asleep[0] >= 0
    z_held = float(data.qpos[2])
    assert z_held > 0.25
    data.eq_active[0] = 0  # let go
    if wake:
        wake_all(data)
    mujoco.mj_step(model, data, 300)
    if wake:
        assert data.qpos[2] == pytest.approx(0.03, abs=2e-3)  # fell onto the floor
        assert data.tree_asleep[0] >= 0  # and went back to sleep there
    else:
        assert data.tree_asleep[0] >= 0
        assert float(data.qpos[2]) == z_held  # still hovering, untouched


def test_grasp_assist_release_wakes_the_held_object(scene: SceneSpec) -> None:
    n = len(scene.objects)
    model, data, z_held = _hovering_asleep(scene, 0)
    adr = object_qpos_addresses(model, n)
    # The bug: switching the weld off alone leaves the object asleep in the air.
    mujoco.mj_step(model, data, 200)
    assert float(data.qpos[adr[0] + 2]) == z_held

    model, data, z_held = _hovering_asleep(scene, 0)
    assist = GraspAssist(model, n)
    assist.release(data)
    mujoco.mj_step(model, data)
    assert data.tree_asleep[_object_trees(model, n)[0]] < 0
    mujoco.mj_step(model, data, 300)
    z_rest = scene.objects[0].pos[2]
    assert float(data.qpos[adr[0] + 2]) == pytest.approx(z_rest, abs=5e-3)
    assert z_held - float(data.qpos[adr[0] + 2]) > 0.09


def test_checker_window_wakes_an_object_asleep_in_the_air(scene: SceneSpec) -> None:
    n = len(scene.objects)
    model, data, z_held = _hovering_asleep(scene, 0)
    adr = object_qpos_addresses(model, n)
    asleep_before = data.tree_asleep.copy()
    end = _simulate_window(model, data, 0.5)
    assert float(end.qpos[adr[0] + 2]) == pytest.approx(scene.objects[0].pos[2], abs=5e-3)
    # The window ran on a copy.
    assert float(data.qpos[adr[0] + 2]) == z_held
    np.testing.assert_array_equal(data.tree_asleep, asleep_before)


def test_wake_all_on_awake_data_changes_nothing(scene: SceneSpec) -> None:
    model, data = _fresh(scene)
    n = len(scene.objects)
    adr = object_qpos_addresses(model, n)
    for a in adr:
        data.qpos[a + 2] += 0.02  # falling objects stay awake
    mujoco.mj_forward(model, data)
    mujoco.mj_step(model, data, 2)
    assert data.ntree_awake == model.ntree
    woken = mujoco.MjData(model)
    mujoco.mj_copyData(woken, model, data)
    wake_all(woken)
    assert woken.ntree_awake == model.ntree
    for _ in range(20):
        mujoco.mj_step(model, data)
        mujoco.mj_step(model, woken)
        assert data.ntree_awake == model.ntree
        np.testing.assert_array_equal(woken.qpos, data.qpos)
        np.testing.assert_array_equal(woken.qvel, data.qvel)


def test_wake_all_wakes_every_sleeping_tree(scene: SceneSpec) -> None:
    model, data = _fresh(scene)
    trees = _object_trees(model, len(scene.objects))
    _step_until_objects_sleep(model, data, trees)
    qpos = data.qpos.copy()
    wake_all(data)
    mujoco.mj_step(model, data)
    assert data.ntree_awake == model.ntree
    assert np.all(data.tree_asleep < 0)
    # Resting objects stay where they were (to within the settling jitter).
    np.testing.assert_allclose(data.qpos, qpos, atol=1e-4)


def test_controller_wakes_sleeping_objects_when_the_gripper_opens(scene: SceneSpec) -> None:
    model, data = compile_scene(scene)
    trees = _object_trees(model, len(scene.objects))
    ctrl = RobotController(model, data, ControlConfig())
    ctrl.reset(HOME_QPOS, gripper=-1.0)
    for _ in range(10):
        ctrl.advance()
    _step_until_objects_sleep(model, data, trees)
    closed = np.r_[HOME_QPOS, -1.0]
    opened = np.r_[HOME_QPOS, 1.0]

    # Keeping the gripper closed wakes nothing.
    ctrl.command(closed)
    mujoco.mj_step(model, data)
    assert np.all(data.tree_asleep[trees] >= 0)

    # Opening it wakes every tree on the next physics step.
    ctrl.command(opened)
    mujoco.mj_step(model, data)
    assert data.ntree_awake == model.ntree
    assert np.all(data.tree_asleep[trees] < 0)

    # Once open, an unchanged command wakes nothing: the objects fall asleep again.
    _step_until_objects_sleep(model, data, trees)
    ctrl.command(opened)
    mujoco.mj_step(model, data)
    assert np.all(data.tree_asleep[trees] >= 0)


def test_stepping_with_sleep_is_deterministic(scene: SceneSpec) -> None:
    def run() -> tuple[np.ndarray, np.ndarray, int]:
        model, data = _fresh(scene)
        adr = object_qpos_addresses(model, len(scene.objects))
        data.qpos[adr[0] + 2] += 0.03  # one object drops onto the table
        mujoco.mj_forward(model, data)
        mujoco.mj_step(model, data, 200)
        wake_all(data)
        mujoco.mj_step(model, data, 200)
        return data.qpos.copy(), data.tree_asleep.copy(), int(data.ntree_awake)

    q1, asleep1, awake1 = run()
    q2, asleep2, awake2 = run()
    np.testing.assert_array_equal(q1, q2)
    np.testing.assert_array_equal(asleep1, asleep2)
    assert awake1 == awake2
    assert np.any(asleep1 >= 0), "the run exercised sleep"

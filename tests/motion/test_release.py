"""OpenGripper from a weld, in real physics: with ``open_gently`` the first control step only just passes the
command that releases the weld, then the fingers open as planned; the subtask keeps its length. The oracle
opens gently only where the gripper still touches the object (``Rollout.gripper_touches``)."""

from __future__ import annotations

import numpy as np
import pytest

from samplehd.motion.assist import RELEASE_MARGIN
from samplehd.robot.constants import GRIPPER_STROKE


def _rollout(scene, gently: bool = False):
    from samplehd.motion.assist import compile_scene_with_assist
    from samplehd.motion.execute import Rollout, initial_state, scene_facts
    from samplehd.robot.controller import ControlConfig
    from samplehd.world.bodies import SceneBodies
    from samplehd.world.planner_config import PlannerConfig
    from samplehd.world.robot_info import RobotInfo

    model, data = compile_scene_with_assist(scene)
    ctrl = initial_state(model, data, ControlConfig())
    return Rollout(model, data, ctrl, RobotInfo.from_model(model, data), SceneBodies(model, len(scene.objects)),
                   scene_facts(scene), PlannerConfig(), np.random.default_rng(0), open_gently=gently)


def _open_from_weld(scene, gently: bool) -> tuple[list[float], list[int], int]:
    """Weld object 1 to the gripper at home and open it; returns the commands sent, the welded object
    after each step, and the steps OpenGripper should take."""
    from samplehd.motion.execute import drive, step_controller
    from samplehd.world.planner_config import PlannerConfig

    ro = _rollout(scene, gently)
    ctrl, data = ro.ctrl, ro.data
    ro.assist.attach(data, 1)
    ro.assist.attach_command = -0.7  # the fingers closed on about 13 mm
    commands: list[float] = []
    welded: list[int] = []

    def step(target):
        commands.append(target.gripper)
        report = step_controller(ctrl, target)
        welded.append(ro.assist.active)
        return report

    drive(ro.open_gripper(1, 0.034, gently=gently), step)
    return commands, welded, int(round(PlannerConfig().open_time / ctrl.config.control_dt))


@pytest.mark.parametrize("gently", [False, True])
def test_open_gripper_releases_the_weld_in_its_first_step(scene, gently: bool) -> None:
    commands, welded, steps = _open_from_weld(scene, gently)
    full = 2.0 * 0.034 / GRIPPER_STROKE - 1.0
    assert len(commands) == steps and welded == [-1] * steps
    assert commands[1:] == pytest.approx([full] * (steps - 1))
    if gently:  # just past the release (one margin beyond the weld's command), well short of the opening
        assert -0.7 + RELEASE_MARGIN < commands[0] <= -0.7 + 1.25 * RELEASE_MARGIN + 1e-9 < full
    else:
        assert commands[0] == pytest.approx(full)


def test_gripper_touches_reads_the_contacts_of_the_gripper_with_the_object(scene) -> None:
    import mujoco

    ro = _rollout(scene)
    assert not any(ro.gripper_touches(i) for i in range(len(scene.objects)))  # at home, nothing in the hand
    m, d = ro.model, ro.data
    pad = next(g for g in range(m.ngeom) if m.geom_bodyid[g] == ro.finger_bodies[0] and m.geom_contype[g])
    adr = m.jnt_qposadr[m.body_jntadr[ro.bodies.object_body[1]]]
    d.qpos[adr:adr + 3] = d.geom_xpos[pad] - [0.0, 0.0, 0.05]  # the can (origin at its base) around the pad
    mujoco.mj_forward(m, d)
    assert ro.gripper_touches(1) and not ro.gripper_touches(0)

"""OpenGripper from a weld, in real physics: with ``open_gently`` the first control step only just passes the
command that releases the weld, then the fingers open as planned; the subtask keeps its length."""

from __future__ import annotations

import numpy as np
import pytest

from samplehd.motion.assist import RELEASE_MARGIN
from samplehd.robot.constants import GRIPPER_STROKE


def _open_from_weld(scene, gently: bool) -> tuple[list[float], list[int], int]:
    """Weld object 1 to the gripper at home and open it; returns the commands sent, the welded object
    after each step, and the steps OpenGripper should take."""
    from samplehd.motion.assist import compile_scene_with_assist
    from samplehd.motion.execute import Rollout, drive, initial_state, scene_facts, step_controller
    from samplehd.robot.controller import ControlConfig
    from samplehd.world.bodies import SceneBodies
    from samplehd.world.planner_config import PlannerConfig
    from samplehd.world.robot_info import RobotInfo

    model, data = compile_scene_with_assist(scene)
    ctrl = initial_state(model, data, ControlConfig())
    ro = Rollout(model, data, ctrl, RobotInfo.from_model(model, data), SceneBodies(model, len(scene.objects)),
                 scene_facts(scene), PlannerConfig(), np.random.default_rng(0), open_gently=gently)
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

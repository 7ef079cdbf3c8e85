"""Records one :data:`~samplehd.record.episode.FRAME_FIELDS` frame per control step.

A frame pairs the state observed at the start of a control step with the command issued in that
step (joint targets, gripper command and the SAMPLE-HD steering vector that produces the same TCP
motion), as a policy would see and act. The last frame holds the final state with a hold command.

:class:`RecordingStep` wraps the step function that drives a plan's control targets
(:func:`samplehd.motion.execute.drive`): it records the frame, then steps. :class:`ActionStep`
executes each target as the environment executes the recorded action instead (the grasp rule with
the steering vector's gripper command, then the controller in steering mode), so that the recorded
actions replay bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import mujoco
import numpy as np

from samplehd.motion.assist import GraspAssist
from samplehd.motion.execute import ControlTarget, SubtaskCut
from samplehd.record.episode import FRAME_FIELDS
from samplehd.render.states import LiveStates
from samplehd.robot.controller import ControlReport, RobotController
from samplehd.world.bodies import grasped_object

__all__ = [
    "ActionStep",
    "FrameRecorder",
    "RecordingStep",
]


class FrameRecorder:
    """Accumulates per-frame records of one rollout.

    Args:
        model: compiled world.
        data: its live data (read, never written).
        arm_qpos: qpos addresses of the arm joints.
        arm_dof: dof addresses of the arm joints.
        finger_qpos: qpos addresses of the two finger joints.
        finger_bodies: body ids of the two fingers.
        tcp_site: id of the TCP site.
        object_bodies: body ids of the scene objects, in scene order.
        live: where each recorded state also goes, for rendering beside the rollout.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, arm_qpos: np.ndarray, arm_dof: np.ndarray,
                 finger_qpos: np.ndarray, finger_bodies: tuple[int, int], tcp_site: int,
                 object_bodies: np.ndarray, live: LiveStates | None = None) -> None:
        self.model, self.data = model, data
        self.arm_qpos, self.arm_dof, self.finger_qpos = arm_qpos, arm_dof, finger_qpos
        self.finger_bodies = finger_bodies
        self.tcp_site = tcp_site
        self.object_bodies = np.asarray(object_bodies)
        self.body_to_object = {int(b): i for i, b in enumerate(self.object_bodies)}
        self.rows: dict[str, list[np.ndarray]] = {k: [] for k in FRAME_FIELDS}
        self.live = live

    def __len__(self) -> int:
        return len(self.rows["time"])

    def record(self, subtask_index: int, progress: float, target_object: int, command_joint_pos: np.ndarray,
               gripper_command: float, steering: np.ndarray, safety_code: int = 0, held: int | None = None) -> int:
        """Append the current state with the command of this step; returns the grasped object.

        ``held`` overrides the contact test (the object the grasp assist holds); by default the
        grasped object is the one touching both fingers.
        """
        d = self.data
        # After mj_step, positions derived from qpos lag one step behind it; recompute them so the
        # recorded poses are exactly those a replay of the recorded qpos produces.
        mujoco.mj_kinematics(self.model, d)
        r = self.rows
        tcp_quat = np.empty(4)
        mujoco.mju_mat2Quat(tcp_quat, d.site_xmat[self.tcp_site])
        grasped = held if held is not None else grasped_object(self.model, d, self.finger_bodies, self.body_to_object)
        r["time"].append(np.float64(d.time))
        r["subtask_index"].append(np.int16(subtask_index))
        r["subtask_progress"].append(np.float32(progress))
        r["target_object"].append(np.int16(target_object))
        r["joint_pos"].append(d.qpos[self.arm_qpos].copy())
        r["joint_vel"].append(d.qvel[self.arm_dof].copy())
        r["gripper_opening"].append(np.float32(d.qpos[self.finger_qpos].sum()))
        r["gripper_command"].append(np.float32(gripper_command))
        r["command_joint_pos"].append(np.asarray(command_joint_pos, dtype=np.float64).copy())
        r["tcp_pos"].append(d.site_xpos[self.tcp_site].copy())
        r["tcp_quat"].append(tcp_quat)
        r["steering"].append(np.asarray(steering, dtype=np.float32))
        r["object_pos"].append(d.xpos[self.object_bodies].copy())
        r["object_quat"].append(d.xquat[self.object_bodies].copy())
        r["grasped_object"].append(np.int16(grasped))
        r["safety_event"].append(np.int8(safety_code))
        r["qpos"].append(d.qpos.copy())
        r["qvel"].append(d.qvel.copy())
        r["act"].append(d.act.copy())
        if self.live is not None:
            self.live.put(r["qpos"][-1], r["qvel"][-1], r["act"][-1], r["time"][-1])
        return grasped

    def record_target(self, target: ControlTarget, safety_code: int = 0) -> int:
        """Append the current state with a planner's control target; returns the grasped object."""
        return self.record(target.subtask, target.progress, target.target_object, target.joints, target.gripper,
                           target.steering, safety_code, held=target.held)

    def cut(self, steps: int) -> None:
        """The subtask of the last ``steps`` frames ended early: their progress runs from 0 to 1."""
        self.rows["subtask_progress"][-steps:] = [np.float32(j / max(1, steps - 1)) for j in range(steps)]

    def frames(self) -> dict[str, np.ndarray]:
        """The recorded frames as arrays with the dtypes of :data:`FRAME_FIELDS`."""
        out = {}
        for k, (shape, dtype) in FRAME_FIELDS.items():
            rows = self.rows[k]
            if rows:
                out[k] = np.asarray(np.stack(rows), dtype=dtype)
            else:
                dims = {"N": len(self.object_bodies), "nq": self.model.nq, "nv": self.model.nv, "na": self.model.na}
                out[k] = np.zeros((0, *(dims[s] if isinstance(s, str) else s for s in shape)), dtype=dtype)
        return out


class RecordingStep:
    """A step function that records a frame before it executes each control target.

    Args:
        recorder: where frames go.
        step: the step that executes a target (e.g. :func:`samplehd.motion.execute.step_controller`
            bound to a controller); its report's safety event is written into the frame.
    """

    def __init__(self, recorder: FrameRecorder, step: Callable[[ControlTarget], ControlReport]) -> None:
        self.recorder = recorder
        self.step = step

    def __call__(self, item: ControlTarget | SubtaskCut) -> ControlReport | None:
        if isinstance(item, SubtaskCut):
            self.recorder.cut(item.steps)
            return None
        self.recorder.record_target(item)
        report = self.step(item)
        if report.safety_event is not None:
            self.recorder.rows["safety_event"][-1] = np.int8(report.safety_event.code)
        return report


class ActionStep(RecordingStep):
    """A step function that executes each target as the environment executes the recorded action.

    The environment replays a recording (``samplehd validate --replay``) by sending each frame's
    float32 steering vector: its step applies the grasp rule with the vector's gripper command, then
    the controller turns the vector into a joint target. A rollout that steps this way executes
    exactly what it records, so the replay reproduces its states bit for bit, where the planner's
    float64 joint targets (:class:`RecordingStep` with
    :func:`~samplehd.motion.execute.step_controller`) differ from the vectors' by ~1e-7 rad: enough
    for fingers that push an object (a missed grasp, a re-grasp of a thin object) to leave it
    elsewhere in the replay.

    The rule is applied before the frame is recorded, so the frame's ``grasped_object`` is the object
    welded in its step, as the rollout's own rule records it.

    Args:
        recorder: where frames go.
        controller: the robot controller that steps the physics.
        assist: the grasp assist the step applies (None: no grasp assist); the rollout must not
            apply it too (``Rollout(use_assist=False, step_assist=assist)``).
        events: where each weld and release is noted (``{"object", "frame", "on"}``), as the
            rollout notes its own (its ``info["assist"]``).
    """

    def __init__(self, recorder: FrameRecorder, controller: RobotController, assist: GraspAssist | None,
                 events: list[dict[str, Any]] | None = None) -> None:
        super().__init__(recorder, self._execute)
        self.controller = controller
        self.assist = assist
        self.events = events if events is not None else []

    def _execute(self, target: ControlTarget) -> ControlReport:
        return self.controller.step(np.asarray(target.steering, dtype=np.float32).astype(float), "steering")

    def __call__(self, item: ControlTarget | SubtaskCut) -> ControlReport | None:
        if isinstance(item, ControlTarget) and self.assist is not None:
            assist = self.assist
            before = assist.active
            command = float(np.float32(item.steering[6]))
            after = assist.update(self.recorder.data, command, self.controller.stopped is not None)
            if after != before:
                self.events.append({"object": max(before, after), "frame": len(self.recorder), "on": after >= 0})
            item = replace(item, held=after if after >= 0 else None)
        return super().__call__(item)

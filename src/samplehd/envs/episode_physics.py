"""One episode's simulation in the tabletop environment: the compiled scene's state, the robot
controller, the grasp assist, and the cheap and full success checks on the state.

:class:`~samplehd.envs.tabletop.TabletopEnv` keeps the Gymnasium contract (spaces, action checks,
reward, termination, info) and makes one :class:`EpisodePhysics` per episode.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import mujoco
import numpy as np

from samplehd.envs.episodes import EpisodeSpec
from samplehd.motion.assist import GraspAssist
from samplehd.motion.execute import initial_state
from samplehd.robot.controller import ControlConfig
from samplehd.tasks.checker import CheckerConfig, check_success
from samplehd.tasks.task import Task, get_family
from samplehd.world.bodies import SceneBodies

__all__ = ["EpisodePhysics"]

FINGER_JOINTS = ("robot_left_finger_joint", "robot_right_finger_joint")


class EpisodePhysics:
    """The physics of one episode: ``data`` set to the scene's pristine state (or the episode's stored
    initial state), the controller at its start, the grasp assist released.

    Args:
        model: the scene's compiled model.
        data: a ``MjData`` of ``model`` to reuse (its contents are overwritten).
        pristine: the scene's state after compilation.
        episode: the episode (its scene, and an optional stored initial state).
        control: the controller's rates and limits.
        grasp_assist: weld an object the fingers close on (:class:`samplehd.motion.assist.GraspAssist`).
        checker: the success checker's options.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, pristine: mujoco.MjData, episode: EpisodeSpec,
                 control: ControlConfig, grasp_assist: bool, checker: CheckerConfig) -> None:
        mujoco.mj_copyData(data, model, pristine)
        self.model = model
        self.data = data
        self.controller = initial_state(model, data, control)
        if episode.initial_state is not None:
            data.qpos[:] = episode.initial_state["qpos"]
            data.qvel[:] = episode.initial_state["qvel"]
            data.act[:] = episode.initial_state["act"]
            mujoco.mj_forward(model, data)
            self.controller.reset(None, gripper=1.0)
        n = len(episode.scene.objects)
        self.assist: GraspAssist | None = None
        if grasp_assist:
            self.assist = GraspAssist(model, n)
            self.assist.release(data)
        self.scene = episode.scene
        self.directions = episode.annotation.get("directions") if episode.annotation else None
        self.checker = checker
        self.object_body = np.array([model.body(f"object_{i}").id for i in range(n)], dtype=int)
        self.tcp_site = model.site("tcp").id
        self.finger_qpos = np.array([model.jnt_qposadr[model.joint(j).id] for j in FINGER_JOINTS])
        self._gripper_bodies = np.array(sorted(SceneBodies(model, n).gripper_bodies), int)
        self._start_pos = np.array([o.pos for o in episode.scene.objects], dtype=float).reshape(-1, 3)
        self._gate_shift = 0.5 * min(checker.relation_margin, checker.lift_height, 0.01)

    @property
    def stopped(self) -> bool:
        """Whether the safety monitor has stopped the arm."""
        return self.controller.stopped is not None

    def apply(self, action: np.ndarray, mode: Any) -> Any:
        """One control period: the grasp assist looks at the gripper command first, then the
        controller steps the physics. Returns the controller's step report."""
        if self.assist is not None:
            self.assist.update(self.data, float(action[-1]), stopped=self.stopped)
        return self.controller.step(action, mode)

    def tcp_pos(self) -> np.ndarray:
        """The tool centre point in the world [m]."""
        return self.data.site_xpos[self.tcp_site]

    def finger_opening(self) -> float:
        """The sum of the two finger joints' positions [m]."""
        return float(self.data.qpos[self.finger_qpos].sum())

    def object_pos(self, index: int) -> np.ndarray:
        """Scene object ``index``'s position [m]."""
        return self.data.xpos[self.object_body[index]]

    def may_succeed(self, task: Task) -> bool:
        """A necessary condition of success that costs microseconds, so the checker runs only when needed.

        Every family's predicate needs the moved objects off their scene poses (templates only
        ask for a change), and every family but pick_up needs them out of the gripper's touch
        (the checker's "resting"); pick_up needs the object lifted.
        """
        d = self.data
        moved = self.object_body[list(task.objects)]
        shift = np.linalg.norm(d.xpos[moved] - self._start_pos[list(task.objects)], axis=1)
        if np.any(shift < self._gate_shift):
            return False
        if not get_family(task.family).places:  # held objects touch the gripper
            return True
        if d.ncon:
            bodies = self.model.geom_bodyid[d.contact.geom]
            touch = np.isin(bodies, self._gripper_bodies)
            held = np.isin(bodies, moved)
            if np.any((touch[:, 0] & held[:, 1]) | (touch[:, 1] & held[:, 0])):
                return False
        return True

    def check(self, task: Task) -> tuple[bool, str]:
        """Whether the state completes ``task``, and the checker's reason."""
        if not self.may_succeed(task):
            return False, "the moved objects are still in place or in the gripper"
        # A window-free pass is cheap; only a state that passes it is run through the stability window.
        quick = check_success(self.model, self.data, self.scene, task, replace(self.checker, window=0.0),
                              directions=self.directions)
        if not quick.success:
            return False, quick.reason
        full = self.report(task)
        return full.success, full.reason

    def report(self, task: Task) -> Any:
        """The shared checker's full report on the state (with the stability window)."""
        return check_success(self.model, self.data, self.scene, task, self.checker, directions=self.directions)

"""A closed-loop oracle policy: privileged state in, actions of the environment's control mode out.

The oracle runs the ground-truth path planner (:mod:`samplehd.motion`) on the environment's live
state, one subtask at a time, and turns each planned joint target into an action of the
environment's control mode:

- ``joint_pos``: the target itself;
- ``joint_delta``: the target minus the controller's current target;
- ``ee_delta``: the TCP motion between the two targets' forward kinematics (translation and
  rotation vector, base frame);
- ``steering``: the same motion divided by the steering scales (as the dataset's steering vectors).

It closes the loop: every subtask is planned from the state the previous one left; while it
carries an object it checks every step that the object is still between the fingers, and when a
grasp misses, the object slips or the straight approach to a grasp is blocked it opens the gripper,
backs off and plans a new grasp of the object where it now lies, without the grasp that failed (up to
``max_replans`` times per object): the one re-grasping plan,
:func:`samplehd.motion.regrasp.regrasping_plan`, that the recovery of disturbed episodes runs too.
One plan per episode: when it has run to its end and the task's check still fails, the oracle gives
up (``failure`` is ``check_failed: REASON``) and holds still; it does not start the episode's plan over.

The planner yields one control target per step (:mod:`samplehd.motion.execute`); the oracle keeps
that generator and advances it by one target per :meth:`OraclePolicy.__call__`, after the
environment has stepped — the environment's ``step`` is the plan's step function, as ManiSkill's
motion-planning solutions drive ``env.step``. No thread, and only public state of the environment
(``controller``, ``assist``, ``task``, ``episode``) and of the planner (``hand``, ``grasped()``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Generator
from typing import Any

import gymnasium as gym
import numpy as np

from samplehd.envs.episodes import EpisodeSpec
from samplehd.envs.tabletop import TabletopEnv
from samplehd.errors import PlanningError
from samplehd.fixedmath import matmul
from samplehd.motion.execute import AttemptFailed, ControlTarget, Plan, Rollout, SubtaskCut, scene_facts
from samplehd.motion.regrasp import REGRASP_REASONS, regrasping_plan
from samplehd.motion.steering import steering_from_targets
from samplehd.robot.constants import GRIPPER_STROKE
from samplehd.robot.controller import ControlReport
from samplehd.robot.kinematics import fk_tcp
from samplehd.world.bodies import SceneBodies
from samplehd.world.layout import LAYOUT
from samplehd.world.planner_config import PlannerConfig
from samplehd.world.robot_info import RobotInfo
from samplehd.world.transforms import rotvec

__all__ = ["OraclePolicy", "oracle_action"]

# Failures the oracle answers by backing off and grasping again without the grasp that failed: a missed
# or slipped grasp, and an approach line from the pre-grasp pose that meets an object (the grasp search
# checks the two ends of the line only).
_REPLANNED = (*REGRASP_REASONS, "approach_blocked")


def oracle_action(mode: str, q_now: np.ndarray, q_next: np.ndarray, gripper: float, env: TabletopEnv) -> np.ndarray:
    """Action of an environment control mode that moves the joint target from ``q_now`` to ``q_next``."""
    if mode == "joint_pos":
        a = np.append(q_next, gripper)
    elif mode == "joint_delta":
        a = np.append(q_next - q_now, gripper)
    else:
        t0, t1 = fk_tcp(q_now), fk_tcp(q_next)
        lin = t1[:3, 3] - t0[:3, 3]
        rot = rotvec(matmul(t1[:3, :3], t0[:3, :3].T))
        if mode == "ee_delta":
            a = np.concatenate([lin, rot, [gripper]])
        else:
            c = env.control
            a = steering_from_targets(t0, t1, gripper, c.control_dt, c.max_linear_speed, c.max_angular_speed)
    # float64: in joint_pos mode the targets then reach the controller bit for bit, as in the
    # offline paths (float32 would round them by ~1e-7 rad, enough for contacts to diverge).
    lo, hi = env.action_space.low.astype(float), env.action_space.high.astype(float)
    return np.clip(np.asarray(a, dtype=float), lo, hi)


# The carried object's bottom above its support when the oracle lets go [m] (the dataset's paths: 6 mm).
# Dropped 6-8 mm, a shop-vrb fork (1 g, a few millimetres thick) meets a baking tray's 2.5 mm floor at
# 0.35 m/s; the contacts (20 ms time constant) let it sink past the floor's middle, and it is pushed
# out below (seed 2, shop-vrb stack L1 #22); a plate went through a tray the same way. From 2-4 mm it
# meets the floor at under 0.28 m/s and stays on it.
RELEASE_GAP = 0.002


class OraclePolicy:
    """The closed-loop oracle for one environment.

    Args:
        env: the environment (a ``gymnasium.make`` result or a :class:`TabletopEnv`); the oracle
            reads its privileged state through ``env.unwrapped``.
        seed: seed of the planner's generator (destinations, RRT); :meth:`reset` may change it.
        planner: planner settings (default: the dataset's, with ``release_gap`` :data:`RELEASE_GAP`).
        max_replans: re-grasps per object after a miss, a slip or a blocked approach.

    Example:
        >>> oracle = OraclePolicy(env)                 # doctest: +SKIP
        >>> obs, info = env.reset(seed=0)              # doctest: +SKIP
        >>> oracle.reset(seed=0)                       # doctest: +SKIP
        >>> obs, *_ = env.step(oracle(obs))            # doctest: +SKIP
    """

    def __init__(self, env: gym.Env, seed: int = 0, planner: PlannerConfig | None = None, max_replans: int = 2) -> None:
        self.env: TabletopEnv = env.unwrapped
        self.planner = planner or dataclasses.replace(PlannerConfig(), release_gap=RELEASE_GAP)
        self.max_replans = max_replans
        self.seed = seed
        self.subtask = ""
        self.target_object = -1  # the scene object the current subtask acts on (-1: none)
        self.failure = ""
        self.replans = 0
        self._plan: Generator[ControlTarget | SubtaskCut, ControlReport | None, None] | None = None
        self._rollout: Rollout | None = None
        self._episode: EpisodeSpec | None = None
        self._finished = False

    # ------------------------------------------------------------------ policy API
    def reset(self, seed: int | None = None) -> None:
        """Forget the current plan (call after ``env.reset``)."""
        self.close()
        if seed is not None:
            self.seed = seed
        self.subtask = ""
        self.target_object = -1
        self.failure = ""
        self.replans = 0
        self._episode = None
        self._finished = False

    def __call__(self, obs: Any = None) -> np.ndarray:
        """The next action; ``obs`` is unused (the oracle reads privileged state)."""
        env = self.env
        if self._episode is not env.episode or (self._plan is None and not self._finished):
            self.reset()
            self._episode = env.episode
            self._plan = self._plan_episode()
            report: ControlReport | None = None
            first = True
        elif self._finished:
            if not self.failure:  # the plan ran to its end and the step after it did not succeed
                check = env.check_success()
                if not check["success"]:
                    self.failure = f"check_failed: {check['reason']}"
            return self._hold_action()
        else:
            if env.controller.stopped is not None:  # a safety stop ends the plan
                return self._finish()
            report = ControlReport(time=float(env.data.time), safety_event=env.last_safety_event)
            first = False
        target = self._advance(report, first)
        if target is None:
            return self._finish()
        self.target_object = int(target.target_object)
        env.subtask = self.subtask
        return oracle_action(env.config.control_mode, env.controller.target, target.joints, target.gripper, env)

    @property
    def gave_up(self) -> bool:
        """Whether the oracle stopped trying in this episode (it then holds still)."""
        return self._finished and bool(self.failure)

    def close(self) -> None:
        """Drop the current plan."""
        if self._plan is not None:
            self._plan.close()
        self._plan = None
        self._rollout = None

    def episode_task(self) -> Any:
        """The task to carry out (a :class:`samplehd.tasks.task.Task`): the environment's own.

        A policy that decides the task itself (from a parsed instruction and a perceived scene)
        overrides this; it is read once when the episode's plan starts.
        """
        return self.env.task

    # ------------------------------------------------------------------ plan
    def _advance(self, report: ControlReport | None, first: bool) -> ControlTarget | None:
        """The plan's next control target (None: the plan ended), checked closed-loop: while the
        object is carried it must still be between the fingers, or the plan hears it slipped."""
        plan = self._plan
        try:
            item = next(plan) if first else plan.send(report)
            while True:
                if isinstance(item, SubtaskCut):
                    item = plan.send(None)
                    continue
                slipped = self._slipped()
                if slipped is None:
                    return item
                item = plan.throw(slipped)
        except StopIteration:
            return None

    def _slipped(self) -> AttemptFailed | None:
        ro = self._rollout
        name = ro.subtasks[-1] if ro is not None and ro.subtasks else ""
        self.subtask = name
        if ro is None or ro.hand is None or name not in ("ObjectMove", "MoveDOWN"):
            return None
        welded = self.env.assist
        if (welded is None or welded.active != ro.hand.index) and ro.grasped() != ro.hand.index:
            return AttemptFailed("grasp_slipped", f"object {ro.hand.index} slipped out of the gripper in {name}")
        return None

    def _finish(self) -> np.ndarray:
        self._finished = True
        self.close()
        return self._hold_action()

    def _hold_action(self) -> np.ndarray:
        env = self.env
        ctrl = env.controller
        g = 2.0 * ctrl.gripper_width / GRIPPER_STROKE - 1.0
        return oracle_action(env.config.control_mode, ctrl.target, ctrl.target, g, env)

    def _plan_episode(self) -> Plan[None]:
        env = self.env
        model, data, ctrl = env.model, env.data, env.controller
        scene = env.episode.scene
        task = self.episode_task()
        facts = scene_facts(scene)
        # The generator of the offline generator's first attempt (plan_and_execute draws each
        # attempt's generator from the episode's), so both make the same random choices.
        rng = np.random.default_rng(np.random.default_rng(self.seed).integers(2**63))
        directions = env.episode.annotation.get("directions") if env.episode.annotation else None
        robot = RobotInfo.from_model(model, data)
        bodies = SceneBodies(model, len(scene.objects))
        # The environment's grasp assist (when on) welds for every policy; the planner must not weld
        # itself, but it closes the gripper as the dataset's paths do: it stops closing when both pads
        # touch (a squeeze ramp on a thin handle spikes the contact force past the safety limit).
        # It releases a carried object as low as its collision hulls allow (a mug dropped 10 mm onto a
        # baking tray's 2 mm floor falls through it). It centres rim grasps on what the pads pinch (on a
        # sloped brim one pad would otherwise push the plate away before the other touches it), and it
        # eases the pads off a carried object before the weld lets go (released while squeezed, thin
        # scissors are shot out of the pads through a chopping board), then, where a pad still rests on
        # the object, opens them just past the weld's release for one step (opened at once, the pad
        # drags light scissors through a plate's floor); where no release pose of a spot is free it
        # tries the object turned half round (a tray held by its near rim behind a box), and after every
        # spot the arm's other IK branches above the first spots; it lays a long object along a support's
        # top where it overhangs it as turned (a fork across a tray rests on the rim), and lowers an object
        # lifted against the arm until it is clear.
        ro = Rollout(model, data, ctrl, robot, bodies, facts, self.planner, rng, LAYOUT, directions,
                     use_assist=False, step_assist=env.assist, hull_bottom=True, fit_pinch=True,
                     ease_release=True, turn_release=True, open_gently=True, other_branches=True,
                     align_on_top=True, free_start=True)
        self._rollout = ro
        try:
            yield from regrasping_plan(ro, task, self.max_replans, reasons=_REPLANNED, on_failure=self._replanned)
        except AttemptFailed as exc:
            self.failure = exc.reason
            return
        except PlanningError as exc:
            self.failure = f"planning: {exc}"
            return
        self.subtask = "Completed"
        env.subtask = "Completed"

    def _replanned(self, failure: AttemptFailed) -> bool:
        """A missed or slipped grasp or a blocked approach is answered by a re-grasp without the grasp
        that failed."""
        self.replans += 1
        return True

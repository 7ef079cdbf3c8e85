"""The subtask planner as a generator of control targets, and the one loop that drives it.

:class:`Rollout`'s subtasks (:meth:`~Rollout.pick`, :meth:`~Rollout.place`, :meth:`~Rollout.go_home`,
...) are generators: each yields one :class:`ControlTarget` per control step (joint targets, gripper
command, the SAMPLE-HD steering vector of that motion, the subtask and its progress) and receives the
:class:`~samplehd.robot.controller.ControlReport` of the step that executed it. Planning is
interleaved with execution: each subtask is planned from the state the previous one left (the
object's actual pose, the actual grasp), so small slips in physics do not accumulate.

Whoever drives the plan owns the physics: :func:`drive` sends each target to a step function —
:func:`step_controller` (joint-position mode at the control rate over 500 Hz physics) for the
dataset, wrapped by the frame recorder (:class:`samplehd.record.recorder.RecordingStep`); the
environment's own ``step`` for the closed-loop oracle (:mod:`samplehd.envs.oracle`), which turns a
target into an action of the environment's control mode. No thread, no recorder inside the planner.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Generator, Iterator
from dataclasses import dataclass
from typing import Any, TypeVar

import mujoco
import numpy as np

from samplehd.catalogue import ObjectFacts, object_facts
from samplehd.errors import PlanningError
from samplehd.fixedmath import inv_rigid, matmul, norm
from samplehd.motion.assist import RELEASE_MARGIN, GraspAssist
from samplehd.motion.order import effector_point
from samplehd.motion.order import next_object as order_next_object
from samplehd.motion.planner import (
    destination_candidates,
    leaves_room,
    plan_joint_move,
    release_height,
    straight_move,
)
from samplehd.motion.steering import steering_from_targets, steering_motion
from samplehd.robot.constants import GRIPPER_ACTUATOR, GRIPPER_STROKE, HOME_QPOS, TCP_OFFSET
from samplehd.robot.controller import ControlConfig, ControlReport, RobotController
from samplehd.robot.kinematics import fk_tcp, ik_all, ik_batch, wrap_to_limits
from samplehd.scene.spec import SceneSpec
from samplehd.tasks.task import Task, get_family
from samplehd.world.bodies import SceneBodies, grasped_object, object_pose, object_world_box, object_world_hull_box
from samplehd.world.collision import CollisionChecker, Held
from samplehd.world.grasps import PINCH_TOLERANCE, choose_grasps, ik_near, pinch_gaps
from samplehd.world.layout import LAYOUT, Directions, TableLayout
from samplehd.world.placement import SPOT_SECOND_LOOK, SPOT_SECOND_SAMPLES
from samplehd.world.planner_config import PlannerConfig
from samplehd.world.robot_info import RobotInfo

__all__ = [
    "AttemptFailed",
    "ControlTarget",
    "Plan",
    "Rollout",
    "SubtaskCut",
    "drive",
    "initial_state",
    "scene_facts",
    "step_controller",
]


# fit_pinch: the pads' gaps are evened out (to PINCH_TOLERANCE) in this many moves, each followed by this
# many still steps for the arm to settle.
_PINCH_CORRECTIONS = 3
_PINCH_SETTLE_STEPS = 2
# ease_release: how long the pads ease off a welded object before the weld is released [s].
_EASE_TIME = 0.15
# turn_release: how far a footprint may be off-centre about the object's origin for a half turn to keep it [m].
_SYMMETRY_TOLERANCE = 0.002
# free_start: how far a held object lifted against the arm may be lowered to clear it [m].
_CLEAR_DROP = 0.1
# open_gently: the gripper command of OpenGripper's first step, beyond the one the weld was made with, in
# release margins (past the one margin that releases the weld, about 2.7 mm of opening in all).
_GENTLE_OPENING = 1.25


@dataclass(frozen=True)
class ControlTarget:
    """What the planner commands for one control step, and what a recorder stores beside the state.

    Attributes:
        subtask: index of the subtask in :attr:`Rollout.subtasks`.
        progress: progress of the subtask in [0, 1] at the start of the step.
        target_object: scene object the subtask acts on (-1: none).
        joints: (6,) joint position targets [rad].
        gripper: gripper command in [-1, 1] (+1 open).
        steering: (7,) float32 SAMPLE-HD steering vector producing the same TCP motion.
        held: the object the grasp assist holds (None: read it from the contacts).
    """

    subtask: int
    progress: float
    target_object: int
    joints: np.ndarray
    gripper: float
    steering: np.ndarray
    held: int | None = None


@dataclass(frozen=True)
class SubtaskCut:
    """The subtask ended early, after its last ``steps`` control steps (their progress runs 0 to 1)."""

    steps: int


T = TypeVar("T")
# A plan yields control targets (and subtask cuts) and is sent the report of each executed step.
Plan = Generator[ControlTarget | SubtaskCut, ControlReport | None, T]


def step_controller(controller: RobotController, target: ControlTarget) -> ControlReport:
    """The physics step of one control target: the controller in joint-position mode."""
    return controller.step(np.concatenate([target.joints, [target.gripper]]), "joint_position")


def drive(plan: Plan[T], step: Callable[[ControlTarget | SubtaskCut], ControlReport | None]) -> T:
    """Run a plan to its end, sending every target it yields to ``step``; returns the plan's value.

    Exceptions of the plan (:class:`AttemptFailed`, ...) propagate to the caller.
    """
    try:
        item = next(plan)
        while True:
            item = plan.send(step(item))
    except StopIteration as stop:
        return stop.value


def initial_state(model: mujoco.MjModel, data: mujoco.MjData, config: ControlConfig) -> RobotController:
    """Put the arm at home with the gripper open, objects as compiled; returns the controller."""
    ctrl = RobotController(model, data, config)
    ctrl.reset(HOME_QPOS, gripper=1.0)
    robot = RobotInfo.from_model(model, data)
    data.qpos[robot.finger_qpos] = GRIPPER_STROKE / 2
    mujoco.mj_forward(model, data)
    return ctrl


def scene_facts(scene: SceneSpec) -> list[ObjectFacts | None]:
    """Catalogue facts of each scene object (None for objects the catalogue does not know: the
    planner then falls back to the model's geometry)."""
    out: list[ObjectFacts | None] = []
    for o in scene.objects:
        try:
            out.append(object_facts(o.instance))
        except Exception:  # noqa: BLE001 - objects unknown to the catalogue fall back to model geometry
            out.append(None)
    return out


class AttemptFailed(PlanningError):
    """One execution attempt failed; ``reason`` is a short counted key, ``grasp`` the grasp index used."""

    def __init__(self, reason: str, message: str, grasp: int = -1) -> None:
        super().__init__(message)
        self.reason = reason
        self.grasp = grasp


def _upright(rot: np.ndarray, max_tilt: float = 0.35) -> np.ndarray:
    """The orientation turned by the smallest rotation that brings its z axis to the vertical.

    An object can tilt a little in the fingers before both pads touch; it is put down upright (the
    TCP tilts by the same small angle) so tall, narrow objects do not topple. Tilts above
    ``max_tilt`` [rad] (an object held on its side) are kept.
    """
    z = rot[:, 2]
    axis = np.cross(z, [0.0, 0.0, 1.0])
    s, c = norm(axis), float(z[2])
    ang = math.atan2(s, c)
    if s < 1e-9 or ang > max_tilt:
        return rot
    k = axis / s
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    fix = np.eye(3) + np.sin(ang) * kx + matmul((1.0 - np.cos(ang)) * kx, kx)
    return matmul(fix, rot)


def _released(t_obj: np.ndarray, yaw: float) -> np.ndarray:
    """The held object's orientation at release: upright (:func:`_upright`), turned by ``yaw`` [rad]
    about the vertical."""
    cz, sz = np.cos(yaw), np.sin(yaw)
    return matmul(np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]]), _upright(t_obj[:3, :3]))


def _gripper_command(opening: float) -> float:
    return float(np.clip(2.0 * opening / GRIPPER_STROKE - 1.0, -1.0, 1.0))


@dataclass
class _Hand:
    """What the gripper holds: object index and its pose in the TCP frame."""

    index: int
    tcp_to_object: np.ndarray
    opening: float
    approach_opening: float = 0.0


@dataclass(frozen=True)
class _Release:
    """How a held object is set down: the joint-space move to above the release pose, the descent,
    the fingers' opening there [m] and the destination as recorded in the rollout's info."""

    move: np.ndarray
    method: str
    down: np.ndarray
    opening: float
    destination: dict[str, Any]


class Rollout:
    """Runs subtasks of one attempt on a live ``MjData`` and records them.

    Args:
        model: compiled scene.
        data: state at the start of the attempt (modified in place).
        controller: the robot controller bound to ``model``/``data``.
        robot: robot addresses.
        bodies: scene body ids.
        facts: catalogue facts per object (None for unknown objects).
        config: planner settings.
        rng: random generator (destinations, RRT).
        layout: table layout.
        directions: scene direction vectors.
        use_assist: apply the grasp rule at every control step, welding the grasped object to the
            gripper while held (see :mod:`.assist`); off where the step function applies it (the
            environment's ``step`` for the closed-loop oracle).
        step_assist: the grasp assist the step function applies (the environment's), with
            ``use_assist`` off: the rollout reads its welds and grasps as with its own (the
            gripper stops closing when both pads touch, a grasp is held when welded) but never
            updates it. None: the rollout's own assist (off without ``use_assist``).
        grasp_memo: the compiled scene's name for :func:`~samplehd.world.grasps.choose_grasps`'s
            ``memo`` (None: every grasp search runs).
        hull_bottom: find a held object's release height down to where its collision hulls meet the
            table. Off (the dataset's paths, whose bytes are fixed): down to where MuJoCo's per-piece
            bounding boxes do, which for mesh pieces (boxes in each piece's principal-axes frame) reach
            up to a centimetre lower, so over a thin support (a baking tray's 2 mm floor) the object is
            released that much higher and may fall through it.
        fit_pinch: centre each rim grasp on what its pads pinch, so both touch at once
            (:func:`~samplehd.world.grasps.choose_grasps`'s ``fit_pinch``). Off (the dataset's paths):
            around the rim site's nominal wall, which on a sloped brim lets one pad push the object
            before the other touches it.
        ease_release: before the weld is released, ease the pads off the object for a moment with the
            weld still on. Off (the dataset's paths): the opening command releases the weld while the
            pads still squeeze, which can shoot a thin tapered object out of them.
        turn_release: where no release pose of a destination spot is free, try the spot with the object
            turned half round about the vertical (objects whose footprint is symmetric about their
            origin only): a tray held by its near rim, placed close to the robot, folds the arm into
            itself; turned, the grasp is on the far side. Off (the dataset's paths): each spot as drawn.
        open_gently: where the gripper still touches the welded object when OpenGripper begins, open
            it in two stages: for the first control step just past the command that releases the weld
            (the object drops clear of the pads), then as wide as planned; the subtask keeps its length.
            Off (the dataset's paths): as wide as planned at once, and pads snapping open drag a light
            object resting against them with them.
        other_branches: where every release spot has failed with the arm's IK branch nearest its
            configuration, try the first spots again with its other branches: the nearest may fold
            the upper arm through the table above a far spot where another reaches it from above.
            Off (the dataset's paths): the nearest branch only.
        align_on_top: set an object that overhangs its support's top as it is turned now along the
            top's long side where it fits so (:func:`~samplehd.motion.planner.top_turn`). Off (the
            dataset's paths): as it is turned.
        free_start: where the held object ends its lift against the arm (a pan lifted by its handle
            meets the upper-arm link; the lift is not collision-checked), lower it straight until it is
            clear before the move to the destination (:meth:`_lower_clear`). Off (the dataset's paths):
            no move can start there and the placement fails.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, controller: RobotController, robot: RobotInfo,
                 bodies: SceneBodies, facts: list[ObjectFacts | None], config: PlannerConfig, rng: np.random.Generator,
                 layout: TableLayout = LAYOUT, directions: Directions | None = None,
                 use_assist: bool = True, step_assist: GraspAssist | None = None,
                 grasp_memo: str | None = None, hull_bottom: bool = False, fit_pinch: bool = False,
                 ease_release: bool = False, turn_release: bool = False, open_gently: bool = False,
                 other_branches: bool = False, align_on_top: bool = False, free_start: bool = False) -> None:
        self.grasp_memo = grasp_memo
        self.use_assist = use_assist
        self.hull_bottom = hull_bottom
        self.fit_pinch = fit_pinch
        self.ease_release = ease_release
        self.turn_release = turn_release
        self.open_gently = open_gently
        self.other_branches = other_branches
        self.align_on_top = align_on_top
        self.free_start = free_start
        # Whether a grasp assist welds grasped objects, the rollout's own or the step function's.
        self.assisted = use_assist or step_assist is not None
        self.model, self.data, self.ctrl, self.robot, self.bodies = model, data, controller, robot, bodies
        self.facts, self.cfg, self.rng, self.layout, self.directions = facts, config, rng, layout, directions
        self.dt = controller.config.control_dt
        fingers = tuple(sorted(b for b in bodies.gripper_bodies
                               if any(model.jnt_bodyid[j] == b for j in range(model.njnt))))
        self.finger_bodies = (fingers[0], fingers[-1])
        self.steps = 0  # control targets yielded so far (the frames a recorder holds)
        self.subtasks: list[str] = []
        self.checker = CollisionChecker(model, data, bodies, robot)
        self.gripper = 1.0
        self.hand: _Hand | None = None
        self.info: dict[str, Any] = {"grasps": [], "destinations": [], "methods": [], "assist": []}
        self.current_grasp = -1
        if step_assist is None:
            self.assist = GraspAssist(model, bodies.num_objects)
            self.assist.release(data)
        else:
            self.assist = step_assist
        # Where the objects are at the start of the attempt (the first recorded frame): the
        # ``nearest`` pick order measures from these.
        self.start_positions = data.xpos[bodies.object_body].copy()
        self.moved: list[int] = []  # the objects put down so far, in turn

    # ------------------------------------------------------------------ stepping
    def _begin(self, name: str) -> int:
        self.subtasks.append(name)
        return len(self.subtasks) - 1

    def run(self, name: str, target: int, targets: np.ndarray,
            gripper: float | np.ndarray | Callable[[int], float] | None = None,
            until: Callable[[int], bool] | None = None) -> Plan[None]:
        """Yield joint targets (one per control step) as subtask ``name``.

        Args:
            name: subtask name.
            target: scene object the subtask acts on.
            targets: (T, 6) joint targets [rad].
            gripper: gripper command in [-1, 1]: one value, one per step, or a function of the step
                index (default: unchanged).
            until: called with the step index after each step; True ends the subtask there (its
                frames' progress then runs from 0 to 1 over the steps taken).
        """
        idx = self._begin(name)
        n = len(targets)
        grips = None
        if callable(gripper):
            grip_of = gripper
        else:
            grips = np.broadcast_to(np.asarray(self.gripper if gripper is None else gripper, float), (n,))
            grip_of = grips.__getitem__
        cc = self.ctrl.config
        # The steering of every step at once, from consecutive targets; a step whose start is not the
        # previous target (clipped by the controller) gets its own.
        poses = fk_tcp(np.vstack([self.ctrl.target[None], targets])) if n else np.zeros((0, 4, 4))
        motion = steering_motion(poses[:-1], poses[1:], self.dt, cc.max_linear_speed, cc.max_angular_speed)
        # with the gripper commands known in advance, every step's vector at once (each row the bits of its own)
        steers = None if grips is None else np.clip(np.column_stack([motion, grips]), -1.0, 1.0).astype(np.float32)
        previous = self.ctrl.target
        for k, q in enumerate(targets):
            self.gripper = float(grip_of(k))
            now = self.ctrl.target
            if np.array_equal(now, previous):
                steer = (np.clip(np.append(motion[k], self.gripper), -1.0, 1.0).astype(np.float32) if steers is None
                         else steers[k])
            else:
                steer = steering_from_targets(fk_tcp(now), poses[k + 1], self.gripper, self.dt,
                                              cc.max_linear_speed, cc.max_angular_speed)
            previous = q
            if self.use_assist:
                self._apply_grasp_rule()
            held = self.assist.active if self.assist.active >= 0 else None
            self.steps += 1
            report = yield ControlTarget(idx, k / max(1, n - 1), target, q, self.gripper, steer, held)
            if report is not None and report.safety_event is not None:
                raise AttemptFailed(f"safety_{report.safety_event.kind}", f"{name}: {report.safety_event}")
            if until is not None and k + 1 < n and until(k):
                yield SubtaskCut(k + 1)
                break

    def _apply_grasp_rule(self) -> None:
        """The grasp assist's rule at the start of this control step, as the environment applies it."""
        before = self.assist.active
        after = self.assist.update(self.data, self.gripper, self.ctrl.stopped is not None)
        if after != before:
            self.info["assist"].append({"object": max(before, after), "frame": self.steps,
                                        "on": after >= 0})

    def hold(self, name: str, target: int, duration: float, gripper: float) -> Plan[None]:
        """Keep the arm still for ``duration`` seconds with a gripper command."""
        n = max(1, int(round(duration / self.dt)))
        yield from self.run(name, target, np.repeat(self.ctrl.target[None], n, axis=0), gripper)

    def final_target(self) -> ControlTarget:
        """The hold command that goes with the final state (recorded, never executed)."""
        idx = max(0, len(self.subtasks) - 1)
        steer = np.zeros(7, np.float32)
        steer[6] = self.gripper
        held = self.assist.active if self.assist.active >= 0 else None
        return ControlTarget(idx, 1.0, -1, self.ctrl.target, self.gripper, steer, held)

    # ------------------------------------------------------------------ helpers
    def _sync(self) -> None:
        mujoco.mj_forward(self.model, self.data)
        self.checker.sync(self.data)

    def _tcp_world(self) -> np.ndarray:
        t = np.eye(4)
        t[:3, :3] = self.data.site_xmat[self.robot.tcp_site].reshape(3, 3)
        t[:3, 3] = self.data.site_xpos[self.robot.tcp_site]
        return t

    def _transport_z(self, held_index: int) -> float:
        """TCP height [m, world] that lifts the held object's bottom over every other object."""
        tops = [object_world_box(self.model, self.data, self.bodies, k).hi[2]
                for k in range(self.bodies.num_objects) if k != held_index]
        top = max(tops, default=self.layout.table_height)
        tcp = self._tcp_world()
        bottom = object_world_box(self.model, self.data, self.bodies, held_index).lo[2]
        below = tcp[2, 3] - bottom
        return float(max(top + self.cfg.transport_clearance + below,
                         self.layout.table_height + self.cfg.min_transport_height,
                         self.layout.table_height + self.cfg.min_lift + below))

    # ------------------------------------------------------------------ subtasks
    def next_object(self, task: Task, remaining: list[int]) -> int:
        """The object of ``remaining`` (the task's objects not moved yet, in its order) to pick next,
        by the planner's ``order`` (:mod:`samplehd.motion.order`). Only a family whose moved objects
        are a set (place, remove) is reordered; stack_three's order is its meaning (middle, then top)."""
        if self.cfg.order == "instruction" or not get_family(task.family).takes_set:
            return order_next_object("instruction", remaining)
        mujoco.mj_kinematics(self.model, self.data)  # positions as the next recorded frame has them
        tcp = self._tcp_world()
        return order_next_object(self.cfg.order, remaining, effector_point(tcp[:3, 3], tcp[:3, :3]),
                                 self.start_positions)

    def pick(self, i: int, exclude: tuple[int, ...] = (), lift: bool = True) -> Plan[int]:
        """GripperMoveAvoid, ApproachGrasp, CloseGripper (and MoveUP) for object ``i``.

        Returns:
            The index of the grasp used (in the registry's candidate list).
        """
        self._sync()
        q0 = self.ctrl.target
        grasps = choose_grasps(self.model, self.data, self.bodies, self.robot, self.checker, i, self.facts[i],
                               q0, self.cfg, self.layout, exclude, memo=self.grasp_memo,
                               fit_pinch=self.fit_pinch)
        if not grasps:
            raise AttemptFailed("no_feasible_grasp", f"object {i}: no reachable, collision-free grasp")
        k, gp = grasps[0]
        self.current_grasp = k
        self.info["grasps"].append({"object": i, "index": k, **gp.grasp.to_dict()})
        open_cmd = _gripper_command(gp.grasp.opening)
        lift_z = self._transport_z(i)
        try:
            path, method = plan_joint_move(self.checker, q0, gp.q_pregrasp, gp.grasp.opening, self.dt, self.cfg,
                                           self.rng, lift_z=lift_z, robot=self.robot)
            self.info["methods"].append(method)
        except PlanningError as exc:
            raise AttemptFailed("no_path_to_object", str(exc), k) from exc
        yield from self.run("GripperMoveAvoid", i, path, open_cmd)
        self._sync()
        try:
            path = straight_move(self.checker, fk_tcp(self.ctrl.target), gp.tcp_grasp, self.ctrl.target,
                                 gp.grasp.opening, self.dt, self.cfg.approach_speed,
                                 ramp_time=self.cfg.line_ramp_time)
        except PlanningError as exc:
            raise AttemptFailed("approach_blocked", str(exc), k) from exc
        yield from self.run("ApproachGrasp", i, path, open_cmd)
        if self.fit_pinch and gp.grasp.name == "rim":
            yield from self._centre_pinch(i, gp.grasp.opening, open_cmd)
        yield from self.close_gripper(i, gp.grasp.opening, gp.grasp.width)
        self._sync()
        if not self._holding(i):
            raise AttemptFailed("grasp_missed", f"object {i}: the fingers closed without holding it", k)
        tcp = self._tcp_world()
        # Release with the fingers opened a little beyond the measured grip, not the full approach opening.
        held_width = float(self.data.qpos[self.robot.finger_qpos].sum())
        release_opening = min(gp.grasp.opening, held_width + 0.012)
        self.hand = _Hand(i, matmul(inv_rigid(tcp), object_pose(self.data, self.bodies, i)), release_opening,
                          gp.grasp.opening)
        if lift:
            yield from self.move_up(i, k)
        return k

    def _centre_pinch(self, i: int, opening: float, open_cmd: float) -> Plan[None]:
        """Move the open gripper along its closing line until both pads are as far from object ``i``,
        measured where the TCP is (not where it was planned): on a sloped brim a pad's gap changes by
        nearly 4 mm per millimetre of height, so the arm's tracking error alone can make one pad touch
        and push the object a step before the other; the grasp assist welds only when both touch."""
        for _ in range(_PINCH_CORRECTIONS):
            self._sync()
            tcp = self._tcp_world()
            gaps = pinch_gaps(self.model, self.data, self.bodies, i, tcp, self.robot, opening)
            if gaps is None or abs(gaps[0] - gaps[1]) <= PINCH_TOLERANCE:
                return
            shift = 0.5 * (gaps[0] - gaps[1]) * matmul(tcp[:3, :3], self.robot.finger_axis)
            start = fk_tcp(self.ctrl.target)
            end = start.copy()
            end[:3, 3] += matmul(self.robot.base_rot.T, shift)
            try:
                path = straight_move(self.checker, start, end, self.ctrl.target, opening, self.dt,
                                     self.cfg.approach_speed)
            except PlanningError:
                return
            settle = np.repeat(path[-1:], _PINCH_SETTLE_STEPS, axis=0)
            yield from self.run("ApproachGrasp", i, np.vstack([path, settle]), open_cmd)

    def _ease_grip(self, i: int) -> Plan[None]:
        """Ease the pads off the welded object ``i`` before the weld is released: a command half the
        assist's release margin wider than the one it welded with keeps the weld and stops the squeeze.
        Released while squeezed, a thin tapered object (shop-vrb scissors) is shot out of the pads,
        falls 27 mm in one control step and passes through a 13 mm board."""
        eased = min(1.0, self.assist.attach_command + 0.5 * RELEASE_MARGIN)
        yield from self.hold("OpenGripper", i, _EASE_TIME, eased)

    def close_gripper(self, i: int, opening: float, width: float) -> Plan[None]:
        """CloseGripper: ramp the finger command down until both pads touch the object, arm still.

        With the grasp assist, once both fingers touch the object (the rule's test, so the rule
        welds it in that step) the command holds half a millimetre inside the measured opening:
        the pads press on it, no harder (pads rattling against light convex objects under a
        stiff squeeze spike contact forces past the safety limit). Without it the fingers squeeze
        with ``squeeze_force`` (command = measured opening minus force / servo gain).
        """
        n = max(2, int(round(self.cfg.close_time / self.dt)))
        ramp = max(1, int(n * 0.7))
        start = _gripper_command(opening)
        end = _gripper_command(max(0.0, width - 0.006))
        cmds = np.linspace(start, end, ramp + 1)[1:]
        kp = float(self.model.actuator_gainprm[self.model.actuator(GRIPPER_ACTUATOR).id, 0]) or 1e4
        frozen: list[float] = []
        assisted = self.assisted and self.assist.available

        def command(k: int) -> float:
            if frozen:
                return frozen[0]
            measured = float(self.data.qpos[self.robot.finger_qpos].sum())
            if assisted and (self.assist.active == i or self.assist.touched(self.data, (i,)) == i):
                frozen.append(_gripper_command(max(0.0, measured - 0.0005)))
                return frozen[0]
            if k < ramp:
                return float(cmds[k])
            if not assisted:
                frozen.append(_gripper_command(max(0.0, measured - self.cfg.squeeze_force / kp)))
                return frozen[0]
            return float(cmds[-1])

        # With the assist the grasp is made when the object attaches: hold a moment for the finger
        # forces to settle, then go on.
        attached_at: list[int] = []
        settle = max(1, int(round(self.cfg.grip_settle_time / self.dt)))

        def settled(k: int) -> bool:
            if frozen and self.assist.active == i and not attached_at:
                attached_at.append(k)
            return bool(attached_at) and k - attached_at[0] >= settle

        yield from self.run("CloseGripper", i, np.repeat(self.ctrl.target[None], n, axis=0), command,
                            until=settled if assisted else None)

    def grasped(self) -> int:
        """The scene object touching both fingers now, or -1."""
        return grasped_object(self.model, self.data, self.finger_bodies, self.bodies.body_to_object)

    def _holding(self, i: int, tolerance: float = 0.002) -> bool:
        """Whether object ``i`` is held: with the grasp assist, in its weld (the rule decides what is
        held); without it, its collision geoms within ``tolerance`` [m] of both fingers' (contacts
        on thin convex pieces flicker from step to step, distances do not)."""
        if self.assisted and self.assist.available:
            return self.assist.active == i
        return self.assist.touched(self.data, (i,), tolerance) == i

    def move_up(self, i: int, grasp_index: int = -1) -> Plan[None]:
        """MoveUP: straight lift of the held object to the transport height."""
        z = self._transport_z(i)
        start = fk_tcp(self.ctrl.target)
        held = Held(i, self.hand.tcp_to_object)
        path = None
        # Tall objects held high may not reach the full transport height: lift as high as reachable.
        for zk in np.arange(z, start[2, 3] + self.robot.base_pos[2] + 0.05 - 1e-9, -0.02):
            end = start.copy()
            end[2, 3] = zk - self.robot.base_pos[2]
            try:
                path = straight_move(self.checker, start, end, self.ctrl.target, 0.0, self.dt, self.cfg.lift_speed,
                                     held=held, check=False, ramp_time=self.cfg.line_ramp_time)
                break
            except PlanningError:
                continue
        if path is None:
            raise AttemptFailed("lift_unreachable", f"object {i}: no reachable lift", grasp_index)
        yield from self.run("MoveUP", i, path)
        self._sync()
        if not self._holding(i):
            raise AttemptFailed("grasp_slipped", f"object {i} slipped out of the gripper while lifting", grasp_index)
        # Re-measure the grasp after lifting: the object may have settled in the fingers.
        self.hand = _Hand(i, matmul(inv_rigid(self._tcp_world()), object_pose(self.data, self.bodies, i)),
                          self.hand.opening, self.hand.approach_opening)

    def place(self, i: int, task: Task, grasp_index: int = -1) -> Plan[None]:
        """ObjectMove, MoveDOWN, OpenGripper, MoveToDefaultPos for the held object ``i``."""
        self._sync()
        hand = self.hand
        if hand is None or hand.index != i:
            raise AttemptFailed("not_holding", f"object {i} is not in the gripper", grasp_index)
        t_obj = object_pose(self.data, self.bodies, i)
        # Ignore the held object itself when searching for room.
        spots = destination_candidates(self.data, self.bodies, self.facts, i, task, self.rng, self.cfg,
                                       self.layout, self.directions, align_on_top=self.align_on_top)
        if not spots:
            raise AttemptFailed("no_free_spot", f"object {i}: no free spot at the destination", grasp_index)
        spots = self._roomy_first(i, task, spots)
        transport_z = self._transport_z(i)
        q_now = self.ctrl.target
        if self.free_start and not self.checker.free(q_now, 0.0, Held(i, hand.tcp_to_object)):
            # No joint move can start here (plan_joint_move refuses a start in collision): lower first.
            q_now = yield from self._lower_clear(i, hand, grasp_index)
            t_obj = object_pose(self.data, self.bodies, i)
        into = get_family(task.family).destination == "opening"
        max_drop = self.cfg.max_drop_into if into else self.cfg.max_drop
        last_error = "no reachable release pose"
        release: _Release | str = last_error
        for xy, yaw in itertools.chain(self._turned_spots(spots, i), self._second_look(i, task, spots)):
            release = self._release_plan(i, hand, t_obj, xy, yaw, transport_z, q_now, max_drop, q_now)
            if not isinstance(release, str):
                break
            last_error = release
        if isinstance(release, str) and self.other_branches:
            release = self._other_branch_release(i, hand, t_obj, spots, transport_z, q_now, max_drop)
        if not isinstance(release, str):
            hand = dataclasses.replace(hand, opening=release.opening)
            self.info["destinations"].append(release.destination)
            self.info["methods"].append(release.method)
            yield from self.run("ObjectMove", i, release.move)
            yield from self.run("MoveDOWN", i, release.down)
            # The opening command releases the weld (the rule, in OpenGripper's first step).
            opening = hand.opening
            welded = self.assisted and self.assist.active >= 0
            if welded:
                opening = max(opening, (self.assist.release_command() + 1.0) * 0.5 * GRIPPER_STROKE)
                if self.ease_release:
                    yield from self._ease_grip(i)
            gently = welded and self.open_gently and self.gripper_touches(i)
            yield from self.open_gripper(i, opening, gently=gently)
            self.hand = None
            yield from self.go_home(i, opening)
            self.moved.append(i)
            return
        raise AttemptFailed("no_release_path", f"object {i}: {last_error}", grasp_index)

    def _lower_clear(self, i: int, hand: _Hand, grasp_index: int) -> Plan[np.ndarray]:
        """``free_start``: a straight descent of the held object ``i`` to the first height, in 1 cm
        steps down to ``_CLEAR_DROP``, where it is clear of the arm; the arm's configuration there."""
        held = Held(i, hand.tcp_to_object)
        start = fk_tcp(self.ctrl.target)
        for dz in np.arange(0.01, _CLEAR_DROP + 1e-9, 0.01):
            end = start.copy()
            end[2, 3] -= dz
            q = ik_near(end, self.ctrl.target)
            if q is None or not self.checker.free(q, 0.0, held):
                continue
            path = straight_move(self.checker, start, end, self.ctrl.target, 0.0, self.dt, self.cfg.lift_speed,
                                 held=held, check=False, ramp_time=self.cfg.line_ramp_time)
            yield from self.run("ObjectMove", i, path)
            self._sync()
            return self.ctrl.target
        raise AttemptFailed("no_release_path", f"object {i}: held against the arm, and no lower pose clear of it",
                            grasp_index)

    def _release_plan(self, i: int, hand: _Hand, t_obj: np.ndarray, xy: np.ndarray, yaw: float, transport_z: float,
                      q_now: np.ndarray, max_drop: float, seed: np.ndarray) -> _Release | str:
        """The moves that set held object ``i`` down at ``xy`` turned by ``yaw`` (ObjectMove to above
        the release pose, MoveDOWN to it), or why there are none; ``seed``: the configuration whose
        IK branch the arm takes above the release pose (``q_now``: the nearest)."""
        held = Held(i, hand.tcp_to_object)
        # Release pose: object moved to (x, y), turned by yaw about the vertical, dropped onto its support.
        rot = _released(t_obj, yaw)
        box = object_world_hull_box if self.hull_bottom else object_world_box
        obj_bottom_below = t_obj[2, 3] - box(self.model, self.data, self.bodies, i).lo[2]
        start_z = self._carried_z(t_obj, transport_z)
        try:
            z_rel = release_height(self.checker, self.bodies, i, rot, xy, start_z,
                                   self.layout.table_height + obj_bottom_below - 0.001)
        except PlanningError as exc:
            return str(exc)
        t_obj_rel = np.eye(4)
        t_obj_rel[:3, :3] = rot
        t_obj_rel[:3, 3] = (xy[0], xy[1], z_rel + self.cfg.release_gap)
        tcp_rel_w = matmul(t_obj_rel, inv_rigid(hand.tcp_to_object))
        rel_b = self.robot.world_to_base(tcp_rel_w)
        q_above = None
        # Above the release pose at the transport height, or as high as the arm reaches there.
        z_top = max(transport_z, self._tcp_world()[2, 3])
        for zk in np.arange(z_top, tcp_rel_w[2, 3] + 0.02 - 1e-9, -0.02):
            tcp_above_w = tcp_rel_w.copy()
            tcp_above_w[2, 3] = zk
            above_b = self.robot.world_to_base(tcp_above_w)
            qa, ok = ik_batch(above_b[None], seed[None], TCP_OFFSET)
            if ok[0]:
                q_above = qa[0]
                break
        if q_above is None:
            return "release pose out of reach"
        # Where the fingers cannot open beside the object (a can in a mug), release it higher and
        # let it drop the last centimetres; over a container, from above the rim if need be (a
        # short box deep in a mug: the open fingers are wider than the mug).
        # Open as wide as the approach did where there is room (a pad must not stay on the object),
        # else a little beyond the grip.
        drop = None
        for dz in np.arange(0.0, min(max_drop, tcp_above_w[2, 3] - tcp_rel_w[2, 3]) + 1e-9, 0.01):
            t = rel_b.copy()
            t[2, 3] += dz
            qr, ok = ik_batch(t[None], q_above[None], TCP_OFFSET)
            if not ok[0]:
                continue
            for opening in (hand.approach_opening, hand.opening):
                if self.checker.free(qr[0], opening, held if dz else None, allow_objects_with_gripper=(i,)):
                    drop = (dz, t, opening)
                    break
            if drop is not None:
                break
        if drop is None:
            return "the fingers cannot open at the release pose"
        try:
            move, method = plan_joint_move(self.checker, q_now, q_above, 0.0, self.dt, self.cfg, self.rng,
                                           held=held, lift_z=transport_z, robot=self.robot)
            down = straight_move(self.checker, above_b, drop[1], q_above, 0.0, self.dt, self.cfg.approach_speed,
                                 held=held, ramp_time=self.cfg.line_ramp_time)
        except PlanningError as exc:
            return str(exc)
        destination = {"object": i, "xy": [float(xy[0]), float(xy[1])], "z": float(t_obj_rel[2, 3]),
                       "yaw": float(yaw), "drop": float(drop[0])}
        return _Release(move, method, down, drop[2], destination)

    def _carried_z(self, t_obj: np.ndarray, transport_z: float) -> float:
        """Height [m, world] of the held object's frame (pose ``t_obj`` now) with the TCP at ``transport_z``."""
        return transport_z - (self._tcp_world()[2, 3] - t_obj[2, 3])

    def _other_branch_release(self, i: int, hand: _Hand, t_obj: np.ndarray, spots: list[tuple[np.ndarray, float]],
                              transport_z: float, q_now: np.ndarray, max_drop: float) -> _Release | str:
        """``other_branches``: the first spots again, each with the arm's other IK branches above it
        (nearest to the arm first), once every spot has failed with the nearest branch."""
        error = "no other IK branch"
        start_z = self._carried_z(t_obj, transport_z)
        for xy, yaw in self._turned_spots(spots, i):
            top = np.eye(4)
            top[:3, :3] = _released(t_obj, yaw)
            top[:3, 3] = (xy[0], xy[1], start_z)
            tcp_top = self.robot.world_to_base(matmul(top, inv_rigid(hand.tcp_to_object)))
            branches, ok = wrap_to_limits(ik_all(tcp_top, TCP_OFFSET), q_now)
            branches = branches[ok]
            for k in np.argsort(np.linalg.norm(branches - q_now, axis=1), kind="stable")[1:]:
                release = self._release_plan(i, hand, t_obj, xy, yaw, transport_z, q_now, max_drop, branches[k])
                if not isinstance(release, str):
                    return release
                error = release
        return error

    def open_gripper(self, i: int, opening: float, gently: bool = False) -> Plan[None]:
        """OpenGripper: the arm still for ``open_time``, the fingers opened to ``opening`` [m]; ``gently``:
        the first control step only just past the command that releases the weld (``open_gently``).

        Opened at once from a weld, the position servo snaps the pads about 10 mm apart within a few
        milliseconds; a pad resting on shop-vrb scissors (5.6 g) dragged them sideways and down at 1.3 m/s,
        and the contacts (20 ms time constant) let them sink 13 mm, through a plate's 3 mm floor. A step
        just past the release lets them drop clear of the pads first (at most 0.34 m/s, 7 mm sideways)."""
        n = max(1, int(round(self.cfg.open_time / self.dt)))
        commands = np.full(n, _gripper_command(opening))
        if gently:
            commands[0] = min(commands[0], self.assist.attach_command + _GENTLE_OPENING * RELEASE_MARGIN)
        yield from self.run("OpenGripper", i, np.repeat(self.ctrl.target[None], n, axis=0), commands)

    def gripper_touches(self, i: int) -> bool:
        """Whether a part of the gripper is in contact with object ``i`` now (the last step's MuJoCo
        contacts): after the ease, a pad resting on a thin object's top (shop-vrb scissors)."""
        m, d = self.model, self.data
        body, grip = int(self.bodies.object_body[i]), self.bodies.gripper_bodies
        for k in range(d.ncon):
            b1, b2 = int(m.geom_bodyid[d.contact[k].geom1]), int(m.geom_bodyid[d.contact[k].geom2])
            if (b1 == body and b2 in grip) or (b2 == body and b1 in grip):
                return True
        return False

    def _roomy_first(self, i: int, task: Task, spots: list[tuple[np.ndarray, float]]
                     ) -> list[tuple[np.ndarray, float]]:
        """``spots`` for object ``i``, those that leave room for the task's objects still to come to
        the same table part first (:func:`~samplehd.motion.planner.leaves_room`), each group in its order."""
        to_come = [k for k in task.objects if k != i and k not in self.moved]
        if not to_come or get_family(task.family).destination != "table_part":
            return spots
        return sorted(spots, key=lambda s: not leaves_room(self.data, self.bodies, self.facts, i, s, to_come, task,
                                                           self.cfg, self.layout))

    def _second_look(self, i: int, task: Task, tried: list[tuple[np.ndarray, float]]
                     ) -> Iterator[tuple[np.ndarray, float]]:
        """More release spots for object ``i``, drawn only once every spot of ``tried`` has failed: a
        search with SPOT_SECOND_SAMPLES times the samples whose best SPOT_SECOND_LOOK are all tried
        (those of ``tried`` left out)."""
        cfg = dataclasses.replace(self.cfg, spot_samples=SPOT_SECOND_SAMPLES * self.cfg.spot_samples)
        spots = destination_candidates(self.data, self.bodies, self.facts, i, task, self.rng, cfg, self.layout,
                                       self.directions, shortlist=SPOT_SECOND_LOOK, options=SPOT_SECOND_LOOK)
        seen = {(float(xy[0]), float(xy[1]), yaw) for xy, yaw in tried}
        fresh = [(xy, yaw) for xy, yaw in spots if (float(xy[0]), float(xy[1]), yaw) not in seen]
        yield from self._turned_spots(self._roomy_first(i, task, fresh), i)

    def _turned_spots(self, spots: list[tuple[np.ndarray, float]], i: int) -> list[tuple[np.ndarray, float]]:
        """The release spots to try, in order: with ``turn_release`` and an object whose footprint is
        symmetric about its origin, each spot is followed by itself with the object turned half round."""
        facts = self.facts[i]
        if not self.turn_release or facts is None:
            return list(spots)
        lo, hi = np.asarray(facts.bbox_min, float)[:2], np.asarray(facts.bbox_max, float)[:2]
        if np.max(np.abs(lo + hi)) > _SYMMETRY_TOLERANCE:
            return list(spots)
        return [s for xy, yaw in spots for s in ((xy, yaw), (xy, yaw + math.pi))]

    def go_home(self, target: int, opening: float) -> Plan[None]:
        """MoveToDefaultPos: straight retreat up, then a joint-space move home."""
        self._sync()
        start = fk_tcp(self.ctrl.target)
        up = start.copy()
        up[2, 3] += self.cfg.retreat_distance
        gcmd = _gripper_command(opening)
        try:
            retreat = straight_move(self.checker, start, up, self.ctrl.target, opening, self.dt, self.cfg.lift_speed,
                                    check=False, ramp_time=self.cfg.line_ramp_time)
            q_up = retreat[-1] if len(retreat) else self.ctrl.target
            self.checker.sync(self.data)
            home, _ = plan_joint_move(self.checker, q_up, HOME_QPOS, opening, self.dt, self.cfg, self.rng,
                                      lift_z=self._tcp_world()[2, 3] + self.cfg.retreat_distance, robot=self.robot)
        except PlanningError as exc:
            raise AttemptFailed("no_path_home", str(exc)) from exc
        path = np.vstack([retreat, home]) if len(home) else retreat
        yield from self.run("MoveToDefaultPos", target, path, gcmd)

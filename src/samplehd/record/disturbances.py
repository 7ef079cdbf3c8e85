"""Disturbances of a recorded rollout, and the oracle's recovery from them: failure and recovery data.

With probability ``probability`` per episode, one disturbance of ``kinds`` is applied at a seeded
moment of the recorded rollout:

- ``missed_grasp``: the approach to the grasp stops short at a seeded point (the executed targets
  hold there), so the fingers close off the object;
- ``slip``: the gripper opens for a moment at a seeded point of the lift (MoveUP), the grasp rule
  releases the weld and the object drops (from a few centimetres: dropped from the transport height,
  cans and bottles land on their side, where no grasp of the planner reaches them);
- ``nudge``: the object to be grasped is pushed at a seeded point of the move towards it
  (GripperMoveAvoid): moved a seeded distance (3-6 cm) in a seeded horizontal direction over
  :data:`_PUSH_FRAMES` control steps, an equal part at the start of each and left at rest (a push by
  a force topples tall objects when friction stops them; this one slides them like a hand that
  pushes and lets go);
- ``wrong_object``: another object (seeded) is approached and grasped before the instructed one;
- ``short_release``: the transport stops at a seeded point, the object is lowered there onto the table
  and released, short of the destination (families that place only; in others the episode stays
  undisturbed). The release goes down as a place does (a collision-checked straight line, the fingers
  free to open at its end); where the object would come down on another object (the destination's rim,
  a plate on the way) or the way down is not free, it waits for the first point of the transport where
  it is: let go on a rim, an object topples, and no grasp of the planner reaches it on its side. A
  transport without such a point after the seeded one leaves the episode undisturbed.

A drawn disturbance whose moment never comes (a one-frame subtask, a family without it) leaves the
episode undisturbed and unlabelled; the dataset's unit then makes it again without the disturbance
(:func:`samplehd.dataset.work.run_episode_unit`), since a disturbed rollout steps its recorded vectors
(:class:`samplehd.record.recorder.ActionStep`) where an undisturbed one steps its joint targets.

The oracle is not told. It notices the state through the grasp rule (the object is not in the weld
after CloseGripper, leaves it while carried, or the weld holds another object than the one to move)
and through the success checker at the end of the plan, and it recovers by replanning from the
current state: open the gripper, back off home, grasp the object where it now lies, and go on: the
closed-loop oracle's one re-grasping plan (:func:`samplehd.motion.regrasp.regrasping_plan`), with more
failures recovered (:data:`RECOVERABLE`) and the labels kept.

The draw comes from its own stream, ``SeedSequence([episode seed, 0xD157])``: the episode's own
generator draws nothing new, so an episode drawn undisturbed is the episode a dataset without
disturbances has, byte for byte.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Generator
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from samplehd.errors import PlanningError
from samplehd.motion.execute import AttemptFailed, ControlTarget, Plan, Rollout, SubtaskCut
from samplehd.motion.planner import release_height, straight_move
from samplehd.motion.regrasp import regrasping_plan
from samplehd.record.episode import Episode
from samplehd.robot.constants import GRIPPER_STROKE, TCP_OFFSET
from samplehd.robot.controller import ControlReport
from samplehd.robot.kinematics import fk_tcp, ik_batch
from samplehd.schema import Config, bounded
from samplehd.tasks.task import Task, get_family
from samplehd.world.bodies import object_pose, object_world_box
from samplehd.world.collision import Held

__all__ = [
    "DISTURBANCE_KINDS",
    "LABEL_FIELDS",
    "Disturbance",
    "DisturbanceConfig",
    "Disturber",
    "draw_disturbance",
]

DISTURBANCE_KINDS = ("missed_grasp", "slip", "nudge", "wrong_object", "short_release")
_STREAM = 0xD157  # the seed stream of disturbance draws

# Per-frame labels an episode with a disturbance carries beside its FRAME_FIELDS: (T,) int8 flags.
LABEL_FIELDS: dict[str, tuple[tuple[str | int, ...], str]] = {
    "disturbance_active": ((), "i1"),
    "recovery": ((), "i1"),
}

# Where in its subtask each kind strikes: the progress in [lo, hi] of that subtask.
_MOMENTS: dict[str, tuple[str, float, float]] = {
    "missed_grasp": ("ApproachGrasp", 0.1, 0.4),
    "slip": ("MoveUP", 0.3, 0.8),
    "nudge": ("GripperMoveAvoid", 0.5, 0.9),
    "wrong_object": ("GripperMoveAvoid", 0.0, 0.0),
    "short_release": ("ObjectMove", 0.3, 0.6),
}
_NUDGE_DISTANCE = (0.03, 0.06)  # how far a push moves an object [m]
_PUSH_FRAMES = 4  # control steps a push lasts
_SLIP_FRAMES = 3  # control steps the gripper stays open in a slip (or until the oracle notices)
_ON_TABLE = 0.004  # a short release's object rests on the table when it comes to rest this close to it [m]
# Failures (AttemptFailed reasons) the oracle recovers from by opening, backing off and grasping again.
RECOVERABLE = ("grasp_missed", "grasp_slipped", "wrong_object", "approach_blocked", "not_holding")


@dataclass(frozen=True)
class DisturbanceConfig(Config, section="disturbances"):
    """Disturbances applied to generated episodes (see the module docstring).

    Attributes:
        probability: chance that an episode gets one disturbance (0: none, the section is off).
        kinds: the kinds drawn from, uniformly.
        max_recoveries: recoveries the oracle attempts before the episode is kept as a failure.
    """

    probability: float = bounded(0.0, lo=0.0, hi=1.0)
    kinds: tuple[str, ...] = bounded(DISTURBANCE_KINDS, choices=DISTURBANCE_KINDS, nonempty=True, unique=True)
    max_recoveries: int = bounded(3, lo=1, hi=10)

    @property
    def enabled(self) -> bool:
        """Whether any episode can be disturbed."""
        return self.probability > 0.0


@dataclass(frozen=True)
class Disturbance:
    """One drawn disturbance.

    Attributes:
        kind: one of :data:`DISTURBANCE_KINDS`.
        subtask: the subtask it strikes in (the first one of that name, first moved object).
        progress: where in that subtask, in [0, 1].
        direction: nudge: horizontal push direction [rad, world frame].
        distance: nudge: how far the push moves the object [m].
        other: wrong_object: rank among the other objects (the object is ``others[other % len]``).
    """

    kind: str
    subtask: str
    progress: float
    direction: float = 0.0
    distance: float = 0.0
    other: int = 0

    def to_dict(self) -> dict[str, object]:
        return {"kind": self.kind, "subtask": self.subtask, "progress": self.progress, "direction": self.direction,
                "distance": self.distance, "other": self.other}


def draw_disturbance(config: DisturbanceConfig, seed: int) -> Disturbance | None:
    """The disturbance of the episode with seed ``seed`` (None: undisturbed), from its own stream."""
    if not config.enabled:
        return None
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), _STREAM]))
    if rng.random() >= config.probability:
        return None
    kind = config.kinds[int(rng.integers(len(config.kinds)))]
    subtask, lo, hi = _MOMENTS[kind]
    progress = float(rng.uniform(lo, hi))
    direction = float(rng.uniform(-math.pi, math.pi))
    distance = float(rng.uniform(*_NUDGE_DISTANCE))
    other = int(rng.integers(1 << 16))
    return Disturbance(kind, subtask, progress, direction, distance, other)


@dataclass
class _Labels:
    """What happened, filled in as the rollout runs (frames are recorded frame indices)."""

    frame: int = -1
    last: int = -1
    object: int = -1
    failure: str = ""
    message: str = ""
    noticed: int = -1
    recovery_first: int = -1
    recovery_last: int = -1
    recoveries: int = 0
    params: dict[str, Any] = field(default_factory=dict)


class Disturber:
    """Applies one :class:`Disturbance` to a rollout and keeps its labels.

    It acts in two places: :meth:`step` wraps the step function that executes control targets (it
    changes the executed target or the physics state at the seeded moment; what it executes is what
    is recorded, so the recorded actions replay it), and :meth:`plan` is the recovering plan of the
    task that the rollout runs instead of the plain one.

    Args:
        disturbance: what to apply.
        ro: the rollout (its subtasks, grasp rule, state).
        max_recoveries: recoveries before giving up.
    """

    def __init__(self, disturbance: Disturbance, ro: Rollout, max_recoveries: int = 3) -> None:
        self.d = disturbance
        self.ro = ro
        self.max_recoveries = max_recoveries
        self.labels = _Labels()
        self._hold: np.ndarray | None = None  # missed_grasp / short_release: joints the arm holds at
        self._open_until = -1  # slip: the gripper stays open until this frame
        self._recovering = False  # a recovery has begun and the object is not held again yet

    @property
    def fired(self) -> bool:
        """Whether the disturbance has been applied."""
        return self.labels.frame >= 0

    # ------------------------------------------------------------------ executed targets
    def step(self, inner: Callable[[ControlTarget | SubtaskCut], ControlReport | None]
             ) -> Callable[[ControlTarget | SubtaskCut], ControlReport | None]:
        """The step function ``inner`` with the disturbance applied to the targets it executes."""

        def disturbed(item: ControlTarget | SubtaskCut) -> ControlReport | None:
            if isinstance(item, ControlTarget):
                item = self._apply(item)
            return inner(item)

        return disturbed

    def _frame(self) -> int:
        """The frame the target being executed is recorded as."""
        return self.ro.steps - 1

    def _strikes(self, item: ControlTarget) -> bool:
        ro, d = self.ro, self.d
        subtask = d.subtask
        return (not self.fired and ro.subtasks[item.subtask] == subtask and item.progress >= d.progress
                and ro.subtasks.count(subtask) == 1)

    def _apply(self, item: ControlTarget) -> ControlTarget:
        ro, d, lab = self.ro, self.d, self.labels
        frame = self._frame()
        if d.kind == "missed_grasp":
            if self._hold is None and self._strikes(item):
                self._hold = item.joints.copy()
                lab.frame, lab.object = frame, item.target_object
                return item
            if self._hold is not None and ro.subtasks[item.subtask] == "ApproachGrasp" and self.labels.failure == "":
                lab.last = frame
                return replace(item, joints=self._hold.copy(), steering=_still(item.gripper))
            if self._hold is not None and ro.subtasks[item.subtask] != "ApproachGrasp":
                self._hold = None
            return item
        if d.kind == "slip":
            if self._strikes(item) and ro.assist.active >= 0:
                lab.frame, lab.object = frame, ro.assist.active
                self._open_until = frame + _SLIP_FRAMES - 1
            if self.fired and frame <= self._open_until and not lab.failure:
                lab.last = frame
                return self._opened(item)
            return item
        if d.kind == "nudge":
            if self._strikes(item):
                lab.frame, lab.object = frame, item.target_object
                lab.last = frame + _PUSH_FRAMES - 1
                step = d.distance / _PUSH_FRAMES * np.array([math.cos(d.direction), math.sin(d.direction)])
                lab.params = {"push_step": [float(v) for v in step], "push_frames": _PUSH_FRAMES}
            if self.fired and lab.frame <= frame <= lab.last:
                _push_step(ro, lab.object, np.asarray(lab.params["push_step"]))
            return item
        return item

    def _opened(self, item: ControlTarget) -> ControlTarget:
        """The target with the gripper opened: the grasp rule (applied by the step with this command)
        releases the weld in this step."""
        command = 1.0
        steering = item.steering.copy()
        steering[6] = command
        return replace(item, gripper=command, steering=steering, held=None)

    # ------------------------------------------------------------------ the recovering plan
    def plan(self, task: Task, exclude: dict[int, set[int]]) -> Plan[None]:
        """The task's plan with the oracle's recovery (:func:`samplehd.motion.regrasp.regrasping_plan`):
        each moved object in the planner's order is picked (and placed); once the disturbance has been
        applied, a failure of :data:`RECOVERABLE` is answered by backing off and grasping again.

        The disturbance's own failure leaves its grasp to be tried again (the failure says nothing
        against the grasp it struck); a grasp that fails in a recovery is not tried again.
        """
        before = (lambda i: self._grasp_wrong(task, i)) if self.d.kind == "wrong_object" else None
        yield from regrasping_plan(self.ro, task, self.max_recoveries, reasons=RECOVERABLE, exclude=exclude,
                                   watch=self._watched, before=before, on_failure=self._noticed,
                                   on_grasp=self._grasped)

    def _noticed(self, exc: AttemptFailed) -> bool:
        """A failure the recovery answers: labelled (the first one is the disturbance's); returns whether
        the grasp that failed is excluded from the next picks. Before the disturbance nothing is
        recovered: the failure propagates."""
        lab = self.labels
        if not self.fired:
            raise exc
        exclude = bool(lab.failure)
        if not lab.failure:
            lab.failure, lab.message = exc.reason, str(exc)
            lab.noticed = self._frame()
            lab.last = max(lab.last, lab.frame)
        if lab.recovery_first < 0:
            lab.recovery_first = self.ro.steps
        lab.recoveries += 1
        self._recovering = True
        return exclude

    def _grasped(self, i: int) -> None:
        """A pick succeeded: a recovery in progress ends with the object held again."""
        if self._recovering:
            self.labels.recovery_last = self._frame()
            self._recovering = False

    def _grasp_wrong(self, task: Task, i: int) -> Plan[None]:
        """wrong_object: approach and close on another object first (it is not lifted); the oracle sees
        in the grasp rule that the weld holds another object than ``i``."""
        ro, lab = self.ro, self.labels
        others = [j for j in range(ro.bodies.num_objects) if j not in task.involved]
        if not others:
            return
        j = others[self.d.other % len(others)]
        lab.frame, lab.object = ro.steps, j
        lab.params = {"instructed_object": i}
        try:
            yield from ro.pick(j, lift=False)
        except AttemptFailed as exc:
            if exc.reason == "no_feasible_grasp" and ro.steps == lab.frame:
                lab.frame, lab.object, lab.params = -1, -1, {}  # nothing happened: the episode goes on undisturbed
                return
            raise AttemptFailed("wrong_object", f"object {j} approached instead of object {i}") from None
        lab.last = self._frame()
        if ro.assist.active != i:
            raise AttemptFailed("wrong_object", f"the gripper holds object {ro.assist.active}, not object {i}")

    def _watched(self, plan: Plan[Any]) -> Generator[ControlTarget | SubtaskCut, ControlReport | None, Any]:
        """``plan`` watched step by step: while an object is carried (MoveUP, ObjectMove, MoveDOWN) it must stay in
        the weld; when it does not, the plan hears that it slipped. A short release strikes here too."""
        ro = self.ro
        try:
            item = next(plan)
            while True:
                report = yield item
                if isinstance(item, SubtaskCut):
                    item = plan.send(report)
                    continue
                name = ro.subtasks[-1] if ro.subtasks else ""
                down = None
                if self.d.kind == "short_release" and not self.fired and ro.hand is not None and self._strikes(item):
                    down = self._lowering(ro.hand.index)
                if down is not None:
                    plan.close()
                    yield from self._release_here(ro.hand.index, down)
                    return None
                if (ro.hand is not None and name in ("MoveUP", "ObjectMove", "MoveDOWN")
                        and ro.assist.available and ro.assist.active != ro.hand.index):
                    item = plan.throw(AttemptFailed("grasp_slipped", f"object {ro.hand.index} slipped out of "
                                                                     f"the gripper in {name}"))
                else:
                    item = plan.send(report)
        except StopIteration as stop:
            return stop.value

    def _opening(self) -> float:
        """How wide the fingers open to let the held object go [m]."""
        ro = self.ro
        return max(ro.hand.opening, (ro.assist.release_command() + 1.0) * 0.5 * GRIPPER_STROKE)

    def _lowering(self, i: int) -> np.ndarray | None:
        """short_release: the way down from where the held object ``i`` is, as a place goes down: timed joint
        targets of a straight, collision-checked TCP line until the object is just above the table, the
        fingers free to open there. None where the object would come down on another object (let go on a
        rim or a top, it topples, and no grasp of the planner reaches an object on its side), where the
        line or the opening fingers collide, or where the pose is out of reach."""
        ro = self.ro
        ro._sync()
        t_obj = object_pose(ro.data, ro.bodies, i)
        table = ro.layout.table_height + t_obj[2, 3] - object_world_box(ro.model, ro.data, ro.bodies, i).lo[2]
        try:
            z_rel = release_height(ro.checker, ro.bodies, i, t_obj[:3, :3], t_obj[:2, 3], t_obj[2, 3], table - 0.001)
        except PlanningError:  # it touches something where it is
            return None
        if z_rel > table + _ON_TABLE:
            return None
        end_w = ro._tcp_world()
        end_w[2, 3] -= max(0.0, t_obj[2, 3] - (z_rel + ro.cfg.release_gap))
        end_b = ro.robot.world_to_base(end_w)
        q, ok = ik_batch(end_b[None], ro.ctrl.target[None], TCP_OFFSET)
        held = Held(i, ro.hand.tcp_to_object)
        if not ok[0] or not ro.checker.free(q[0], self._opening(), held, allow_objects_with_gripper=(i,)):
            return None
        try:
            return straight_move(ro.checker, fk_tcp(ro.ctrl.target), end_b, ro.ctrl.target, 0.0, ro.dt,
                                 ro.cfg.approach_speed, held=held, ramp_time=ro.cfg.line_ramp_time)
        except PlanningError:
            return None

    def _release_here(self, i: int, down: np.ndarray) -> Plan[None]:
        """short_release: the transport stops; the object is lowered along ``down`` onto the table and
        released."""
        ro, lab = self.ro, self.labels
        lab.frame, lab.object = self._frame(), i
        opening = self._opening()
        if len(down):
            yield from ro.run("MoveDOWN", i, down)
        yield from ro.hold("OpenGripper", i, ro.cfg.open_time, 2.0 * opening / GRIPPER_STROKE - 1.0)
        lab.last = self._frame()
        ro.hand = None
        yield from ro.go_home(i, opening)

    def notice_check(self, reason: str) -> None:
        """The checker found the final state failed after the disturbance: a recovery starts here."""
        lab = self.labels
        if not lab.failure:
            lab.failure, lab.message = "checker_failed", reason
            lab.noticed = self._frame() + 1
        if lab.recovery_first < 0:
            lab.recovery_first = self.ro.steps
        lab.recoveries += 1

    def recovery_plan(self, task: Task) -> Plan[None]:
        """After the checker noticed a failure: every moved object is grasped where it lies and moved again."""
        ro = self.ro
        remaining = list(task.objects)
        places = get_family(task.family).places
        while remaining:
            i = ro.next_object(task, remaining)
            remaining.remove(i)
            k = yield from self._watched(ro.pick(i))
            if places:
                yield from self._watched(ro.place(i, task, k))

    def finish(self, episode: Episode, success: bool, reason: str) -> Episode:
        """The episode with its disturbance labels: ``info["disturbance"]`` and the per-frame flags."""
        lab = self.labels
        t = episode.num_frames
        last = t - 1
        if lab.recovery_first >= 0 and (lab.recovery_last < 0 or not success):
            lab.recovery_last = last
        active = np.zeros(t, np.int8)
        if lab.frame >= 0:
            active[lab.frame:max(lab.frame, lab.last) + 1] = 1
        recovery = np.zeros(t, np.int8)
        if lab.recovery_first >= 0:
            recovery[lab.recovery_first:lab.recovery_last + 1] = 1
        label = {
            **self.d.to_dict(),
            "frame": lab.frame,
            "last_frame": max(lab.frame, lab.last),
            "object": lab.object,
            "failure": lab.failure,
            "failure_message": lab.message,
            "noticed_frame": lab.noticed,
            "recovery_first": lab.recovery_first,
            "recovery_last": lab.recovery_last,
            "recoveries": lab.recoveries,
            "success": bool(success),
            "outcome": "recovered" if success and lab.failure else ("absorbed" if success else "failed"),
            "reason": "" if success else reason,
            **lab.params,
        }
        frames = {**episode.frames, "disturbance_active": active, "recovery": recovery}
        info = {**episode.info, "disturbance": label}
        return replace(episode, frames=frames, info=info, success=bool(success))


def _push_step(ro: Rollout, i: int, step: np.ndarray) -> None:
    """One step of a nudge: object ``i`` moved by ``step`` [m, world x and y] and put at rest."""
    m, d = ro.model, ro.data
    joint = int(m.body_jntadr[ro.bodies.object_body[i]])
    adr, dof = int(m.jnt_qposadr[joint]), int(m.jnt_dofadr[joint])
    d.qpos[adr:adr + 2] += step
    d.qvel[dof:dof + 6] = 0.0


def _still(gripper: float) -> np.ndarray:
    steer = np.zeros(7, np.float32)
    steer[6] = gripper
    return steer

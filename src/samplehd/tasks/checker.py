"""The success checker: one documented predicate per task family, used by the ground-truth path
generator, the Gymnasium environment and evaluation alike.

The checker first lets the world run on a scratch copy of the state for ``config.window`` seconds
with the controls unchanged (the arm holds its pose), so "resting" and "stable" mean the objects stay
put for that long; then it evaluates the family's predicate on the final state. The state passed in
is never modified.

Predicates (tolerances are the fields of :class:`CheckerConfig`):

- **resting** (used below): the object touches no gripper body, its drift over the window is at
  most ``stable_drift`` and its speed at the end at most ``rest_speed``.
- **place**: every moved object is resting and its centre lies inside the destination table part
  (``samplehd.world.layout.table_parts_of``; the neutral band counts as outside).
- **remove**: every moved object is resting, none lies in the cleared part and each lies in the
  opposite part.
- **stack** / **stack_three**: each moved object is resting, in contact with the object below it,
  its bottom at least ``stack_min_rise`` above the bottom of that object, and its centre over that
  object's footprint (bounding box in x, y grown by ``footprint_margin``); the object below is
  stable too (for stack_three: middle on bottom, top on middle).
- **put**: the object is resting, its centre is inside the container's footprint shrunk by
  ``container_margin`` and its bottom is below the container's rim (top of its bounding box).
- **place_relative**: the object is resting on the table and its offset from the reference object,
  projected on the scene's direction vector, exceeds ``relation_margin``.
- **pick_up**: the object's bottom is at least ``lift_height`` above the table top, it touches a
  finger (or hangs in the grasp assist's weld) and nothing but the robot, and it does not drop
  during the window.

Independently of success the report lists objects the task does not name that were **disturbed**
(moved more than ``disturb_distance`` or turned more than ``disturb_angle`` from their scene pose)
and objects that **fell** (tipped more than ``fall_angle`` or left the table top).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, TypedDict

import mujoco
import numpy as np

from samplehd.fixedmath import dot, norm
from samplehd.physics import wake_all
from samplehd.scene.spec import SceneSpec
from samplehd.schema import Config, bounded
from samplehd.tasks.task import ProgramTask, Task, get_family, parse_task
from samplehd.world.bodies import SceneBodies, contact_pairs, object_world_box, object_world_hull_box, quat_tilt
from samplehd.world.layout import DIRECTIONS, LAYOUT, Directions, TableLayout

__all__ = ["CheckReport", "CheckResult", "CheckerConfig", "Judge", "check_success", "welded"]


@dataclass(frozen=True)
class CheckerConfig(Config, section="checker"):
    """Tolerances of the success checker.

    Attributes:
        window: time the state runs on before it is judged (stability window) [s].
        rest_speed: largest linear speed of a resting object at the end [m/s].
        stable_drift: largest displacement of a resting object over the window [m].
        footprint_margin: growth of the lower object's footprint for stacking [m].
        stack_min_rise: smallest height of a stacked object's bottom above the lower one's bottom [m].
        container_margin: shrink of the container's footprint for put [m].
        rim_tolerance: how far above the rim an object's bottom may be and still count as inside [m].
        relation_margin: smallest projected offset for place_relative [m].
        lift_height: smallest height of a picked object's bottom above the table [m].
        disturb_distance: displacement that counts as disturbing an uninvolved object [m].
        disturb_angle: rotation that counts as disturbing an uninvolved object [rad].
        fall_angle: tilt that counts as falling over [rad].
    """

    window: float = bounded(1.0, lo=0.0, unit="s")
    rest_speed: float = bounded(0.02, lo=0.0, unit="m/s")
    stable_drift: float = bounded(0.01, lo=0.0, unit="m")
    footprint_margin: float = bounded(0.01, lo=0.0, unit="m")
    stack_min_rise: float = bounded(0.001, lo=0.0, unit="m")
    container_margin: float = bounded(0.005, lo=0.0, unit="m")
    rim_tolerance: float = bounded(0.01, lo=0.0, unit="m")
    relation_margin: float = bounded(0.02, lo=0.0, unit="m")
    lift_height: float = bounded(0.05, lo=0.0, unit="m")
    disturb_distance: float = bounded(0.02, lo=0.0, unit="m")
    disturb_angle: float = bounded(0.26, lo=0.0, unit="rad")
    fall_angle: float = bounded(0.79, lo=0.0, unit="rad")


class CheckReport(TypedDict):
    """A :class:`CheckResult` as JSON (:meth:`CheckResult.to_dict`): the same fields, tuples as lists."""

    success: bool
    family: str
    reason: str
    disturbed: list[int]
    fallen: list[int]
    details: dict[str, Any]


@dataclass(frozen=True)
class CheckResult:
    """The checker's verdict.

    Attributes:
        success: the family's predicate holds.
        family: task family.
        reason: why it failed (empty on success), e.g. "object 2 not in part left".
        disturbed: uninvolved objects that moved or turned beyond the tolerances.
        fallen: objects (any) that tipped over or left the table.
        details: per-object measurements (JSON-ready).
    """

    success: bool
    family: str
    reason: str = ""
    disturbed: tuple[int, ...] = ()
    fallen: tuple[int, ...] = ()
    details: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> CheckReport:
        return {
            "success": self.success,
            "family": self.family,
            "reason": self.reason,
            "disturbed": list(self.disturbed),
            "fallen": list(self.fallen),
            "details": self.details,
        }

    @classmethod
    def from_dict(cls, d: CheckReport) -> CheckResult:
        return cls(bool(d["success"]), str(d["family"]), str(d.get("reason", "")),
                   tuple(d.get("disturbed", ())), tuple(d.get("fallen", ())), dict(d.get("details", {})))


class Judge:
    """Measurements of the final state, shared by the predicates."""

    def __init__(self, model: mujoco.MjModel, start: mujoco.MjData, end: mujoco.MjData, bodies: SceneBodies,
                 config: CheckerConfig, layout: TableLayout, directions: Directions) -> None:
        self.model, self.start, self.end, self.b, self.cfg, self.layout = model, start, end, bodies, config, layout
        self.directions = directions
        self.contacts = contact_pairs(model, end)

    def pos(self, i: int, data: mujoco.MjData | None = None) -> np.ndarray:
        return (data or self.end).xpos[self.b.object_body[i]].copy()

    def touching(self, i: int, bodies: set[int] | int) -> bool:
        bi = int(self.b.object_body[i])
        others = {bodies} if isinstance(bodies, int) else bodies
        return any((min(bi, o), max(bi, o)) in self.contacts for o in others)

    def resting(self, i: int) -> str:
        """Empty string if object i rests, else why not."""
        if self.touching(i, self.b.gripper_bodies):
            return f"object {i} still touches the gripper"
        drift = float(norm(self.pos(i) - self.pos(i, self.start)))
        if drift > self.cfg.stable_drift:
            return f"object {i} moved {drift * 1000:.0f} mm during the {self.cfg.window:.1f} s window"
        speed = float(norm(self.end.cvel[self.b.object_body[i], 3:]))
        if speed > self.cfg.rest_speed:
            return f"object {i} still moves at {speed:.3f} m/s"
        return ""

    def on_table(self, i: int) -> bool:
        box = object_world_box(self.model, self.end, self.b, i)
        return box.lo[2] < self.layout.table_height + 0.01 or self.touching(i, self.b.table_body)

    def stacked(self, top: int, base: int) -> str:
        if r := self.resting(top):
            return r
        if not self.touching(top, int(self.b.object_body[base])):
            return f"object {top} does not touch object {base}"
        if (object_world_hull_box(self.model, self.end, self.b, top).lo[2]
                < object_world_hull_box(self.model, self.end, self.b, base).lo[2] + self.cfg.stack_min_rise):
            return f"object {top} is not above object {base}"
        bb = object_world_box(self.model, self.end, self.b, base)
        if not bb.contains_xy(self.pos(top), -self.cfg.footprint_margin):
            return f"object {top} is not over the footprint of object {base}"
        return ""


def welded(model: mujoco.MjModel, data: mujoco.MjData, i: int) -> bool:
    """Whether object i hangs in the grasp assist's weld (``samplehd.motion.assist``)."""
    e = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, f"grasp_weld_{i}")
    return e >= 0 and bool(data.eq_active[e])


def _simulate_window(model: mujoco.MjModel, data: mujoco.MjData, window: float) -> mujoco.MjData:
    end = mujoco.MjData(model)
    mujoco.mj_copyData(end, model, data)
    # Judge real physics, not sleep: an object asleep where nothing holds it falls in the window.
    wake_all(end)
    # nothing is read between the steps: MuJoCo's own loop (the same steps, without a Python call each)
    mujoco.mj_step(model, end, int(round(window / model.opt.timestep)))
    mujoco.mj_forward(model, end)
    return end


def check_success(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    scene: SceneSpec,
    task: ProgramTask | Task,
    config: CheckerConfig | None = None,
    layout: TableLayout = LAYOUT,
    directions: Directions | None = None,
) -> CheckResult:
    """Judge whether the task is fulfilled in the state ``data``.

    Args:
        model: the compiled scene (``samplehd.scene.spec.compile_scene``).
        data: the state to judge; not modified (the window runs on a copy).
        scene: the ``SceneSpec`` the episode started from (initial poses for disturbance).
        task: the executor's task dict or a parsed :class:`~samplehd.tasks.task.Task`.
        config: tolerances; defaults to :class:`CheckerConfig`.
        layout: table layout (table parts).
        directions: the scene's ground-plane direction vectors (CLEVR ``directions``); defaults to
            ``samplehd.world.layout.DIRECTIONS``.

    Returns:
        The verdict with the reason for a failure and the disturbed/fallen objects.
    """
    config = config or CheckerConfig()
    t = parse_task(task)
    n = len(scene.objects)
    bodies = SceneBodies(model, n)
    start = mujoco.MjData(model)
    mujoco.mj_copyData(start, model, data)
    mujoco.mj_forward(model, start)
    end = _simulate_window(model, start, config.window)
    j = Judge(model, start, end, bodies, config, layout, directions or DIRECTIONS)
    reason, details = get_family(t.family).check(j, t)
    # Disturbance and falls, relative to the scene's initial poses.
    moved_ok = set(t.objects)
    disturbed, fallen = [], []
    for k in range(n):
        p0 = np.asarray(scene.objects[k].pos, dtype=float)
        q0 = np.asarray(scene.objects[k].quat, dtype=float)
        p1 = j.pos(k)
        q1 = end.xquat[bodies.object_body[k]]
        tilt = quat_tilt(q0, q1)
        if tilt > config.fall_angle or p1[2] < layout.table_height - 0.05:
            fallen.append(k)
        if k in moved_ok:
            continue
        qd = abs(float(dot(q0, q1)))
        ang = 2.0 * math.acos(min(1.0, qd))
        if norm(p1 - p0) > config.disturb_distance or ang > config.disturb_angle:
            disturbed.append(k)
    return CheckResult(not reason, t.family, reason, tuple(disturbed), tuple(fallen), details)


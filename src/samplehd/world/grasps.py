"""The grasp registry: candidate grasps per object, as TCP poses in the object frame.

Candidates come from the catalogue's per-instance grasp sites (rims of bowls, trays and pans,
handles of mugs, pans and scissors, bodies of cans, glasses and thermoses, across cutlery handles,
edges of boards), expanded by the rules below, and, for objects without sites (imported meshes),
derived from the object's bounding box. :func:`grasp_candidates` lists them best first; the
feasibility query :func:`choose_grasps` picks per instance by reachability (analytic IK), a
collision-free approach and finger clearance; :func:`graspable_in_scene` asks it once per scene
object, so scenes and instructions only name objects the arm can take.

Rules (data, one entry per site name in :data:`GRASP_RULES`):

- ``yaws``: for axisymmetric sites, how many rotations about the object's z axis to try.
- ``top_down``: side-approach sites (approach horizontal) also get a top-down variant, the fingers
  reaching ``finger_reach`` below the top.
- ``clearance``: room left between each finger and the object when the gripper opens [m] (less,
  down to :data:`MIN_CLEARANCE`, for objects nearly as wide as the stroke).
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import math
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from samplehd.catalogue import ObjectFacts
from samplehd.fixedmath import dot, matmul, norm
from samplehd.robot.constants import GRIPPER_STROKE, HOME_QPOS, TCP_OFFSET
from samplehd.robot.kinematics import ik_all, ik_batch, wrap_to_limits
from samplehd.world.bodies import SceneBodies, object_pose, object_world_box
from samplehd.world.collision import CollisionChecker
from samplehd.world.layout import LAYOUT, TableLayout
from samplehd.world.planner_config import PlannerConfig
from samplehd.world.robot_info import RobotInfo

__all__ = [
    "GRASP_RULES",
    "MIN_CLEARANCE",
    "Grasp",
    "GraspPlan",
    "GraspRule",
    "choose_grasps",
    "grasp_candidates",
    "graspable_in_scene",
    "ik_candidates",
    "ik_near",
    "PINCH_TOLERANCE",
    "pinch_gaps",
    "register_grasp_rule",
]

MIN_CLEARANCE = 0.0015  # [m] least room between a finger and the object when the gripper is fully open


@dataclass(frozen=True)
class Grasp:
    """A grasp: where the TCP goes relative to the object and how the fingers close.

    Attributes:
        name: site kind ("body", "rim", "handle", "edge", "box").
        position: TCP position in the object frame [m].
        approach: unit vector the gripper moves along to reach the grasp (object frame); the TCP z
            axis points along it.
        closing: unit vector along which the fingers close (object frame), orthogonal to approach.
        width: extent of the object between the fingers [m].
        opening: finger opening before closing [m] (≤ the stroke).
    """

    name: str
    position: tuple[float, float, float]
    approach: tuple[float, float, float]
    closing: tuple[float, float, float]
    width: float
    opening: float

    def rotation(self, finger_axis: np.ndarray) -> np.ndarray:
        """TCP orientation in the object frame (3×3).

        Args:
            finger_axis: the TCP-frame axis the fingers close along (unit, orthogonal to TCP z).
        """
        z = np.asarray(self.approach, dtype=float)
        c = np.asarray(self.closing, dtype=float)
        c = c - dot(c, z) * z
        c /= norm(c)
        fa = np.asarray(finger_axis, dtype=float)
        # Map TCP frame (fa, z × fa, z) onto the object frame (c, z × c, z).
        tcp_basis = np.column_stack([fa, np.cross([0.0, 0.0, 1.0], fa), [0.0, 0.0, 1.0]])
        obj_basis = np.column_stack([c, np.cross(z, c), z])
        return matmul(obj_basis, tcp_basis.T)

    def pose(self, finger_axis: np.ndarray) -> np.ndarray:
        """4×4 TCP pose in the object frame."""
        t = np.eye(4)
        t[:3, :3] = self.rotation(finger_axis)
        t[:3, 3] = self.position
        return t

    def to_dict(self) -> dict[str, object]:
        return {
            "name": self.name,
            "position": list(self.position),
            "approach": list(self.approach),
            "closing": list(self.closing),
            "width": self.width,
            "opening": self.opening,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Grasp:
        return cls(
            str(d["name"]),
            tuple(float(v) for v in d["position"]),  # type: ignore[arg-type]
            tuple(float(v) for v in d["approach"]),  # type: ignore[arg-type]
            tuple(float(v) for v in d["closing"]),  # type: ignore[arg-type]
            float(d["width"]),
            float(d["opening"]),
        )


@dataclass(frozen=True)
class GraspRule:
    """How sites of one kind are expanded into grasps.

    Attributes:
        yaws: rotations about the object z axis tried for axisymmetric sites.
        top_down: add a top-down variant of side-approach sites.
        clearance: room between each finger and the object when open [m].
        finger_reach: how far below the object's top the fingertips may reach top-down [m].
        priority: sites with a lower value are tried first (then in the catalogue's order).
    """

    yaws: int = 8
    top_down: bool = True
    clearance: float = 0.012
    finger_reach: float = 0.035
    priority: int = 1


# Handles are tried last: a pinch across a thin loop of convex pieces chatters in MuJoCo and can
# spike the contact force, so bodies and rims go first where they fit.
GRASP_RULES: dict[str, GraspRule] = {
    "body": GraspRule(yaws=8, top_down=True, clearance=0.012, priority=0),
    "rim": GraspRule(yaws=12, top_down=True, clearance=0.007, priority=1),
    "handle": GraspRule(yaws=1, clearance=0.012, priority=2),
    "edge": GraspRule(yaws=1, top_down=False, clearance=0.01, priority=3),
    "box": GraspRule(yaws=1, clearance=0.012, priority=1),
}


def register_grasp_rule(name: str, rule: GraspRule) -> None:
    """Add or replace the rule for grasp sites named ``name``."""
    GRASP_RULES[name] = rule


def _rotz(v: np.ndarray, a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]])


def _t(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def _opening(width: float, clearance: float, stroke: float) -> float:
    return float(min(stroke, width + 2 * clearance))


RELEASE_CLEARANCE = 0.003  # [m] least room per finger around an object's widest part, fully open


def _clears_widest(closing: np.ndarray, lo: np.ndarray, hi: np.ndarray, stroke: float) -> bool:
    """Whether fingers coming from above along ``closing`` pass the object's widest part when open.

    A side site's closing line taken from above sits higher than the site, where a flared object
    (a wine glass's bowl, a bottle's shoulder) may be wider than the site: the fingers would close
    under the flare and could not open past it to let go. The bounding box bounds every height.
    """
    size = hi - lo
    widest = abs(float(closing[0])) * size[0] + abs(float(closing[1])) * size[1]
    return widest + 2 * RELEASE_CLEARANCE <= stroke


def grasp_candidates(
    sites: Any,
    bbox_min: np.ndarray,
    bbox_max: np.ndarray,
    stroke: float = GRIPPER_STROKE,
) -> list[Grasp]:
    """Candidate grasps of one object instance, best first.

    Args:
        sites: the catalogue's grasp sites (objects with name, position, approach, closing, width,
            axisymmetric), best first; may be empty.
        bbox_min: lower corner of the object's bounding box in its frame [m].
        bbox_max: upper corner [m].
        stroke: largest finger opening [m].

    Returns:
        Grasps whose width leaves each finger its clearance within the stroke.
    """
    lo, hi = np.asarray(bbox_min, float), np.asarray(bbox_max, float)
    top = float(hi[2])
    out: list[Grasp] = []
    for site in sites or ():
        rule = GRASP_RULES.get(site.name, GraspRule())
        if site.width + 2 * MIN_CLEARANCE > stroke:
            continue
        pos = np.asarray(site.position, float)
        app = np.asarray(site.approach, float)
        clo = np.asarray(site.closing, float)
        variants: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        if abs(app[2]) < 0.5 and rule.top_down and _clears_widest(clo, lo, hi, stroke):
            # Side approach: also take the same closing line from above, as deep as the fingers reach.
            z = max(pos[2], top - rule.finger_reach, 0.5 * top)
            variants.append((np.array([pos[0], pos[1], z]), np.array([0.0, 0.0, -1.0]), clo))
        if app[2] < -0.5 or not rule.top_down:
            variants.append((pos, app, clo))
        n_yaw = rule.yaws if getattr(site, "axisymmetric", False) else 1
        for p, a, c in variants:
            for k in range(n_yaw):
                yaw = 2 * math.pi * k / n_yaw
                out.append(Grasp(site.name, _t(_rotz(p, yaw)), _t(_rotz(a, yaw)), _t(_rotz(c, yaw)),
                                 float(site.width), _opening(site.width, rule.clearance, stroke)))
            if n_yaw == 1 and a[2] < -0.5:
                # A top-down pinch is symmetric under a half turn; the planner may prefer either.
                out.append(Grasp(site.name, _t(p), _t(a), _t(-c), float(site.width),
                                 _opening(site.width, rule.clearance, stroke)))
    if not out:
        out = _box_grasps(lo, hi, stroke)
    return sorted(out, key=lambda g: GRASP_RULES.get(g.name, GraspRule()).priority)


def _box_grasps(lo: np.ndarray, hi: np.ndarray, stroke: float) -> list[Grasp]:
    """Top-down grasps across the narrower horizontal side of the bounding box (imported meshes)."""
    rule = GRASP_RULES["box"]
    size = hi - lo
    c = (lo + hi) / 2
    z = max(lo[2] + 0.5 * size[2], hi[2] - rule.finger_reach)
    out = []
    for axis in np.argsort(size[:2]):
        w = float(size[axis])
        if w + 2 * MIN_CLEARANCE > stroke:
            continue
        closing = np.zeros(3)
        closing[axis] = 1.0
        for sgn in (1.0, -1.0):
            out.append(Grasp("box", (float(c[0]), float(c[1]), float(z)), (0.0, 0.0, -1.0), _t(sgn * closing), w,
                             _opening(w, rule.clearance, stroke)))
    return out


@dataclass(frozen=True, eq=False)
class GraspPlan:
    """A chosen grasp of one object in the current state.

    Attributes:
        grasp: the grasp (object frame).
        tcp_grasp: TCP pose at the grasp, robot base frame (4×4).
        tcp_pregrasp: TCP pose at the pre-grasp, robot base frame (4×4).
        q_grasp: joint configuration at the grasp [rad].
        q_pregrasp: joint configuration at the pre-grasp [rad].
    """

    grasp: Grasp
    tcp_grasp: np.ndarray
    tcp_pregrasp: np.ndarray
    q_grasp: np.ndarray
    q_pregrasp: np.ndarray


def ik_near(pose_base: np.ndarray, seed: np.ndarray) -> np.ndarray | None:
    q, ok = ik_batch(pose_base[None], np.asarray(seed, float)[None], TCP_OFFSET)
    return q[0] if ok[0] else None


def ik_candidates(pose_base: np.ndarray, seed: np.ndarray) -> list[np.ndarray]:
    """Every IK solution inside the limits, nearest ``seed`` first (each wrapped towards it) [rad]."""
    qs, ok = wrap_to_limits(ik_all(pose_base, TCP_OFFSET), seed)  # row by row, in one pass
    out = [q for q, inside in zip(qs, ok, strict=True) if inside]
    out.sort(key=lambda q: float(np.sum((q - seed) ** 2)))
    return out


def _elbow_up(q: np.ndarray) -> bool:
    """Whether a configuration keeps the UR5e's usual pose: elbow above the wrist, wrist down."""
    # With the standard DH frames, the elbow is up when the lift and elbow joints have opposite signs.
    return bool(q[1] < 0 and q[2] > 0)


# Cost of one place in the grasp registry's order (catalogue preference) in choose_grasps.
_GRASP_ORDER_COST = 0.05


def choose_grasps(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    bodies: SceneBodies,
    robot: RobotInfo,
    checker: CollisionChecker,
    i: int,
    facts: ObjectFacts | None,
    seed_q: np.ndarray,
    config: PlannerConfig,
    layout: TableLayout = LAYOUT,
    exclude: tuple[int, ...] = (),
    memo: str | None = None,
    fit_pinch: bool = False,
) -> list[tuple[int, GraspPlan]]:
    """Feasible grasps of object ``i`` in the current state, best first, with their registry index.

    The cost of a grasp grows with its place in the registry's order, with the wrist turn and with
    the joint travel from ``seed_q``; the search stops at ``config.grasp_candidates`` feasible grasps
    or where no later candidate can cost less than the best found (the first entry is the same as
    with a full search; the others are those found on the way).

    A grasp is feasible when the grasp and pre-grasp poses have an elbow-up IK solution, the
    fingers (opened to the grasp's opening) touch nothing, the object included, at either pose, and
    the fingertips stay ``finger_clearance`` above the table (the grasp is raised a little where the
    open fingers would press on the object).

    ``memo`` names the compiled scene (its spec and how it was compiled, e.g. the spec as JSON and
    ``model.ngeom``): the result is then kept in this process under it and the bytes of everything
    else the search reads (the state, the arguments), and a later call with the same bytes gets a
    copy instead of searching again. Every instruction of a scene starts its first pick from the same
    state (the scene as compiled, the arm at home), so a worker that meets the scene again skips it.

    ``fit_pinch`` centres each rim grasp on what its pads will pinch at the chosen height (measured
    by rays from the open pads against the object's collision geoms), so that both pads touch at
    once and the grasp's width is that span; off (the dataset's paths, whose bytes are fixed), the
    pads stand around the rim site's nominal wall. On a sloped brim (the procedural soup plate's,
    74° from vertical) the pads reach the brim's top 4 mm, where the inner pad's lower edge meets
    the brim's upper face 7 mm before the outer pad meets the lip: closing, it pushes and tilts the
    plate before both pads touch, and the grasp assist never welds it.
    """
    args = (model, data, bodies, robot, checker, i, facts, seed_q, config, layout, exclude, fit_pinch)
    if memo is None:
        return _search_grasps(*args)
    key = _search_key(memo, *args)
    found = _SEARCHES.get(key)
    if found is None:
        found = _search_grasps(*args)
        _SEARCHES[key] = copy.deepcopy(found)
        while len(_SEARCHES) > _SEARCHES_KEPT:
            _SEARCHES.popitem(last=False)
        return found
    _SEARCHES.move_to_end(key)
    return copy.deepcopy(found)


# choose_grasps results by memo and input bytes (least recently used dropped first): a few KB each
_SEARCHES: OrderedDict[bytes, list[tuple[int, GraspPlan]]] = OrderedDict()
_SEARCHES_KEPT = 4096


def _search_key(memo: str, model: mujoco.MjModel, data: mujoco.MjData, bodies: SceneBodies, robot: RobotInfo,
                checker: CollisionChecker, i: int, facts: ObjectFacts | None, seed_q: np.ndarray,
                config: PlannerConfig, layout: TableLayout, exclude: tuple[int, ...], fit_pinch: bool) -> bytes:
    """The digest of everything :func:`_search_grasps` reads."""
    h = hashlib.sha256(memo.encode())
    site_facts = None if facts is None else (facts.graspable_sites, facts.bbox_min, facts.bbox_max)
    # fit_pinch joins the key only when set, so the dataset's keys (and its memo) stay as they were
    pinch = ("fit_pinch",) if fit_pinch else ()
    h.update(repr((model.nq, model.ngeom, model.nbody, bodies.num_objects, i, tuple(exclude), site_facts, config,
                   *pinch, layout, checker.margin, checker.object_margin, robot.finger_open_sign, robot.finger_depth,
                   robot.tcp_site)).encode())
    for arr in (model.geom_type, model.geom_size, model.geom_dataid, model.mesh_vertnum, model.geom_contype,
                model.geom_conaffinity, np.asarray(seed_q, dtype=float), checker.base_qpos, data.qpos, data.xpos,
                data.xquat, data.xmat, data.geom_xpos, data.geom_xmat, robot.base_pos, robot.base_rot,
                robot.finger_axis):
        h.update(np.ascontiguousarray(arr).tobytes())
    return h.digest()


def _search_grasps(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    bodies: SceneBodies,
    robot: RobotInfo,
    checker: CollisionChecker,
    i: int,
    facts: ObjectFacts | None,
    seed_q: np.ndarray,
    config: PlannerConfig,
    layout: TableLayout,
    exclude: tuple[int, ...],
    fit_pinch: bool = False,
) -> list[tuple[int, GraspPlan]]:
    t_obj = object_pose(data, bodies, i)
    sites = facts.graspable_sites if facts is not None else ()
    bmin = facts.bbox_min if facts is not None else bodies.local_box(i).lo
    bmax = facts.bbox_max if facts is not None else bodies.local_box(i).hi
    cands = grasp_candidates(sites, np.asarray(bmin), np.asarray(bmax))
    feasible: list[tuple[float, int, GraspPlan]] = []
    min_tcp_z = layout.table_height + robot.finger_depth + config.finger_clearance
    top_z = float(object_world_box(model, data, bodies, i).hi[2])
    best_cost = math.inf
    for k, g in enumerate(cands):
        if k * _GRASP_ORDER_COST >= best_cost:
            break  # every later candidate costs at least this much: none can beat the best
        if k in exclude:
            continue
        tcp_w = matmul(t_obj, g.pose(robot.finger_axis))
        app = tcp_w[:3, 2]
        if app[2] > -0.5:
            continue  # only top-down grasps: side approaches run the fingers into the table
        if tcp_w[2, 3] < min_tcp_z:
            tcp_w[2, 3] = min_tcp_z
        # Raise the grasp where the open fingers would press on the object (sloped rims), as long
        # as the pads still reach 4 mm below the object's top.
        max_tcp_z = top_z - 0.004 + robot.finger_depth
        best = None
        # Open wider where the collision hull is thicker than the site's nominal width (sloped rims).
        openings = sorted({min(GRIPPER_STROKE, g.opening + extra) for extra in (0.0, 0.012, 0.024)})
        heights = np.arange(0.0, max(0.0, max_tcp_z - tcp_w[2, 3]) + 1e-9, 0.003)[:8]
        arm_poses: dict[int, _GraspArmPoses] = {}  # the IK of a height serves every opening
        for opening, h in ((o, h) for o in openings for h in range(len(heights))):
            if best is not None:
                break
            if h not in arm_poses:
                arm_poses[h] = _grasp_arm_poses(robot, tcp_w, app, float(heights[h]), seed_q, config)
            best = _free_branch(checker, arm_poses[h], opening, i)
            if best is not None:
                if opening != g.opening:
                    g = dataclasses.replace(g, opening=float(opening))
                if fit_pinch and g.name == "rim":
                    best, g = _fitted_pinch(model, data, bodies, robot, checker, i, t_obj, tcp_w, app,
                                            float(heights[h]), g, seed_q, config, best)
        if best is None:
            continue
        # Prefer the catalogue's order, then small wrist turns from the seed.
        cost = (k * _GRASP_ORDER_COST + float(np.abs(best[0][5] - seed_q[5])) * 0.1
                + float(np.sum(np.abs(best[0] - seed_q))) * 0.02)
        best_cost = min(best_cost, cost)
        feasible.append((cost, k, GraspPlan(g, best[2], best[3], best[1], best[0])))
        if len(feasible) >= config.grasp_candidates:
            break
    feasible.sort(key=lambda x: x[0])
    return [(k, gp) for _, k, gp in feasible]


def graspable_in_scene(model: mujoco.MjModel, data: mujoco.MjData, facts: list[ObjectFacts | None],
                       config: PlannerConfig | None = None) -> list[bool]:
    """Per scene object: whether :func:`choose_grasps` finds a grasp from the arm's current state.

    This is the planner's own test (reachable elbow-up IK, collision-free pre-grasp and grasp,
    free lift), run once per scene so that instructions only move objects the arm can take.

    Args:
        model: the compiled scene (with the robot).
        data: its state (object poses; the arm is taken at home, where every path starts).
        facts: ``object_facts`` of each scene object, in order.
        config: planner settings (the grasp search stops at the first feasible grasp).
    """
    config = dataclasses.replace(config or PlannerConfig(), grasp_candidates=1)
    robot = RobotInfo.from_model(model, data)
    bodies = SceneBodies(model, len(facts))
    checker = CollisionChecker(model, data, bodies, robot)
    return [bool(choose_grasps(model, data, bodies, robot, checker, i, f, HOME_QPOS, config))
            for i, f in enumerate(facts)]


@dataclass
class _GraspArmPoses:
    """The arm's configurations for one grasp pose, whatever the finger opening.

    Attributes:
        tcp_b: grasp pose in the base frame.
        pre_b: pre-grasp pose in the base frame.
        branches: per elbow-up IK branch of the pre-grasp (nearest the seed first, at most 4):
            (pre-grasp q, grasp q).
        lifts: per branch, the grasp lifted 2 and 5 cm (None: out of reach), solved when first asked.
    """

    tcp_b: np.ndarray
    pre_b: np.ndarray
    branches: list[tuple[np.ndarray, np.ndarray]]
    lifts: dict[int, list[np.ndarray] | None] = field(default_factory=dict)

    def lift_free(self, checker: CollisionChecker, b: int, opening: float, i: int) -> bool:
        """Whether the gripper can rise 2 and 5 cm from branch ``b``'s grasp without touching another
        object (a finger under an overhanging rim, a plate's, would lift it)."""
        if b not in self.lifts:
            up = np.repeat(self.tcp_b[None], 2, axis=0)
            up[:, 2, 3] += (0.02, 0.05)
            q, ok = ik_batch(up, self.branches[b][1], TCP_OFFSET)
            self.lifts[b] = list(q) if ok.all() else None
        qs = self.lifts[b]
        return qs is not None and all(checker.free(q, opening, allow_objects_with_gripper=(i,)) for q in qs)


def _grasp_arm_poses(robot: RobotInfo, tcp_w: np.ndarray, app: np.ndarray, dz: float, seed_q: np.ndarray,
                     config: PlannerConfig) -> _GraspArmPoses:
    tcp_k = tcp_w.copy()
    tcp_k[2, 3] += dz
    pre_w = tcp_k.copy()
    pre_w[:3, 3] -= config.approach_distance * app
    tcp_b, pre_b = robot.world_to_base(tcp_k), robot.world_to_base(pre_w)
    pres = [q for q in ik_candidates(pre_b, seed_q)[:4] if _elbow_up(q)]
    branches: list[tuple[np.ndarray, np.ndarray]] = []
    if not pres:
        return _GraspArmPoses(tcp_b, pre_b, branches)
    # the grasp nearest each pre-grasp branch, all in one batch (each row the bits of its own ik_near)
    q_gs, ok = ik_batch(np.repeat(tcp_b[None], len(pres), axis=0), np.array(pres), TCP_OFFSET)
    for q_pre, q_g, found in zip(pres, q_gs, ok, strict=True):
        if not found or np.max(np.abs(q_g - q_pre)) > 0.6:
            continue
        branches.append((q_pre, q_g))
    return _GraspArmPoses(tcp_b, pre_b, branches)


def _free_branch(checker: CollisionChecker, poses: _GraspArmPoses, opening: float,
                 i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """The first IK branch of ``poses`` whose grasp, pre-grasp and lift are collision-free with the
    fingers open to ``opening`` [m]: (pre-grasp q, grasp q, grasp pose, pre-grasp pose), or None."""
    for b, (q_pre, q_g) in enumerate(poses.branches):
        if not checker.free(q_g, opening):
            return None  # the same pose collides for every IK branch: try higher
        if not checker.free(q_pre, opening):
            continue
        if not poses.lift_free(checker, b, opening, i):
            continue
        return q_pre, q_g, poses.tcp_b, poses.pre_b
    return None


def _fitted_pinch(model: mujoco.MjModel, data: mujoco.MjData, bodies: SceneBodies, robot: RobotInfo,
                  checker: CollisionChecker, i: int, t_obj: np.ndarray, tcp_w: np.ndarray, app: np.ndarray,
                  dz: float, g: Grasp, seed_q: np.ndarray, config: PlannerConfig,
                  best: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
                  ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], Grasp]:
    """Grasp ``g`` (found feasible as ``best`` at ``tcp_w`` raised by ``dz`` [m]) moved along its
    closing line so that both open pads are as far from the object, with the width the pads pinch;
    unchanged where a pad meets nothing or the moved grasp is not free."""
    closing = matmul(tcp_w[:3, :3], robot.finger_axis)
    shift = np.zeros(3)
    for _ in range(3):  # a gap is not linear in the shift where a pad's nearest point moves (a faceted rim)
        tcp_k = tcp_w.copy()
        tcp_k[:3, 3] += shift
        tcp_k[2, 3] += dz
        gaps = pinch_gaps(model, data, bodies, i, tcp_k, robot, g.opening)
        if gaps is None:
            return best, g
        gap_a, gap_b = gaps
        if abs(gap_a - gap_b) <= PINCH_TOLERANCE:
            break
        shift = shift + 0.5 * (gap_a - gap_b) * closing
    moved = tcp_w.copy()
    moved[:3, 3] += shift
    fitted = _free_branch(checker, _grasp_arm_poses(robot, moved, app, dz, seed_q, config), g.opening, i)
    if fitted is None:
        return best, g
    position = np.asarray(g.position, dtype=float) + matmul(t_obj[:3, :3].T, shift)
    return fitted, dataclasses.replace(g, position=_t(position), width=float(g.opening - gap_a - gap_b))


# fit_pinch: the pads' gaps count as even within this [m] (the grasp assist's touch tolerance is 0.5 mm
# and each pad closes about 1 mm per control step)
PINCH_TOLERANCE = 0.0003
_PINCH_STEP = 0.001  # [m] spacing of the rays down each pad's face
_PINCH_ACROSS = (-0.008, 0.0, 0.008)  # [m] ray offsets across each pad's face, inside its 22 mm width


def pinch_gaps(model: mujoco.MjModel, data: mujoco.MjData, bodies: SceneBodies, i: int, tcp_w: np.ndarray,
               robot: RobotInfo, opening: float) -> tuple[float, float] | None:
    """How far each pad, open to ``opening`` [m] at TCP pose ``tcp_w`` (world, 4×4), travels as the
    gripper closes before it meets object ``i``'s collision geoms [m].

    Rays start on each pad's face, over its height (the TCP ± ``finger_depth`` along the approach
    axis) and width, and run along the closing line towards the other pad; a pad's gap is its
    shortest ray. The first entry is the pad on the ``-finger_axis`` side.

    Returns:
        (gap of the ``-finger_axis`` pad, gap of the ``+finger_axis`` pad), or None where a pad's
        rays meet nothing within the opening.
    """
    rot = tcp_w[:3, :3]
    closing = matmul(rot, robot.finger_axis)
    across = matmul(rot, np.cross([0.0, 0.0, 1.0], robot.finger_axis))
    down = rot[:, 2]
    centre = tcp_w[:3, 3]
    depth = robot.finger_depth
    reach = 0.5 * opening + depth + 0.01
    geoms = [int(gid) for gid in bodies.object_geoms(i)
             if (model.geom_contype[gid] or model.geom_conaffinity[gid])
             and norm(data.geom_xpos[gid] - centre) <= model.geom_rbound[gid] + reach]
    along = np.arange(-depth, depth, _PINCH_STEP)
    gaps = []
    for side in (-1.0, 1.0):
        vec = -side * closing
        nearest = math.inf
        for a in along:
            for t in _PINCH_ACROSS:
                pnt = centre + side * 0.5 * opening * closing + a * down + t * across
                for gid in geoms:
                    d = _ray_geom(model, data, gid, pnt, vec)
                    if 0.0 <= d < nearest:
                        nearest = d
        if nearest > opening:
            return None
        gaps.append(nearest)
    return gaps[0], gaps[1]


def _ray_geom(model: mujoco.MjModel, data: mujoco.MjData, gid: int, pnt: np.ndarray, vec: np.ndarray) -> float:
    """Distance along the unit ray ``pnt + x vec`` to geom ``gid``'s surface [m] (-1: none)."""
    if model.geom_type[gid] == mujoco.mjtGeom.mjGEOM_MESH:
        return float(mujoco.mj_rayMesh(model, data, gid, pnt, vec))
    return float(mujoco.mju_rayGeom(data.geom_xpos[gid], data.geom_xmat[gid], model.geom_size[gid], pnt, vec,
                                    int(model.geom_type[gid])))

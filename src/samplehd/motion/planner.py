"""The subtask planner: grasp choice, destination search and collision-checked joint paths for each
SAMPLE-HD subtask of one moved object.

Per moved object the subtasks are, in order (``samplehd.record.episode.SUBTASK_NAMES``):

1. GripperMoveAvoid: from the current configuration to the pre-grasp pose above the object, in
   joint space, collision-checked (via a lifted waypoint, then RRT-Connect, where the straight path
   collides).
2. ApproachGrasp: a straight TCP line along the grasp's approach direction to the grasp pose.
3. CloseGripper: close the fingers with the limited force, arm still.
4. MoveUP: a straight vertical lift to the transport height (the held object's bottom clears every
   other object's top by ``transport_clearance``).
5. ObjectMove: a joint-space move, held object included in the collision checks, to above the
   release pose.
6. MoveDOWN: a straight descent until the object's bottom is ``release_gap`` above its support
   (table, stack base top or container floor, found by probing MuJoCo's collision detection).
7. OpenGripper: open the fingers, arm still.
8. MoveToDefaultPos: a straight retreat up, then a joint-space move home.

pick_up stops after MoveUP, holding the object. Every function is deterministic given its inputs;
randomness (destination sampling, RRT) comes only from the generator passed in.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import asdict, dataclass, field
from typing import Any

import mujoco
import numpy as np

from samplehd.errors import PlanningError
from samplehd.motion.collision import CollisionChecker, Held
from samplehd.motion.grasps import GRIPPER_STROKE, Grasp, grasp_candidates
from samplehd.motion.robot_info import RobotInfo
from samplehd.motion.rrt import rrt_connect
from samplehd.motion.trajectory import cartesian_path, joint_path
from samplehd.placement import (
    BESIDE_FAR,
    BESIDE_NEAR,
    BESIDE_NEED,
    SPOT_COMFORT_REACH,
    SPOT_FAR_PENALTY,
    SPOT_OPTIONS,
    SPOT_REACH_WEIGHT,
    SPOT_ROOM_CAP,
    SPOT_SHORTLIST,
    SPOT_TABLE_EDGE,
    SPOT_TURN_WEIGHT,
    SPOT_TURNS,
    SPOT_WORKSPACE_SLACK,
)
from samplehd.robot.constants import JOINT_LIMITS, TCP_OFFSET
from samplehd.robot.kinematics import fk_tcp, ik_all, ik_batch, wrap_to_limits
from samplehd.scene.layout import DIRECTIONS, LAYOUT, TableLayout
from samplehd.schema import bounded, check_fields, from_mapping
from samplehd.tasks.state import SceneBodies, object_world_box

__all__ = [
    "GraspPlan",
    "PlannerConfig",
    "choose_grasps",
    "destination_candidates",
    "graspable_in_scene",
    "object_pose",
    "plan_joint_move",
    "rect_overlap",
    "release_height",
]


@dataclass(frozen=True)
class PlannerConfig:
    """Distances, speeds and search budgets of the planner.

    Attributes:
        approach_distance: pre-grasp stand-off along the approach direction [m].
        retreat_distance: straight retreat after releasing [m].
        transport_clearance: held object's bottom above the tallest other object in transport [m].
        min_lift: smallest rise of the held object in MoveUP [m].
        min_transport_height: lowest TCP height above the table in transport [m].
        approach_speed: mean TCP speed of approach/descent lines timed minimum-jerk; 1.875× this is
            their peak, and the cruise speed of long ones [m/s].
        lift_speed: the same for lifts and retreats [m/s].
        line_ramp_time: speed-up and slow-down time of long straight lines (0: minimum-jerk) [s].
        joint_speed: largest joint speed of joint-space moves [rad/s].
        joint_ramp_time: speed-up and slow-down time of long joint-space moves, which cruise at the
            speed limits in between (0: minimum-jerk timing, which peaks at 1.875× the mean speed) [s].
        max_tcp_speed: largest TCP speed in joint-space moves (below the steering scale) [m/s].
        max_tcp_angular_speed: largest TCP angular speed in joint-space moves [rad/s].
        finger_clearance: fingertips above the table at the grasp [m].
        release_gap: object's bottom above its support at release [m].
        max_drop: how much higher the object may be released where the fingers cannot open at the
            support (it drops the rest) [m].
        close_time: longest duration of CloseGripper [s].
        grip_settle_time: with the grasp assist, CloseGripper ends this long after the object
            attaches (the fingers hold still from then on) [s].
        squeeze_force: finger force once the pads touch the object [N].
        open_time: duration of OpenGripper [s].
        grasp_candidates: grasps tried per object (best first).
        spot_samples: candidate destinations sampled per object.
        spot_margin: free space between the placed object and its neighbours [m].
        part_margin: placed centre at least this far inside the destination part [m].
        relation_gap: extra distance beyond the relation margin for place_relative [m].
        rrt_iterations: RRT-Connect budget per joint-space move.
    """

    approach_distance: float = bounded(0.08, lo=0.0, unit="m")
    retreat_distance: float = bounded(0.08, lo=0.0, unit="m")
    transport_clearance: float = bounded(0.04, lo=0.0, unit="m")
    min_lift: float = bounded(0.1, lo=0.0, unit="m")
    min_transport_height: float = bounded(0.18, lo=0.0, unit="m")
    approach_speed: float = bounded(0.1, lo=0.0, lo_open=True, unit="m/s")
    lift_speed: float = bounded(0.12, lo=0.0, lo_open=True, unit="m/s")
    joint_speed: float = bounded(1.2, lo=0.0, lo_open=True, unit="rad/s")
    joint_ramp_time: float = bounded(0.6, lo=0.0, unit="s")
    line_ramp_time: float = bounded(0.5, lo=0.0, unit="s")
    max_tcp_speed: float = bounded(0.245, lo=0.0, lo_open=True, unit="m/s")
    max_tcp_angular_speed: float = bounded(0.98, lo=0.0, lo_open=True, unit="rad/s")
    finger_clearance: float = bounded(0.0015, lo=0.0, unit="m")
    release_gap: float = bounded(0.006, lo=0.0, unit="m")
    max_drop: float = bounded(0.08, lo=0.0, unit="m")
    close_time: float = bounded(1.0, lo=0.0, lo_open=True, unit="s")
    grip_settle_time: float = bounded(0.2, lo=0.0, unit="s")
    squeeze_force: float = bounded(20.0, lo=0.0, lo_open=True, unit="N")
    open_time: float = bounded(0.5, lo=0.0, lo_open=True, unit="s")
    grasp_candidates: int = bounded(8, lo=1)
    spot_samples: int = bounded(400, lo=1)
    spot_margin: float = bounded(0.02, lo=0.0, unit="m")
    part_margin: float = bounded(0.03, lo=0.0, unit="m")
    relation_gap: float = bounded(0.03, lo=0.0, unit="m")
    rrt_iterations: int = bounded(1500, lo=1)

    def __post_init__(self) -> None:
        check_fields(self, "paths.planner")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any], where: str = "paths.planner") -> PlannerConfig:
        return from_mapping(cls, d, where)


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


def object_pose(data: mujoco.MjData, bodies: SceneBodies, i: int) -> np.ndarray:
    """World pose (4×4) of object ``i`` in the state ``data``."""
    b = bodies.object_body[i]
    t = np.eye(4)
    t[:3, :3] = data.xmat[b].reshape(3, 3)
    t[:3, 3] = data.xpos[b]
    return t


def _ik_near(pose_base: np.ndarray, seed: np.ndarray) -> np.ndarray | None:
    q, ok = ik_batch(pose_base[None], np.asarray(seed, float)[None], TCP_OFFSET)
    return q[0] if ok[0] else None


def ik_candidates(pose_base: np.ndarray, seed: np.ndarray) -> list[np.ndarray]:
    """Every IK solution inside the limits, nearest ``seed`` first (each wrapped towards it) [rad]."""
    sols = ik_all(pose_base, TCP_OFFSET)
    out = []
    for s in sols:
        q, ok = wrap_to_limits(s, seed)
        if ok:
            out.append(q)
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
    facts: Any,
    seed_q: np.ndarray,
    config: PlannerConfig,
    layout: TableLayout = LAYOUT,
    exclude: tuple[int, ...] = (),
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
    """
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
        tcp_w = t_obj @ g.pose(robot.finger_axis)
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
            poses = arm_poses[h]
            for b, (q_pre, q_g) in enumerate(poses.branches):
                if not checker.free(q_g, opening):
                    break  # the same pose collides for every IK branch: try higher
                if not checker.free(q_pre, opening):
                    continue
                if not poses.lift_free(checker, b, opening, i):
                    continue
                best = (q_pre, q_g, poses.tcp_b, poses.pre_b)
                if opening != g.opening:
                    g = dataclasses.replace(g, opening=float(opening))
                break
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


def graspable_in_scene(model: mujoco.MjModel, data: mujoco.MjData, facts: list[Any],
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
    from samplehd.robot.constants import HOME_QPOS

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
    branches: list[tuple[np.ndarray, np.ndarray]] = []
    for q_pre in ik_candidates(pre_b, seed_q)[:4]:
        if not _elbow_up(q_pre):
            continue
        q_g = _ik_near(tcp_b, q_pre)
        if q_g is None or np.max(np.abs(q_g - q_pre)) > 0.6:
            continue
        branches.append((q_pre, q_g))
    return _GraspArmPoses(tcp_b, pre_b, branches)


def rect_overlap(c1: np.ndarray, r1: np.ndarray, h1: np.ndarray, c2: np.ndarray, r2: np.ndarray,
                 h2: np.ndarray, margin: float) -> np.ndarray:
    """Separating-axis test of oriented rectangles (centres, 2×2 rotations, half sizes) grown by margin.

    Broadcasts over leading dimensions (centres and half sizes ``(..., 2)``, rotations ``(..., 2, 2)``),
    so one call tests many pairs; returns whether each pair overlaps (a boolean array of the leading
    shape).
    """
    r1, r2 = np.broadcast_arrays(np.asarray(r1, float), np.asarray(r2, float))
    axes = np.swapaxes(np.concatenate((r1, r2), axis=-1), -1, -2)  # the four candidate axes, as rows
    reach = (np.abs(axes @ r1) @ (np.asarray(h1) + margin / 2)[..., None]
             + np.abs(axes @ r2) @ (np.asarray(h2) + margin / 2)[..., None])
    apart = np.abs(axes @ (np.asarray(c2) - np.asarray(c1))[..., None])
    return np.all(apart <= reach, axis=(-2, -1))


def _footprint(
    data: mujoco.MjData, bodies: SceneBodies, k: int, facts: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centre xy, 2×2 rotation, half sizes) of object k's footprint rectangle in the world."""
    t = object_pose(data, bodies, k)
    yaw = math.atan2(t[1, 0], t[0, 0])
    rot = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    if facts is not None:
        c_local, half = np.asarray(facts.footprint_center), np.asarray(facts.footprint_half_extents)
    else:
        box = bodies.local_box(k)
        c_local, half = box.center[:2], box.half[:2]
    if abs(t[2, 2]) < 0.9:  # tipped over: fall back to the world box
        wb = object_world_box(bodies.model, data, bodies, k)
        return wb.center[:2], np.eye(2), wb.half[:2]
    return t[:2, 3] + rot @ c_local, rot, half


def destination_candidates(
    data: mujoco.MjData,
    bodies: SceneBodies,
    facts: list[Any],
    i: int,
    task: Any,
    rng: np.random.Generator,
    config: PlannerConfig,
    layout: TableLayout = LAYOUT,
    directions: dict[str, Any] | None = None,
    ignore: tuple[int, ...] = (),
    relaxed: bool = False,
) -> list[tuple[np.ndarray, float]]:
    """Candidate world (x, y) positions of object ``i``'s frame origin at release and turns about the
    vertical [rad], best first.

    place/remove: free spots inside the destination part; place_relative: free spots past the
    reference object along the scene's direction; stack/put: the support's top or opening centre.
    Where no spot is free, the search runs once more with the gaps to other objects and to the
    part's edges halved (``relaxed``), as a person would squeeze an object in.
    """
    t_obj = object_pose(data, bodies, i)
    if task.family in ("stack", "put", "stack_three"):
        base = task.support_of(i)
        t_base = object_pose(data, bodies, base)
        f = facts[base]
        if task.family == "put" and f is not None and f.opening is not None:
            c_local = np.array([*f.opening.center, 0.0])
        elif f is not None:
            c_local = np.array([*f.top.center, 0.0])
        else:
            c_local = np.array([*bodies.local_box(base).center[:2], 0.0])
        target = (t_base[:3, :3] @ c_local + t_base[:3, 3])[:2]
        # Place the object's footprint centre (not its frame origin) on the target.
        _, rot_i, _ = _footprint(data, bodies, i, facts[i])
        fc = np.asarray(facts[i].footprint_center) if facts[i] is not None else bodies.local_box(i).center[:2]
        return [(target - rot_i @ fc, 0.0)]
    c_i, rot_i0, half_i = _footprint(data, bodies, i, facts[i])
    offset0 = c_i - t_obj[:2, 3]  # footprint centre relative to the frame origin (kept on transport)
    others = [k for k in range(bodies.num_objects) if k != i and k not in ignore]
    foot = {k: _footprint(data, bodies, k, facts[k]) for k in others}
    table_lo = -np.array(layout.table_size) / 2 + SPOT_TABLE_EDGE
    table_hi = np.array(layout.table_size) / 2 - SPOT_TABLE_EDGE
    n = int(config.spot_samples)
    # The object may turn about the vertical on the way (the wrist turns), which helps long objects fit.
    yaws = rng.choice(np.array(SPOT_TURNS), size=n)
    ref_origin = np.zeros(2)
    if task.family == "place_relative":
        ref = task.reference
        d = np.asarray((directions or DIRECTIONS)[task.direction], float)[:2]
        d /= np.linalg.norm(d)
        lateral = np.array([-d[1], d[0]])
        c_ref, rot_ref, half_ref = foot[ref]
        ext_ref = abs(d @ rot_ref[:, 0]) * half_ref[0] + abs(d @ rot_ref[:, 1]) * half_ref[1]
        ref_origin = object_pose(data, bodies, ref)[:2, 3]
        # Near the reference first; the second half of the samples reaches further and wider, for a
        # reference with neighbours on that side.
        half = n // 2
        (near_dist, near_lat), (far_dist, far_lat) = BESIDE_NEAR, BESIDE_FAR
        dist = np.concatenate([rng.uniform(0.0, near_dist, half), rng.uniform(0.0, far_dist, n - half)])
        lat = np.concatenate([rng.uniform(-near_lat, near_lat, half), rng.uniform(-far_lat, far_lat, n - half)])
        lo = np.array(layout.workspace_min) - SPOT_WORKSPACE_SLACK
        hi = np.array(layout.workspace_max) + SPOT_WORKSPACE_SLACK
        need = config.relation_gap + BESIDE_NEED
    else:
        lo, hi = layout.part_bounds(task.destination_part)
        lo, hi = lo + config.part_margin, hi - config.part_margin
        centres = rng.uniform(lo, hi, size=(n, 2))
        d = None
    # Every sample at once: turned footprint, centre, frame origin, then the filters in turn.
    cy, sy = np.cos(yaws), np.sin(yaws)
    rz = np.stack([np.stack([cy, -sy], axis=1), np.stack([sy, cy], axis=1)], axis=1)  # (n, 2, 2)
    rots = rz @ rot_i0
    offsets = rz @ offset0
    if d is not None:
        ext_i = np.abs(rots[:, :, 0] @ d) * half_i[0] + np.abs(rots[:, :, 1] @ d) * half_i[1]
        c = c_ref + (ext_ref + ext_i + config.spot_margin + dist)[:, None] * d + lat[:, None] * lateral
    else:
        c = centres
    origins = c - offsets
    keep = np.all((origins >= lo) & (origins <= hi), axis=1)
    if d is not None:
        keep &= (origins - ref_origin) @ d >= need
    r = np.abs(rots) @ half_i
    keep &= np.all((c - r >= table_lo) & (c + r <= table_hi), axis=1)
    reach = np.hypot(origins[:, 0] - layout.robot_base[0], origins[:, 1] - layout.robot_base[1])
    keep &= (reach >= layout.reach_min) & (reach <= layout.reach_max)
    gap = np.full(n, np.inf)
    for k in others:
        ck, rk, hk = foot[k]
        keep &= ~rect_overlap(c, rots, half_i, ck, rk, hk, config.spot_margin)
        gap = np.minimum(gap, np.linalg.norm(ck - c, axis=1))
    # Prefer room around the spot, the arm's comfortable reach and no turn.
    score = (-np.minimum(gap, SPOT_ROOM_CAP) + SPOT_REACH_WEIGHT * np.abs(reach - SPOT_COMFORT_REACH)
             + SPOT_TURN_WEIGHT * np.abs(yaws))
    if d is not None:  # the far, wide samples only where the near ones found nothing
        score += SPOT_FAR_PENALTY * (np.maximum(0.0, dist - BESIDE_NEAR[0])
                                     + np.maximum(0.0, np.abs(lat) - BESIDE_NEAR[1]))
    scored = [(float(score[s]), origins[s], float(yaws[s])) for s in np.flatnonzero(keep)]
    if not scored and not relaxed:
        tight = dataclasses.replace(config, spot_margin=config.spot_margin / 2, part_margin=config.part_margin / 2,
                                    spot_samples=3 * config.spot_samples)
        return destination_candidates(data, bodies, facts, i, task, rng, tight, layout, directions, ignore, True)
    scored.sort(key=lambda x: x[0])
    best = scored[:SPOT_SHORTLIST]
    if len(best) > 1:
        order = sorted(rng.permutation(len(best))[: min(SPOT_OPTIONS, len(best))])
        best = [best[j] for j in order]
    return [(o, y) for _, o, y in best]


def release_height(
    checker: CollisionChecker,
    bodies: SceneBodies,
    held: int,
    obj_rot: np.ndarray,
    xy: np.ndarray,
    start_z: float,
    floor_z: float,
    step: float = 0.002,
) -> float:
    """Lowest height of the held object's frame at (x, y) before it touches anything [m].

    Probes MuJoCo's collision detection with the object alone (robot parked where it is), moving it
    down from ``start_z`` in ``step`` increments; stops at ``floor_z``.
    """
    m, d = checker.model, checker.scratch
    body = int(bodies.object_body[held])
    adr = int(m.jnt_qposadr[m.body_jntadr[body]])
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(obj_rot).reshape(9))
    d.qpos[:] = checker.base_qpos
    d.qpos[adr + 3:adr + 7] = quat
    robot = bodies.robot_bodies

    def touches(z: float) -> bool:
        d.qpos[adr:adr + 3] = (xy[0], xy[1], z)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        for k in range(d.ncon):
            c = d.contact[k]
            b1, b2 = int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])
            if body in (b1, b2) and c.dist < 0 and not ({b1, b2} & robot):
                return True
        return False

    if touches(start_z):
        raise PlanningError(f"object {held} collides above its destination at z={start_z:.3f} m")
    lo, hi = floor_z, start_z
    if not touches(lo):
        return lo
    while hi - lo > step:
        mid = 0.5 * (lo + hi)
        if touches(mid):
            lo = mid
        else:
            hi = mid
    return hi


def _limit_tcp_speed(path: np.ndarray, start: np.ndarray, dt: float, config: PlannerConfig) -> float:
    """Factor by which a joint path must be slowed so the TCP stays below the steering limits."""
    qs = np.vstack([start[None], path])
    tcp = fk_tcp(qs)
    v = np.abs(np.diff(tcp[:, :3, 3], axis=0)) / dt
    rel = np.einsum("nji,njk->nik", tcp[:-1, :3, :3], tcp[1:, :3, :3])
    ang = np.arccos(np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1, 1)) / dt
    return max(1.0, float(v.max(initial=0) / config.max_tcp_speed),
               float(ang.max(initial=0) / config.max_tcp_angular_speed))


def timed_joint_path(waypoints: np.ndarray, dt: float, config: PlannerConfig) -> np.ndarray:
    """Joint path through waypoints, slowed so the TCP never exceeds the steering speed limits."""
    speed = config.joint_speed
    path = joint_path(waypoints, dt, speed, ramp_time=config.joint_ramp_time)
    for _ in range(4):
        f = _limit_tcp_speed(path, waypoints[0], dt, config)
        if f <= 1.0 + 1e-6:
            break
        speed /= f * 1.05
        path = joint_path(waypoints, dt, speed, ramp_time=config.joint_ramp_time)
    return path


def plan_joint_move(
    checker: CollisionChecker,
    q_start: np.ndarray,
    q_goal: np.ndarray,
    opening: float,
    dt: float,
    config: PlannerConfig,
    rng: np.random.Generator,
    held: Held | None = None,
    lift_z: float | None = None,
    robot: RobotInfo | None = None,
    allow_objects_with_gripper: tuple[int, ...] = (),
) -> tuple[np.ndarray, str]:
    """A collision-free, timed joint-space move: straight, via lifted waypoints, or RRT-Connect.

    Returns:
        (targets at the control rate, method used: "direct", "lifted" or "rrt").

    Raises:
        PlanningError: no collision-free path was found.
    """
    allow_g = allow_objects_with_gripper

    def free(q: np.ndarray) -> bool:
        return checker.free(q, opening, held, allow_objects_with_gripper=allow_g)

    ends = np.array([q_start, q_goal])
    if checker.path_free(ends, opening, held, allow_objects_with_gripper=allow_g):
        return timed_joint_path(ends, dt, config), "direct"
    if lift_z is not None and robot is not None:
        # Lift straight up from the start and descend straight onto the goal at a safe height.
        via = []
        for q in (q_start, q_goal):
            t = fk_tcp(q)
            t[2, 3] = max(t[2, 3], lift_z - robot.base_pos[2])
            qv = _ik_near(t, q)
            if qv is None:
                break
            via.append(qv)
        if len(via) == 2:
            wps = np.array([q_start, via[0], via[1], q_goal])
            if checker.path_free(wps, opening, held, allow_objects_with_gripper=allow_g):
                return timed_joint_path(wps, dt, config), "lifted"
    lo = np.maximum(JOINT_LIMITS[:, 0], np.minimum(q_start, q_goal) - 1.0)
    hi = np.minimum(JOINT_LIMITS[:, 1], np.maximum(q_start, q_goal) + 1.0)
    if not free(q_start):
        raise PlanningError("the start configuration of a joint move is in collision")
    if not free(q_goal):
        raise PlanningError("the goal configuration of a joint move is in collision")
    wps = rrt_connect(q_start, q_goal, free, lo, hi, rng, max_iterations=int(config.rrt_iterations))
    return timed_joint_path(wps, dt, config), "rrt"


def straight_move(
    checker: CollisionChecker,
    start_pose: np.ndarray,
    end_pose: np.ndarray,
    q_start: np.ndarray,
    opening: float,
    dt: float,
    speed: float,
    held: Held | None = None,
    allow_objects_with_gripper: tuple[int, ...] = (),
    check: bool = True,
    ramp_time: float = 0.0,
) -> np.ndarray:
    """A straight TCP line (base-frame poses) as timed joint targets, collision-checked; ``speed`` and
    ``ramp_time`` as in :func:`cartesian_path`."""
    path = cartesian_path(start_pose, end_pose, q_start, dt, speed, ramp_time=ramp_time)
    if check:
        for q in path[:: max(1, len(path) // 12)]:
            if not checker.free(q, opening, held, allow_objects_with_gripper=allow_objects_with_gripper):
                bad = checker.contacts(q, opening, held, allow_objects_with_gripper=allow_objects_with_gripper)
                names = {mujoco.mj_id2name(checker.model, mujoco.mjtObj.mjOBJ_BODY, b) for a in bad for b in a[:2]}
                raise PlanningError(f"straight TCP move collides ({', '.join(sorted(n or '?' for n in names))})")
    return path

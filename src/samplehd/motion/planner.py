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

import mujoco
import numpy as np

from samplehd.catalogue import ObjectFacts
from samplehd.errors import PlanningError
from samplehd.fixedmath import arccos, dot, matmul, norm
from samplehd.motion.rrt import rrt_connect
from samplehd.motion.trajectory import cartesian_path, joint_path
from samplehd.robot.constants import JOINT_LIMITS
from samplehd.robot.kinematics import fk_tcp
from samplehd.tasks.task import Task, get_family
from samplehd.world.bodies import SceneBodies, object_footprint, object_pose
from samplehd.world.collision import CollisionChecker, Held
from samplehd.world.free_spot import rect_overlap, table_and_reach
from samplehd.world.grasps import ik_near
from samplehd.world.layout import DIRECTIONS, LAYOUT, Directions, TableLayout
from samplehd.world.placement import (
    BESIDE_FAR,
    BESIDE_NEAR,
    BESIDE_NEED,
    GRASP_ROOM,
    ROOM_GRID_STEP,
    SPOT_COMFORT_REACH,
    SPOT_FAR_PENALTY,
    SPOT_OPTIONS,
    SPOT_REACH_WEIGHT,
    SPOT_ROOM_CAP,
    SPOT_SHORTLIST,
    SPOT_TURN_WEIGHT,
    SPOT_TURNS,
    SPOT_WORKSPACE_SLACK,
)
from samplehd.world.planner_config import PlannerConfig
from samplehd.world.robot_info import RobotInfo
from samplehd.world.transforms import yaw_rotation_2d

__all__ = [
    "destination_candidates",
    "leaves_room",
    "plan_joint_move",
    "release_height",
    "straight_move",
    "timed_joint_path",
]


def top_turn(rot: np.ndarray, half: np.ndarray, t_base: np.ndarray, base: ObjectFacts | None) -> float:
    """The turn about the vertical [rad] that sets a footprint (world 2×2 rotation ``rot``, half sizes
    ``half`` [m]) inside the rectangular top of a support at pose ``t_base``: 0 where it fits as it is
    or fits neither way; else the turn in (-π/2, π/2] that lays its long side along the top's (a fork
    across a baking tray rests on the rim, tilts and slides; along it, it lies on the floor)."""
    if base is None or base.top.round:
        return 0.0
    top_half = np.asarray(base.top.half_extents, float)
    c, s = t_base[0, 0], t_base[1, 0]
    base_rot = np.array([[c, -s], [s, c]]) / max(float(np.hypot(c, s)), 1e-12)

    def fits(yaw: float) -> bool:
        turned = matmul(base_rot.T, matmul(yaw_rotation_2d(np.array([yaw]))[0], rot))
        return bool(np.all(matmul(np.abs(turned), half) <= top_half))

    if fits(0.0):
        return 0.0
    long_axis = rot[:, int(half[1] > half[0])]
    top_axis = base_rot[:, int(top_half[1] > top_half[0])]
    yaw = float(np.arctan2(top_axis[1], top_axis[0]) - np.arctan2(long_axis[1], long_axis[0]))
    yaw = (yaw + np.pi / 2) % np.pi - np.pi / 2  # an axis: the turn of least size
    return yaw if fits(yaw) else 0.0


def destination_candidates(
    data: mujoco.MjData,
    bodies: SceneBodies,
    facts: list[ObjectFacts | None],
    i: int,
    task: Task,
    rng: np.random.Generator,
    config: PlannerConfig,
    layout: TableLayout = LAYOUT,
    directions: Directions | None = None,
    ignore: tuple[int, ...] = (),
    relaxed: bool = False,
    shortlist: int = SPOT_SHORTLIST,
    options: int = SPOT_OPTIONS,
    align_on_top: bool = False,
) -> list[tuple[np.ndarray, float]]:
    """Candidate world (x, y) positions of object ``i``'s frame origin at release and turns about the
    vertical [rad], best first.

    By the family's destination recipe (:attr:`samplehd.tasks.task.TaskFamily.destination`):
    ``table_part``: free spots inside the destination part; ``beside``: free spots past the
    reference object along the scene's direction; ``top`` / ``opening``: the support's top or
    opening centre.
    Where no spot is free, the search runs once more with the gaps to other objects and to the
    part's edges halved (``relaxed``), as a person would squeeze an object in. Of the ``shortlist``
    best free samples, ``options`` drawn at random are returned in their order. ``align_on_top``
    (``top``): where the object's footprint, as it is turned now, overhangs the support's top and
    turned along the top's long side it does not, it is turned so (:func:`top_turn`).
    """
    t_obj = object_pose(data, bodies, i)
    recipe = get_family(task.family).destination
    if recipe in ("top", "opening"):
        base = task.support_of(i)
        t_base = object_pose(data, bodies, base)
        f = facts[base]
        if recipe == "opening" and f is not None and f.opening is not None:
            c_local = np.array([*f.opening.center, 0.0])
        elif f is not None:
            c_local = np.array([*f.top.center, 0.0])
        else:
            c_local = np.array([*bodies.local_box(base).center[:2], 0.0])
        target = (matmul(t_base[:3, :3], c_local) + t_base[:3, 3])[:2]
        # Place the object's footprint centre (not its frame origin) on the target.
        _, rot_i, half_i = object_footprint(data, bodies, i, facts[i])
        fc = np.asarray(facts[i].footprint_center) if facts[i] is not None else bodies.local_box(i).center[:2]
        yaw = top_turn(rot_i, half_i, t_base, f) if align_on_top and recipe == "top" else 0.0
        return [(target - matmul(yaw_rotation_2d(np.array([yaw]))[0], matmul(rot_i, fc)), yaw)]
    c_i, rot_i0, half_i = object_footprint(data, bodies, i, facts[i])
    offset0 = c_i - t_obj[:2, 3]  # footprint centre relative to the frame origin (kept on transport)
    others = [k for k in range(bodies.num_objects) if k != i and k not in ignore]
    foot = {k: object_footprint(data, bodies, k, facts[k]) for k in others}
    n = int(config.spot_samples)
    # The object may turn about the vertical on the way (the wrist turns), which helps long objects fit.
    yaws = rng.choice(np.array(SPOT_TURNS), size=n)
    ref_origin = np.zeros(2)
    if recipe == "beside":
        ref = task.reference
        d = np.asarray((directions or DIRECTIONS)[task.direction], float)[:2]
        d /= norm(d)
        lateral = np.array([-d[1], d[0]])
        c_ref, rot_ref, half_ref = foot[ref]
        ext_ref = abs(dot(d, rot_ref[:, 0])) * half_ref[0] + abs(dot(d, rot_ref[:, 1])) * half_ref[1]
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
    rz = yaw_rotation_2d(yaws)  # (n, 2, 2)
    rots = matmul(rz, rot_i0)
    offsets = matmul(rz, offset0)
    if d is not None:
        ext_i = np.abs(matmul(rots[:, :, 0], d)) * half_i[0] + np.abs(matmul(rots[:, :, 1], d)) * half_i[1]
        c = c_ref + (ext_ref + ext_i + config.spot_margin + dist)[:, None] * d + lat[:, None] * lateral
    else:
        c = centres
    origins = c - offsets
    keep = np.all((origins >= lo) & (origins <= hi), axis=1)
    if d is not None:
        keep &= matmul(origins - ref_origin, d) >= need
    on_table, reach = table_and_reach(c, matmul(np.abs(rots), half_i), origins, layout)
    keep &= on_table
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
        return destination_candidates(data, bodies, facts, i, task, rng, tight, layout, directions, ignore, True,
                                      shortlist, options)
    scored.sort(key=lambda x: x[0])
    best = scored[:shortlist]
    if len(best) > 1:
        order = sorted(rng.permutation(len(best))[: min(options, len(best))])
        best = [best[j] for j in order]
    return [(o, y) for _, o, y in best]


def leaves_room(
    data: mujoco.MjData,
    bodies: SceneBodies,
    facts: list[ObjectFacts | None],
    i: int,
    spot: tuple[np.ndarray, float],
    to_come: list[int],
    task: Task,
    config: PlannerConfig,
    layout: TableLayout = LAYOUT,
) -> bool:
    """Whether object ``i`` put down at ``spot`` (its frame origin's world (x, y) and turn, as
    :func:`destination_candidates` gives them) leaves room for the objects ``to_come`` to the task's
    destination part.

    The spot must stay ``GRASP_ROOM`` clear of where those objects stand (their grasps need room for
    the fingers), and each of them in turn must find a free spot of the part (the planner's tests:
    origin in the part shrunk by ``part_margin``, footprint on the table, origin in reach,
    ``spot_margin`` from every other footprint) on a grid of ``ROOM_GRID_STEP``, filled from its
    lowest corner, the first free cell taken (a packing a person would manage; the planner's own
    spots spread out).
    """
    lo, hi = layout.part_bounds(task.destination_part)
    lo, hi = lo + config.part_margin, hi - config.part_margin
    foot = {k: object_footprint(data, bodies, k, facts[k]) for k in range(bodies.num_objects)}
    foot[i] = _turned_footprint(data, bodies, foot[i], i, spot[0], spot[1])
    c_i, rot_i, half_i = foot[i]
    if any(rect_overlap(c_i, rot_i, half_i, *foot[k], GRASP_ROOM) for k in to_come):
        return False
    xs = np.arange(lo[0], hi[0] + 1e-9, ROOM_GRID_STEP)
    ys = np.arange(lo[1], hi[1] + 1e-9, ROOM_GRID_STEP)
    grid = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)
    for k in to_come:
        found = None
        for yaw in dict.fromkeys(SPOT_TURNS):
            c, rot, half = _turned_footprint(data, bodies, foot[k], k, grid, yaw)
            keep, _ = table_and_reach(c, np.broadcast_to(matmul(np.abs(rot), half), c.shape), grid, layout)
            for j, rect in foot.items():
                if j != k:
                    keep &= ~rect_overlap(c, rot, half, *rect, config.spot_margin)
            if keep.any():
                found = (c[np.argmax(keep)], rot, half)
                break
        if found is None:
            return False
        foot[k] = found
    return True


def _turned_footprint(data: mujoco.MjData, bodies: SceneBodies, rect: tuple[np.ndarray, np.ndarray, np.ndarray],
                      k: int, origin: np.ndarray, yaw: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Object ``k``'s footprint ``rect`` (centre, rotation, half sizes, where it stands) with its frame
    origin moved to ``origin`` ((2,) or (m, 2)) and turned by ``yaw`` about the vertical."""
    c, rot, half = rect
    rz = yaw_rotation_2d(np.array([yaw]))[0]
    offset = matmul(rz, c - object_pose(data, bodies, k)[:2, 3])
    return np.asarray(origin) + offset, matmul(rz, rot), half


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
    rel = matmul(np.swapaxes(tcp[:-1, :3, :3], 1, 2), tcp[1:, :3, :3])
    ang = arccos(np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1, 1)) / dt
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
            qv = ik_near(t, q)
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

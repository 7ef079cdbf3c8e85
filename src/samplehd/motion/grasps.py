"""The grasp registry: candidate grasps per object, as TCP poses in the object frame.

Candidates come from the catalogue's per-instance grasp sites (rims of bowls, trays and pans,
handles of mugs, pans and scissors, bodies of cans, glasses and thermoses, across cutlery handles,
edges of boards), expanded by the rules below, and, for objects without sites (imported meshes),
derived from the object's bounding box. :func:`grasp_candidates` lists them best first; the planner
picks per instance by reachability (analytic IK), a collision-free approach and finger clearance.

Rules (data, one entry per site name in :data:`GRASP_RULES`):

- ``yaws``: for axisymmetric sites, how many rotations about the object's z axis to try.
- ``top_down``: side-approach sites (approach horizontal) also get a top-down variant, the fingers
  reaching ``finger_reach`` below the top.
- ``clearance``: room left between each finger and the object when the gripper opens [m] (less,
  down to :data:`MIN_CLEARANCE`, for objects nearly as wide as the stroke).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "GRASP_RULES",
    "GRIPPER_STROKE",
    "MIN_CLEARANCE",
    "Grasp",
    "GraspRule",
    "grasp_candidates",
    "register_grasp_rule",
]

GRIPPER_STROKE = 0.085  # [m] largest finger opening of the parallel-jaw gripper
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
        c = c - np.dot(c, z) * z
        c /= np.linalg.norm(c)
        fa = np.asarray(finger_axis, dtype=float)
        # Map TCP frame (fa, z × fa, z) onto the object frame (c, z × c, z).
        tcp_basis = np.column_stack([fa, np.cross([0.0, 0.0, 1.0], fa), [0.0, 0.0, 1.0]])
        obj_basis = np.column_stack([c, np.cross(z, c), z])
        return obj_basis @ tcp_basis.T

    def pose(self, finger_axis: np.ndarray) -> np.ndarray:
        """4×4 TCP pose in the object frame."""
        t = np.eye(4)
        t[:3, :3] = self.rotation(finger_axis)
        t[:3, 3] = self.position
        return t

    def to_dict(self) -> dict[str, Any]:
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

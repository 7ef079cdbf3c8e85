"""Measurements of a judged state that the families' success predicates share (resting, on the table,
stacked, touching, held in the grasp weld)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from samplehd.world.bodies import SceneBodies, contact_pairs, object_world_box
from samplehd.world.layout import TableLayout

if TYPE_CHECKING:
    from samplehd.tasks.checker import CheckerConfig

__all__ = ["Judge", "welded"]


class Judge:
    """Measurements of the final state, shared by the predicates."""

    def __init__(self, model: mujoco.MjModel, start: mujoco.MjData, end: mujoco.MjData, bodies: SceneBodies,
                 config: CheckerConfig, layout: TableLayout, directions: dict[str, Any]) -> None:
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
        drift = float(np.linalg.norm(self.pos(i) - self.pos(i, self.start)))
        if drift > self.cfg.stable_drift:
            return f"object {i} moved {drift * 1000:.0f} mm during the {self.cfg.window:.1f} s window"
        speed = float(np.linalg.norm(self.end.cvel[self.b.object_body[i], 3:]))
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
        tb = object_world_box(self.model, self.end, self.b, top)
        bb = object_world_box(self.model, self.end, self.b, base)
        if tb.lo[2] < bb.lo[2] + self.cfg.stack_min_rise:
            return f"object {top} is not above object {base}"
        if not bb.contains_xy(self.pos(top), -self.cfg.footprint_margin):
            return f"object {top} is not over the footprint of object {base}"
        return ""


def welded(model: mujoco.MjModel, data: mujoco.MjData, i: int) -> bool:
    """Whether object i hangs in the grasp assist's weld (``samplehd.motion.assist``)."""
    e = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, f"grasp_weld_{i}")
    return e >= 0 and bool(data.eq_active[e])

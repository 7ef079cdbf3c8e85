"""What the keypose policy sees and learns, as arrays: a demonstration's *decisions*
(:func:`decisions`, :class:`Decision`), the top-down view of the scene camera's RGB-D it decides on
(:func:`scene_grid`, in the grid of :mod:`samplehd.learn.topdown`), and a decision as the network's
labels (:func:`keypose_targets`) with the attribute maps of what the view shows.

A demonstration is a series of decisions, one per object it moves: where to grasp (TCP position, yaw
and the opening before closing), how high to lift, and where the carried object goes (the TCP where
the gripper opens; for ``pick_up``, the lifted pose it holds). :func:`decisions` reads them from a
recorded episode's subtasks (``CloseGripper`` starts at the grasp, ``OpenGripper`` at the release,
``MoveUP`` ends at the lift), each with the frame it is decided on: the episode's first, or the first
after the arm went back to its start (``MoveToDefaultPos``), where the camera sees the table again.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from samplehd.errors import ConfigError
from samplehd.language.levels import HELD_OUT_CLASSES
from samplehd.learn.actions import tcp_yaw
from samplehd.learn.keypose.configuration import ATTRIBUTE_VALUES, KEYPOSE_ATTRIBUTES, KeyposeGrid
from samplehd.learn.topdown import GRID_CHANNELS, TopDownGrid
from samplehd.render.renderer import SEG_OBJECT_OFFSET, SEG_ROBOT, camera_intrinsics, camera_pose
from samplehd.world.layout import LAYOUT

__all__ = ["FACTOR", "HEIGHT_UNIT", "LABELS", "OPENING_UNIT", "SCENE_MODALITIES", "Decision", "attribute_maps",
           "attribute_values", "decisions", "grid_of", "input_channels", "keypose_targets", "scene_grid",
           "task_cells"]

SCENE_MODALITIES = ("rgb", "depth", "segmentation")  # depth of the segmentation pass: glass is opaque there
HEIGHT_UNIT = 0.1  # heights (grasp, lift, goal) are learnt in this unit above the table [m]
OPENING_UNIT = 0.085  # the opening is learnt in this unit [m]
FACTOR = 2  # the network's maps have cells this many times larger than the grid's


def input_channels(inputs: str) -> int:
    """The channels of the network's view: the grid image's, and for the privileged-state reference
    (``inputs="state"``) one more marking the cells that show an object the task moves."""
    return GRID_CHANNELS + (inputs == "state")


def task_cells(ids: np.ndarray, objects: Sequence[int]) -> np.ndarray:
    """(rows, cols) float32: 1 where a cell shows one of the scene objects ``objects`` (``ids``: the
    segmentation id seen in each cell)."""
    return np.isin(ids, [SEG_OBJECT_OFFSET + int(i) for i in objects]).astype(np.float32)


def grid_of(config: KeyposeGrid) -> TopDownGrid:
    """The top-down grid the config describes."""
    return TopDownGrid((float(config.origin[0]), float(config.origin[1])), config.cell, config.rows, config.cols)


def scene_grid(renderer: Any, model: Any, data: Any, config: KeyposeGrid, with_ids: bool = False) -> Any:
    """The grid image of the scene camera's view of ``data`` (``renderer`` made for ``model`` at the
    config's size); with ``with_ids``, (it, the segmentation id seen in each cell)."""
    images = renderer.render(data, config.camera, SCENE_MODALITIES)
    camera = {"width": config.width, "height": config.height,
              "intrinsics": camera_intrinsics(model, config.camera, config.width, config.height).tolist(),
              "extrinsics": camera_pose(model, data, config.camera).tolist()}
    grid, robot = grid_of(config), images["segmentation"] == SEG_ROBOT
    if not with_ids:
        return grid.project(images["rgb"], images["depth"], camera, LAYOUT.table_height, robot=robot)
    return grid.project_with_labels(images["rgb"], images["segmentation"], images["depth"], camera,
                                    LAYOUT.table_height, robot=robot)


@dataclass(frozen=True)
class Decision:
    """One object moved: grasp (x, y, z [m], yaw [rad]), the finger opening before closing [m], the
    lift height (z [m]), the goal (x, y, z, yaw of the TCP where it lets go, or holds for ``pick_up``),
    whether it lets go there, and whether it is the episode's last."""

    grasp: tuple[float, float, float, float]
    opening: float
    lift: float
    goal: tuple[float, float, float, float]
    release: bool
    last: bool
    frame: int = 0

    def as_array(self) -> np.ndarray:
        """(13,): grasp (4), opening, lift, goal (4), release, last, frame."""
        return np.array([*self.grasp, self.opening, self.lift, *self.goal, float(self.release), float(self.last),
                         float(self.frame)])


def decisions(subtasks: Sequence[str] | str, subtask_index: np.ndarray, tcp_pos: np.ndarray, tcp_quat: np.ndarray,
              opening: np.ndarray) -> list[Decision]:
    """The decisions of a recorded episode (its ``subtasks`` attribute, per-frame ``subtask_index``,
    TCP and finger opening), in order; [] for an episode whose subtasks do not read as grasp, lift and
    carry (a re-grasp after a slip, an episode cut short)."""
    names = json.loads(subtasks) if isinstance(subtasks, str) else list(subtasks)
    idx = np.asarray(subtask_index)
    tcp = np.asarray(tcp_pos, np.float64)
    yaw = tcp_yaw(np.asarray(tcp_quat, np.float64))
    opening = np.asarray(opening, np.float64)
    starts = {}
    for k in range(len(names)):
        hits = np.flatnonzero(idx == k)
        if len(hits):
            starts[k] = (int(hits[0]), int(hits[-1]))
    out: list[Decision] = []
    frame = 0
    k = 0
    while k < len(names):
        if names[k] != "CloseGripper":
            k += 1
            continue
        if k not in starts or k + 1 >= len(names) or names[k + 1] != "MoveUP" or k + 1 not in starts:
            return []
        tc = starts[k][0]
        lift_end = starts[k + 1][1]
        grasp = (*tcp[tc], float(yaw[tc]))
        lift = float(tcp[lift_end, 2])
        release = next((j for j in range(k + 2, len(names)) if names[j] in ("OpenGripper", "CloseGripper")), None)
        if release is not None and names[release] == "OpenGripper":
            if release not in starts:
                return []
            to = starts[release][0]
            goal = (*tcp[to], float(yaw[to]))
            out.append(Decision(grasp, float(opening[tc]), lift, goal, True, False, frame))
            home = next((j for j in range(release, len(names)) if names[j] == "MoveToDefaultPos"), None)
            if home is not None and home in starts:
                frame = starts[home][1] + 1
            k = release + 1
        else:
            goal = (*tcp[lift_end], float(yaw[lift_end]))
            out.append(Decision(grasp, float(opening[tc]), lift, goal, False, False, frame))
            k += 2
    if out:
        out[-1] = replace(out[-1], last=True)
    if len(set(d.frame for d in out)) != len(out):
        return []
    return out


LABELS = 13  # grasp row, col, z, yaw, opening, lift; goal row, col, z, yaw; release, last; cell-free flag


def keypose_targets(d: Decision, grid: TopDownGrid) -> np.ndarray:
    """The labels (:data:`LABELS`,) of a decision on the network's maps: grasp row and column
    (fractional cells of the coarse map), z and lift over the table [:data:`HEIGHT_UNIT`], yaw [rad],
    opening [:data:`OPENING_UNIT`]; the goal's row, column, z and yaw; release and last (0/1); 1 when
    both cells lie on the map."""
    coarse = grid.coarse(FACTOR)
    g = coarse.cell_of(np.array(d.grasp[:2]))
    p = coarse.cell_of(np.array(d.goal[:2]))
    inside = all(0 <= v[0] <= coarse.rows - 1 and 0 <= v[1] <= coarse.cols - 1 for v in (g, p))
    table = LAYOUT.table_height
    return np.array([g[0], g[1], (d.grasp[2] - table) / HEIGHT_UNIT, d.grasp[3], d.opening / OPENING_UNIT,
                     (d.lift - table) / HEIGHT_UNIT, p[0], p[1], (d.goal[2] - table) / HEIGHT_UNIT, d.goal[3],
                     float(d.release), float(d.last), float(inside)], np.float32)


def _labelled(obj: Mapping[str, Any], attribute: str) -> bool:
    """Whether the auxiliary maps name this attribute of ``obj``: not the class of a held-out class (L4),
    which the policy must never have been told, as perception leaves it out."""
    return not (attribute == "name" and str(obj.get("name")) in HELD_OUT_CLASSES)


def attribute_values(scenes: Sequence[Mapping[str, Any]]) -> dict[str, list[str]]:
    """Per attribute of :data:`KEYPOSE_ATTRIBUTES`, the values the scenes' objects have, sorted (no
    held-out class among the classes)."""
    values = {a: sorted({str(o.get(a)) for s in scenes for o in s["objects"] if _labelled(o, a)})
              for a in KEYPOSE_ATTRIBUTES}
    for a, v in values.items():
        if len(v) > ATTRIBUTE_VALUES:
            raise ConfigError(f"dataset: {len(v)} values of {a!r} ({', '.join(v[:5])}, ...); the keypose policy's "
                              f"attribute maps hold {ATTRIBUTE_VALUES}")
    return values


def attribute_maps(ids: np.ndarray, scene: Mapping[str, Any], values: Mapping[str, list[str]]) -> np.ndarray:
    """(attributes, rows/FACTOR, cols/FACTOR) int8: per coarse cell the index of each attribute of the
    object seen there (``ids``: segmentation ids per grid cell), -1 where no object is and for the class
    of a held-out class."""
    coarse = ids[FACTOR // 2::FACTOR, FACTOR // 2::FACTOR]
    out = np.full((len(KEYPOSE_ATTRIBUTES), *coarse.shape), -1, np.int8)
    for obj in scene["objects"]:
        where = coarse == int(obj["segmentation_id"])
        for a, name in enumerate(KEYPOSE_ATTRIBUTES):
            if _labelled(obj, name):
                out[a][where] = values[name].index(str(obj.get(name)))
    return out

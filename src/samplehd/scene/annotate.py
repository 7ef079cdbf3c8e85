"""CLEVR-layout annotations of a scene, with the SAMPLE-HD fields added.

A scene entry (one per scene in ``scenes.json``, and alone in ``scenes/<stem>.json``)::

    split, image_index, image_filename, seed, version,
    directions       {left, right, front, behind, above, below: unit vectors in the world}
    objects          [{name, shape, color, colour, material, size, weight, mass, table_part,
                       3d_coords, rotation (yaw deg), orientation (quat w,x,y,z), pixel_coords [u, v, depth],
                       bbox {min, max, extents} (world, axis-aligned), footprint_half_extents,
                       segmentation_id, affordances, opening_radius, top_extent, variant}]
    relationships    {left, right, front, behind: per object i, sorted j in that direction of i}
    camera           {name, width, height, intrinsics K, extrinsics (camera-to-world 4x4, MuJoCo axes),
                       pos, target, fovy}
    manipulator      {joint_names, joint_positions, tcp_position, tcp_quaternion, gripper_opening}
    segmentation_ids {background: 0, table: 1, robot: 2, object_offset: 3}
    spec             SceneSpec.to_dict(): exactly rebuilds the world
"""

from __future__ import annotations

from typing import Any, TypedDict

import mujoco
import numpy as np

from samplehd.catalogue import object_facts
from samplehd.fixedmath import matmul
from samplehd.render.renderer import (
    SEG_BACKGROUND,
    SEG_OBJECT_OFFSET,
    SEG_ROBOT,
    SEG_TABLE,
    camera_intrinsics,
    camera_pose,
    project_points,
)
from samplehd.robot.constants import JOINT_NAMES, ROBOT_BODY
from samplehd.scene.spec import SceneSpec
from samplehd.version import __version__
from samplehd.world.bodies import object_body_name
from samplehd.world.grasps import graspable_in_scene
from samplehd.world.layout import DIRECTIONS, table_parts_of
from samplehd.world.relations import compute_relationships
from samplehd.world.transforms import quat_to_mat, yaw_from_quat

__all__ = ["ObjectAnnotation", "SceneAnnotation", "annotate_scene", "image_stem"]


# One object of a scene entry, as the module docstring lists its keys (CLEVR's and SAMPLE-HD's); the
# JSON key "3d_coords" is not an identifier, so the class is declared in the functional form.
ObjectAnnotation = TypedDict("ObjectAnnotation", {
    "name": str, "shape": str, "color": str, "colour": str, "material": str, "size": str, "weight": str,
    "mass": float, "table_part": list[str], "3d_coords": list[float], "rotation": float,
    "orientation": list[float], "pixel_coords": list[float], "bbox": dict[str, list[float]],
    "footprint_half_extents": list[float], "segmentation_id": int, "affordances": list[str],
    "opening_radius": float, "top_extent": float, "variant": str}, total=False)


class SceneAnnotation(TypedDict, total=False):
    """A scene entry of ``scenes.json`` (one per scene; alone in ``scenes/<stem>.json``): the keys the
    module docstring lists. Not every producer writes every key (a perceived scene has objects,
    relationships and directions, and per object its ``attribute_scores``), hence ``total=False``."""

    split: str
    image_index: int
    image_filename: str
    seed: int
    version: str
    directions: dict[str, list[float]]
    objects: list[ObjectAnnotation]
    relationships: dict[str, list[list[int]]]
    camera: dict[str, Any]
    manipulator: dict[str, Any]
    segmentation_ids: dict[str, int]
    spec: dict[str, Any]
    attribute_scores: list[dict[str, Any]]


def image_stem(split: str, index: int) -> str:
    """File stem shared by a scene's image, depth, segmentation and annotation files."""
    return f"SHD_{split}_{index:06d}"


def _manipulator(model: mujoco.MjModel, data: mujoco.MjData) -> dict[str, Any]:
    q = [float(data.qpos[model.jnt_qposadr[model.joint(j).id]]) for j in JOINT_NAMES]
    sid = model.site("tcp").id
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, data.site_xmat[sid])
    fingers = [data.qpos[model.jnt_qposadr[model.joint(j).id]] for j in ("robot_left_finger_joint",
                                                                        "robot_right_finger_joint")]
    return {
        "joint_names": list(JOINT_NAMES),
        "joint_positions": q,
        "tcp_position": data.site_xpos[sid].tolist(),
        "tcp_quaternion": quat.tolist(),
        "gripper_joint_positions": [float(f) for f in fingers],
    }


def annotate_scene(
    scene: SceneSpec,
    model: mujoco.MjModel,
    data: mujoco.MjData,
    width: int,
    height: int,
    split: str = "train",
    camera: str = "scene",
) -> SceneAnnotation:
    """Build the CLEVR-layout annotation of a compiled scene seen from `camera` at width × height."""
    objects = []
    centers = []
    all_facts = [object_facts(obj.instance) for obj in scene.objects]
    if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, ROBOT_BODY) >= 0:
        reachable = graspable_in_scene(model, data, all_facts)
    else:  # a world without the arm: a top-down grasp site that fits the stroke is all there is to check
        reachable = [any(site.approach[2] < -0.7 for site in f.graspable_sites) for f in all_facts]
    for i, obj in enumerate(scene.objects):
        facts = all_facts[i]
        body = model.body(object_body_name(i)).id
        pos = data.xpos[body].copy()
        quat = data.xquat[body].copy()
        rot = quat_to_mat(quat)
        lo, hi = np.asarray(facts.bbox_min), np.asarray(facts.bbox_max)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        world_corners = matmul(corners, rot.T) + pos
        center = pos + matmul(rot, (lo + hi) / 2)
        centers.append(center)
        inst = obj.instance
        aff = facts.affordances.to_dict()
        # Graspable in this scene: the class is, and the ground-truth planner finds a top-down grasp
        # that the arm reaches from home without touching a neighbour (a rectangular board's edge, a
        # wide box, or a mug hemmed in by taller objects is not).
        aff["graspable"] = bool(aff.get("graspable")) and reachable[i]
        objects.append(
            {
                "name": inst.class_name,
                "shape": inst.class_name,
                "variant": inst.variant,
                "color": inst.colour,
                "colour": inst.colour,
                "material": inst.material,
                "size": inst.size,
                "weight": facts.weight,
                "mass": round(float(facts.mass), 6),
                "table_part": table_parts_of(pos[:2]),
                "3d_coords": pos.tolist(),
                "rotation": float(np.degrees(yaw_from_quat(quat))),
                "orientation": quat.tolist(),
                "bbox": {
                    "min": world_corners.min(0).tolist(),
                    "max": world_corners.max(0).tolist(),
                    "extents": list(facts.extents),
                },
                "footprint_half_extents": list(facts.footprint_half_extents),
                "segmentation_id": SEG_OBJECT_OFFSET + i,
                "affordances": aff,
                "opening_radius": facts.opening_radius,
                "top_extent": None if facts.top_extent is None else list(facts.top_extent),
            }
        )
    # pixel_coords: where the object's origin (its base centre) projects, as CLEVR does with 3d_coords;
    # nudged 1 cm up so it lands on the object rather than the table at its foot.
    anchor = np.array([o["3d_coords"] for o in objects]) + np.array([0.0, 0.0, 0.01])
    pix = project_points(model, data, camera, width, height, anchor) if objects else np.zeros((0, 3))
    for o, p in zip(objects, pix, strict=True):
        o["pixel_coords"] = [int(round(p[0])), int(round(p[1])), float(p[2])]
    cam = next(c for c in (scene.camera,) if c.name == camera) if scene.camera.name == camera else None
    return {
        "split": split,
        "image_index": scene.index,
        "image_filename": f"{image_stem(split, scene.index)}.png",
        "seed": scene.seed,
        "version": __version__,
        "directions": {k: list(v) for k, v in DIRECTIONS.items()},
        "objects": objects,
        "relationships": compute_relationships(objects),
        "camera": {
            "name": camera,
            "width": width,
            "height": height,
            "intrinsics": camera_intrinsics(model, camera, width, height).tolist(),
            "extrinsics": camera_pose(model, data, camera).tolist(),
            **({"pos": list(cam.pos), "target": list(cam.target), "fovy": cam.fovy} if cam else {}),
        },
        "manipulator": _manipulator(model, data),
        "segmentation_ids": {
            "background": SEG_BACKGROUND, "table": SEG_TABLE, "robot": SEG_ROBOT, "object_offset": SEG_OBJECT_OFFSET,
        },
        "spec": scene.to_dict(),
    }

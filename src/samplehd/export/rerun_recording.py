"""Export one dataset episode as a Rerun recording (``.rrd``), opened with ``rerun FILE.rrd``.

Entities (timelines ``frame`` (control step) and ``time`` (seconds of simulated time)):

- ``world/<body>/<geom>``: every visible geom of the compiled scene as a ``Mesh3D`` (static, in its
  body's frame, with its colour); ``world/<body>`` carries the body's pose per frame
  (``Transform3D``) from the recorded physics state, so objects, arm and fingers move.
- ``world/camera/<cam>``: each stored camera's pose and pinhole model, with its ``rgb`` image,
  ``depth`` (``DepthImage`` [m]) and ``segmentation`` (``SegmentationImage``: 0 background, 1 table,
  2 robot, 3 + i object i, labelled) per frame.
- ``joints/<joint>`` [rad], ``gripper/opening`` [m], ``gripper/command`` (+1 open, -1 closed),
  ``steering/<axis>`` (SAMPLE-HD's 7-D steering vector): ``Scalars`` series.
- ``subtask``: a ``TextLog`` entry at the first frame of every subtask (and ``Succeeded`` /
  ``Completed`` markers at the end), and ``subtask/index`` as a series.
- ``instruction``: the instruction, its program and the scene as a static ``TextDocument``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from samplehd.dataset.reader import DatasetReader
from samplehd.errors import ConfigError, DatasetError
from samplehd.render.renderer import camera_intrinsics
from samplehd.scene.spec import SceneSpec, compile_scene
from samplehd.scene.world import OPERATOR_CAMERA

__all__ = ["episode_location", "export_rerun"]

_JOINTS = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")
_STEERING = ("vx", "vy", "vz", "wx", "wy", "wz", "gripper")
_FLOOR_HALF = 2.0  # the floor plane is drawn as a square of this half size [m]


def _geom_mesh(model: mujoco.MjModel, g: int) -> tuple[np.ndarray, np.ndarray] | None:
    """(vertices, triangles) of geom ``g`` in its own frame, or None for geoms not drawn."""
    import trimesh

    kind, size = model.geom_type[g], model.geom_size[g]
    t = mujoco.mjtGeom
    if kind == t.mjGEOM_MESH:
        m = model.geom_dataid[g]
        v0, nv = model.mesh_vertadr[m], model.mesh_vertnum[m]
        f0, nf = model.mesh_faceadr[m], model.mesh_facenum[m]
        return model.mesh_vert[v0:v0 + nv].copy(), model.mesh_face[f0:f0 + nf].copy()
    if kind == t.mjGEOM_BOX:
        mesh = trimesh.creation.box(extents=2 * size)
    elif kind == t.mjGEOM_SPHERE:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=size[0])
    elif kind == t.mjGEOM_ELLIPSOID:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        mesh.apply_scale(size)
    elif kind == t.mjGEOM_CYLINDER:
        mesh = trimesh.creation.cylinder(radius=size[0], height=2 * size[1], sections=24)
    elif kind == t.mjGEOM_CAPSULE:
        mesh = trimesh.creation.capsule(radius=size[0], height=2 * size[1], count=[12, 12])
    elif kind == t.mjGEOM_PLANE:
        h = size[0] if size[0] > 0 else _FLOOR_HALF
        w = size[1] if size[1] > 0 else _FLOOR_HALF
        return (np.array([[-h, -w, 0], [h, -w, 0], [h, w, 0], [-h, w, 0]], float),
                np.array([[0, 1, 2], [0, 2, 3]], np.int32))
    else:
        return None
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def _geom_rgba(model: mujoco.MjModel, g: int) -> np.ndarray:
    mat = model.geom_matid[g]
    rgba = model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[g]
    return np.clip(np.round(np.asarray(rgba) * 255), 0, 255).astype(np.uint8)


def _name(model: mujoco.MjModel, kind: mujoco.mjtObj, i: int, prefix: str) -> str:
    return mujoco.mj_id2name(model, kind, i) or f"{prefix}{i}"


def _quat_xyzw(wxyz: np.ndarray) -> list[float]:
    return [float(wxyz[1]), float(wxyz[2]), float(wxyz[3]), float(wxyz[0])]


def episode_location(path: str | Path, episode: int | None) -> tuple[Path, int]:
    """(dataset root, episode index) of an episode given as its file (``DIR/episodes/<stem>.h5``) or as
    a dataset folder and an index."""
    path = Path(path)
    if path.is_dir():
        return path, 0 if episode is None else episode
    if not path.is_file():
        raise DatasetError(f"{path}: no such episode file or dataset folder")
    if episode is not None:
        raise ConfigError(f"episode={episode}: give it with a dataset folder, not with the episode file {path}",
                          field="episode")
    root = path.resolve().parent.parent
    try:
        reader = DatasetReader(root)
    except DatasetError as exc:
        raise DatasetError(f"{path}: not an episode file inside a samplehd dataset ({exc})") from None
    for k, e in enumerate(reader.episodes):
        if (root / e.file).resolve() == path.resolve():
            return root, k
    raise DatasetError(f"{path}: not listed among the episodes of {root}")


def export_rerun(root: str | Path, episode: int, out: str | Path) -> dict[str, Any]:
    """Write episode ``episode`` of the dataset at ``root`` as a Rerun recording ``out`` (.rrd).

    Returns:
        ``{frames, bodies, meshes, cameras, subtasks}``.

    Raises:
        ConfigError: ``out`` does not end in .rrd. DatasetError: no such episode.
    """
    import rerun as rr

    out = Path(out)
    if out.suffix.lower() != ".rrd":
        raise ConfigError(f"out={out}: a Rerun recording must end in .rrd", field="out")
    reader = DatasetReader(root)
    if not 0 <= episode < len(reader):
        raise DatasetError(f"episode {episode}: {root} has episodes 0..{len(reader) - 1}")
    entry = reader.episodes[episode]
    ep = reader.episode(episode)
    scene_doc = reader.scene(entry.scene_index)
    model, data = compile_scene(SceneSpec.from_dict(scene_doc["spec"]))
    f = ep.frames
    if f["qpos"].shape[1] != model.nq:
        raise DatasetError(f"episode {episode}: states hold {f['qpos'].shape[1]} qpos values, the scene model "
                           f"{model.nq}; the dataset does not match this samplehd")
    inst = reader.instruction(episode)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.tmp")
    rec = rr.RecordingStream("samplehd", recording_id=f"samplehd-{Path(root).resolve().name}-{episode}")
    rec.save(str(tmp))
    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    rec.log("instruction", rr.TextDocument(
        f"# {inst['instruction']}\n\nfamily: {inst['family']}\n\nprogram: `{inst['program_sequence']}`\n\n"
        f"scene {entry.scene_index}: " + ", ".join(f"{i}: {o.get('colour', '')} {o.get('material', '')} {o['name']}"
                                                   for i, o in enumerate(scene_doc["objects"])),
        media_type="text/markdown"), static=True)

    # Static geometry, one mesh per visible geom, under its body.
    bodies: dict[int, str] = {}
    meshes = 0
    for g in range(model.ngeom):
        if model.geom_rgba[g][3] == 0 and model.geom_matid[g] < 0:
            continue
        if model.geom_group[g] > 2:  # collision-only groups are not drawn by MuJoCo's viewer either
            continue
        mesh = _geom_mesh(model, g)
        if mesh is None:
            continue
        b = int(model.geom_bodyid[g])
        bodies.setdefault(b, "world" if b == 0 else f"world/{_name(model, mujoco.mjtObj.mjOBJ_BODY, b, 'body')}")
        path = f"{bodies[b]}/{_name(model, mujoco.mjtObj.mjOBJ_GEOM, g, 'geom')}"
        verts, faces = mesh
        rgba = _geom_rgba(model, g)
        rec.log(path, rr.Transform3D(translation=model.geom_pos[g], quaternion=_quat_xyzw(model.geom_quat[g])),
                static=True)
        rec.log(path, rr.Mesh3D(vertex_positions=verts.astype(np.float32), triangle_indices=faces.astype(np.uint32),
                                albedo_factor=rgba), static=True)
        meshes += 1
    # Bodies welded to the world (table, robot base mount) get one static pose; the others one per frame.
    mujoco.mj_kinematics(model, data)
    for b in bodies:
        if b != 0 and model.body_weldid[b] == 0:
            rec.log(bodies[b], rr.Transform3D(translation=data.xpos[b], quaternion=_quat_xyzw(data.xquat[b])),
                    static=True)
    moving = [b for b in bodies if b != 0 and model.body_weldid[b] != 0]

    # Cameras: pinhole models; segmentation labels.
    images = ep.images
    cam_ids = {c: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, c) for c in images}
    labels = [(0, "background", (0, 0, 0)), (1, "table", (150, 110, 70)), (2, "robot", (200, 200, 210))]
    labels += [(3 + i, f"{i}: {o['name']}", None) for i, o in enumerate(scene_doc["objects"])]
    for cam, mods in images.items():
        first = next(iter(mods.values()))
        h, w = first.shape[1], first.shape[2]
        k = camera_intrinsics(model, cam if cam_ids[cam] >= 0 else OPERATOR_CAMERA.name, w, h)
        rec.log(f"world/camera/{cam}", rr.Pinhole(image_from_camera=k, width=w, height=h,
                                                  camera_xyz=rr.ViewCoordinates.RUB), static=True)
        rec.log(f"world/camera/{cam}", rr.AnnotationContext(
            [rr.AnnotationInfo(id=i, label=name, color=col) for i, name, col in labels]), static=True)

    for name in _JOINTS:
        rec.log(f"joints/{name}", rr.SeriesLines(names=name), static=True)
    subtask_starts = 0
    last_subtask = -1
    for t in range(ep.num_frames):
        rec.set_time("frame", sequence=t)
        rec.set_time("time", duration=float(f["time"][t]))
        data.qpos[:] = f["qpos"][t]
        mujoco.mj_kinematics(model, data)
        mujoco.mj_camlight(model, data)
        for b in moving:
            rec.log(bodies[b], rr.Transform3D(translation=data.xpos[b], quaternion=_quat_xyzw(data.xquat[b])))
        for cam, mods in images.items():
            cid = cam_ids[cam] if cam_ids[cam] >= 0 else mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA,
                                                                             OPERATOR_CAMERA.name)
            rot = data.cam_xmat[cid].reshape(3, 3)
            rec.log(f"world/camera/{cam}", rr.Transform3D(translation=data.cam_xpos[cid], mat3x3=rot))
            if "rgb" in mods:
                rec.log(f"world/camera/{cam}/rgb", rr.Image(np.asarray(mods["rgb"][t])))
            if "depth" in mods:
                rec.log(f"world/camera/{cam}/depth", rr.DepthImage(np.asarray(mods["depth"][t]), meter=1.0))
            if "segmentation" in mods:
                rec.log(f"world/camera/{cam}/segmentation",
                        rr.SegmentationImage(np.asarray(mods["segmentation"][t]).astype(np.uint16)))
        for j, name in enumerate(_JOINTS):
            rec.log(f"joints/{name}", rr.Scalars(float(f["joint_pos"][t][j])))
        rec.log("gripper/opening", rr.Scalars(float(f["gripper_opening"][t])))
        rec.log("gripper/command", rr.Scalars(float(f["gripper_command"][t])))
        for j, name in enumerate(_STEERING):
            rec.log(f"steering/{name}", rr.Scalars(float(f["steering"][t][j])))
        s = int(f["subtask_index"][t])
        rec.log("subtask/index", rr.Scalars(float(s)))
        if s != last_subtask:
            rec.log("subtask", rr.TextLog(ep.subtasks[s], level="INFO"))
            last_subtask = s
            subtask_starts += 1
    for marker in (("Succeeded", "Completed") if ep.success else ("Completed",)):
        rec.log("subtask", rr.TextLog(marker, level="INFO" if marker != "Completed" or ep.success else "WARN"))
    rec.flush()
    rec.disconnect()
    tmp.replace(out)
    return {"frames": ep.num_frames, "bodies": len(bodies) - (0 in bodies), "moving": len(moving), "meshes": meshes,
            "cameras": list(images),
            "subtasks": subtask_starts}

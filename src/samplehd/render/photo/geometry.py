"""Triangle meshes of a compiled MuJoCo model's visible geoms, in their bodies' frames.

Every geom the GL presets draw (geom groups 0-2, not fully transparent) becomes triangles with
per-vertex normals and texture coordinates. Primitives get metric texture coordinates (1 unit = 1 m
along the surface), so that a material's texture scale is a physical size; meshes keep their own
coordinates, except food boxes (per-face planar) and cans (cylindrical), which carry printed labels.

Geoms are grouped into parts, one per (body, material): a part moves rigidly with its body, so a frame
needs one transform per part; parts of bodies welded to the world are static.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

__all__ = ["Part", "VISIBLE_GROUPS", "geom_triangles", "model_parts", "model_texture"]

VISIBLE_GROUPS = (0, 1, 2)  # MuJoCo's default geom-group visibility, as the GL presets render
_FLOOR_HALF = 12.0  # [m] an infinite plane becomes a square this large (the room is 6 m wide)
_G = mujoco.mjtGeom


@dataclass
class Part:
    """Triangles of one body and one material.

    Attributes:
        body: body id.
        material: material name ('' when the geoms have none).
        rgba: the material's (or first geom's) colour.
        mesh_class: catalogue class of a mesh ('food_box', 'soda_can', ...), '' for primitives.
        texture: the material's RGB texture id in the model (-1: none).
        static: the body is welded to the world.
        vertices, normals: (n, 3) in the body frame.
        texcoords: (n, 2).
        faces: (m, 3) int32.
    """

    body: int
    material: str
    rgba: np.ndarray
    mesh_class: str
    texture: int
    static: bool
    vertices: np.ndarray
    normals: np.ndarray
    texcoords: np.ndarray
    faces: np.ndarray


def _box(half: np.ndarray) -> tuple[np.ndarray, ...]:
    verts, norms, uvs, faces = [], [], [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            u_ax, v_ax = [a for a in range(3) if a != axis]
            if sign < 0:
                u_ax, v_ax = v_ax, u_ax  # keep the winding counter-clockwise seen from outside
            n = np.zeros(3)
            n[axis] = sign
            base = len(verts)
            for cu, cv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = np.zeros(3)
                p[axis] = sign * half[axis]
                p[u_ax] = cu * half[u_ax]
                p[v_ax] = cv * half[v_ax]
                verts.append(p)
                norms.append(n)
                uvs.append((p[u_ax], p[v_ax]))
            faces += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    return np.array(verts), np.array(norms), np.array(uvs), np.array(faces)


def _grid_faces(rows: int, cols: int, offset: int = 0) -> np.ndarray:
    """Two triangles per cell of a (rows+1)×(cols+1) vertex grid, row-major."""
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    a = offset + r * (cols + 1) + c
    b, d = a + 1, a + cols + 1
    e = d + 1
    return np.concatenate([np.stack([a, b, e], -1).reshape(-1, 3), np.stack([a, e, d], -1).reshape(-1, 3)])


def _revolve(profile_r: np.ndarray, profile_z: np.ndarray, profile_nr: np.ndarray, profile_nz: np.ndarray,
             segments: int, offset: int = 0) -> tuple[np.ndarray, ...]:
    """Surface of revolution about z from a profile (radius, height, normal per profile point)."""
    phi = np.linspace(0.0, 2 * np.pi, segments + 1)
    cp, sp = np.cos(phi)[None, :], np.sin(phi)[None, :]
    r, z = profile_r[:, None], profile_z[:, None]
    verts = np.stack([r * cp, r * sp, np.broadcast_to(z, (len(profile_r), segments + 1))], -1).reshape(-1, 3)
    nr, nz = profile_nr[:, None], profile_nz[:, None]
    norms = np.stack([nr * cp, nr * sp, np.broadcast_to(nz, (len(profile_r), segments + 1))], -1).reshape(-1, 3)
    arc = np.max(profile_r) * phi
    uv = np.stack(np.broadcast_arrays(arc[None, :], z), -1).reshape(-1, 2)
    faces = _grid_faces(len(profile_r) - 1, segments, offset)
    faces = faces[:, [0, 2, 1]]  # profile runs bottom→top, so flip to face outwards
    return verts, norms, uv, faces


def _disc(radius: float, z: float, up: bool, segments: int, offset: int) -> tuple[np.ndarray, ...]:
    phi = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    ring = np.stack([radius * np.cos(phi), radius * np.sin(phi), np.full(segments, z)], -1)
    verts = np.vstack([[0.0, 0.0, z], ring])
    norms = np.tile([0.0, 0.0, 1.0 if up else -1.0], (segments + 1, 1))
    uv = verts[:, :2].copy()
    i = np.arange(segments)
    faces = np.stack([np.zeros(segments, int), 1 + i, 1 + (i + 1) % segments], -1) + offset
    if not up:
        faces = faces[:, [0, 2, 1]]
    return verts, norms, uv, faces


def _concat(parts: list[tuple[np.ndarray, ...]]) -> tuple[np.ndarray, ...]:
    return tuple(np.concatenate([p[k] for p in parts]) for k in range(4))


def _cylinder(radius: float, half: float, segments: int = 40) -> tuple[np.ndarray, ...]:
    side = _revolve(np.array([radius, radius]), np.array([-half, half]), np.ones(2), np.zeros(2), segments)
    n = len(side[0])
    top = _disc(radius, half, True, segments, n)
    bottom = _disc(radius, -half, False, segments, n + len(top[0]))
    return _concat([side, top, bottom])


def _sphere_profile(radius: float, rings: int, z0: float, lo: float, hi: float) -> tuple[np.ndarray, ...]:
    theta = np.linspace(lo, hi, rings + 1)  # polar angle from -z (0) to +z (pi)
    nr, nz = np.sin(theta), -np.cos(theta)
    return radius * nr, z0 + radius * nz, nr, nz


def _capsule(radius: float, half: float, segments: int = 32, rings: int = 8) -> tuple[np.ndarray, ...]:
    r1, z1, nr1, nz1 = _sphere_profile(radius, rings, -half, 0.0, np.pi / 2)
    r2, z2, nr2, nz2 = _sphere_profile(radius, rings, half, np.pi / 2, np.pi)
    return _revolve(np.concatenate([r1, r2]), np.concatenate([z1, z2]), np.concatenate([nr1, nr2]),
                    np.concatenate([nz1, nz2]), segments)


def _ellipsoid(radii: np.ndarray, segments: int = 32, rings: int = 16) -> tuple[np.ndarray, ...]:
    r, z, nr, nz = _sphere_profile(1.0, rings, 0.0, 0.0, np.pi)
    v, n, uv, f = _revolve(r, z, nr, nz, segments)
    v = v * radii
    n = n / radii
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    return v, n, uv * float(np.max(radii)), f


def _plane(half_x: float, half_y: float) -> tuple[np.ndarray, ...]:
    hx = half_x if half_x > 0 else _FLOOR_HALF
    hy = half_y if half_y > 0 else _FLOOR_HALF
    verts = np.array([[-hx, -hy, 0.0], [hx, -hy, 0.0], [hx, hy, 0.0], [-hx, hy, 0.0]])
    return verts, np.tile([0.0, 0.0, 1.0], (4, 1)), verts[:, :2].copy(), np.array([[0, 1, 2], [0, 2, 3]])


def _mesh(model: mujoco.MjModel, mesh_id: int) -> tuple[np.ndarray, ...]:
    """A MuJoCo mesh unrolled to one vertex per face corner (so texcoords and normals may be split)."""
    va, fa, fn = model.mesh_vertadr[mesh_id], model.mesh_faceadr[mesh_id], model.mesh_facenum[mesh_id]
    face = model.mesh_face[fa:fa + fn]
    verts = model.mesh_vert[va + face.ravel()].astype(np.float64)
    na = model.mesh_normaladr[mesh_id]
    if model.mesh_normalnum[mesh_id] > 0:
        norms = model.mesh_normal[na + model.mesh_facenormal[fa:fa + fn].ravel()].astype(np.float64)
    else:
        tri = verts.reshape(-1, 3, 3)
        fnorm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        norms = np.repeat(fnorm / np.maximum(np.linalg.norm(fnorm, axis=1, keepdims=True), 1e-12), 3, axis=0)
    ta = model.mesh_texcoordadr[mesh_id]
    if ta >= 0 and model.mesh_texcoordnum[mesh_id] > 0:
        uv = model.mesh_texcoord[ta + model.mesh_facetexcoord[fa:fa + fn].ravel()].astype(np.float64)
    else:
        uv = verts[:, :2].copy()
    return verts, norms, uv, np.arange(3 * fn).reshape(-1, 3)


def geom_triangles(model: mujoco.MjModel, geom: int) -> tuple[np.ndarray, ...] | None:
    """(vertices, normals, texcoords, faces) of a geom in its own frame, or None for a type not drawn."""
    size = model.geom_size[geom]
    t = int(model.geom_type[geom])
    if t == _G.mjGEOM_BOX:
        return _box(size)
    if t == _G.mjGEOM_SPHERE:
        return _ellipsoid(np.full(3, size[0]))
    if t == _G.mjGEOM_ELLIPSOID:
        return _ellipsoid(size.copy())
    if t == _G.mjGEOM_CYLINDER:
        return _cylinder(size[0], size[1])
    if t == _G.mjGEOM_CAPSULE:
        return _capsule(size[0], size[1])
    if t == _G.mjGEOM_PLANE:
        return _plane(size[0], size[1])
    if t == _G.mjGEOM_MESH and model.geom_dataid[geom] >= 0:
        return _mesh(model, int(model.geom_dataid[geom]))
    return None


def _quat_mat(q: np.ndarray) -> np.ndarray:
    m = np.zeros(9)
    mujoco.mju_quat2Mat(m, np.asarray(q, dtype=np.float64))
    return m.reshape(3, 3)


def geom_rgba(model: mujoco.MjModel, geom: int) -> np.ndarray:
    """The colour MuJoCo draws a geom with: its material's when it has one, else its own."""
    mat = int(model.geom_matid[geom])
    return np.array(model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[geom], dtype=np.float64)


def visible_geoms(model: mujoco.MjModel) -> list[int]:
    """Geoms the GL presets draw: visible groups, not fully transparent, of a drawable type."""
    out = []
    for g in range(model.ngeom):
        if int(model.geom_group[g]) not in VISIBLE_GROUPS or geom_rgba(model, g)[3] <= 0.0:
            continue
        if int(model.geom_type[g]) in (_G.mjGEOM_HFIELD, _G.mjGEOM_SDF, _G.mjGEOM_NONE):
            continue
        out.append(g)
    return out


def _mesh_class(model: mujoco.MjModel, geom: int, classes: tuple[str, ...]) -> str:
    if int(model.geom_type[geom]) != _G.mjGEOM_MESH or model.geom_dataid[geom] < 0:
        return ""
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_MESH, int(model.geom_dataid[geom])) or ""
    return next((c for c in classes if name.startswith(c + "_")), "")


def _label_uv(cls: str, verts: np.ndarray, norms: np.ndarray) -> np.ndarray:
    """Printed-label coordinates in the object frame: cylindrical for cans, per face for boxes."""
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    ext = np.maximum(hi - lo, 1e-9)
    if cls == "soda_can":
        u = (np.arctan2(verts[:, 1], verts[:, 0]) / (2 * np.pi)) % 1.0
        tri_u = u.reshape(-1, 3)  # unrolled triangles: fix the seam where u wraps from 1 to 0
        wrap = (tri_u.max(axis=1) - tri_u.min(axis=1)) > 0.5
        tri_u[wrap] = np.where(tri_u[wrap] < 0.5, tri_u[wrap] + 1.0, tri_u[wrap])
        return np.stack([tri_u.ravel(), (verts[:, 2] - lo[2]) / ext[2]], -1)
    # Food box: the big faces (normal ±y, the box's thin axis) show the front/back print; u along x.
    axis = np.argmax(np.abs(norms), axis=1)
    uv = np.empty((len(verts), 2))
    rel = (verts - lo) / ext
    for a, (iu, iv) in enumerate(((1, 2), (0, 2), (0, 1))):
        sel = axis == a
        uv[sel, 0] = rel[sel, iu]
        uv[sel, 1] = rel[sel, iv]
    # Encode the face in u so one texture holds front, side and top prints: [0,1) front/back, [1,2) sides, [2,3) top.
    uv[:, 0] += np.select([axis == 1, axis == 0], [0.0, 1.0], 2.0)
    return uv


LABELLED_CLASSES = ("food_box", "soda_can")
# Mesh names of catalogue objects start with their class; these classes get their own look.
NAMED_CLASSES = (*LABELLED_CLASSES, "knife", "fork", "spoon", "scissors")


def model_parts(model: mujoco.MjModel, classes: tuple[str, ...] = NAMED_CLASSES) -> list[Part]:
    """All visible geoms of the model as parts, one per (body, material, labelled class)."""
    groups: dict[tuple[int, int, str], list[tuple[np.ndarray, ...]]] = {}
    rgba: dict[tuple[int, int, str], np.ndarray] = {}
    for g in visible_geoms(model):
        tri = geom_triangles(model, g)
        if tri is None:
            continue
        v, n, uv, f = tri
        rot = _quat_mat(model.geom_quat[g])
        v = v @ rot.T + model.geom_pos[g]
        n = n @ rot.T
        cls = _mesh_class(model, g, classes)
        if cls in LABELLED_CLASSES:
            uv = _label_uv(cls, v, n)
        key = (int(model.geom_bodyid[g]), int(model.geom_matid[g]), cls)
        groups.setdefault(key, []).append((v, n, uv, f))
        rgba.setdefault(key, geom_rgba(model, g))
    parts = []
    for (body, mat, cls), pieces in groups.items():
        verts, norms, uvs, faces = [], [], [], []
        offset = 0
        for v, n, uv, f in pieces:
            verts.append(v)
            norms.append(n)
            uvs.append(uv)
            faces.append(f + offset)
            offset += len(v)
        welded = int(model.body_weldid[body]) == 0 and int(model.body_mocapid[body]) < 0
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_MATERIAL, mat) or "" if mat >= 0 else ""
        tex = int(model.mat_texid[mat, int(mujoco.mjtTextureRole.mjTEXROLE_RGB)]) if mat >= 0 else -1
        parts.append(Part(
            body=body, material=name, rgba=rgba[(body, mat, cls)], mesh_class=cls, texture=tex, static=welded,
            vertices=np.concatenate(verts), normals=np.concatenate(norms), texcoords=np.concatenate(uvs),
            faces=np.concatenate(faces).astype(np.int32),
        ))
    return parts


def model_texture(model: mujoco.MjModel, texture: int) -> np.ndarray:
    """A model texture as an (h, w, 3) uint8 image (a cube texture's first face)."""
    w, h, c = int(model.tex_width[texture]), int(model.tex_height[texture]), int(model.tex_nchannel[texture])
    adr = int(model.tex_adr[texture])
    img = np.asarray(model.tex_data[adr:adr + w * h * c]).reshape(h, w, c)
    if int(model.tex_type[texture]) == int(mujoco.mjtTexture.mjTEXTURE_CUBE) and h >= 6 * w:
        img = img[:w]
    return np.ascontiguousarray(img[..., :3] if c >= 3 else np.repeat(img[..., :1], 3, axis=2))

"""Vendor the SHOP-VRB shapes from a MuBlE checkout into ``samplehd/catalogue/data/shop_vrb``.

Run once by a maintainer (needs the ``mesh`` extra: trimesh, manifold3d); the package itself only
reads the files this writes. For each of the 15 SAMPLE-HD classes' MuBlE objects it:

1. reads ``meshes/train/<name>/simple_mesh.stl`` (visual) and ``<name>_hull_*.stl`` (V-HACD hulls);
2. repairs the visual mesh until it is closed (merge vertices, drop degenerate and duplicate faces,
   cut the faces of non-manifold edges, fan-fill boundary loops); where that fails, the visual mesh
   becomes the union of the hulls (recorded in the provenance file);
3. turns both into samplehd's object frame: z up, resting on z = 0, the body axis (round things)
   or footprint centre at x = y = 0, long objects along x, handles towards +x, cutlery handles and
   scissor rings towards -x; scaled by the variant's real-world factor below;
4. measures what the planner and the annotations need (top surface, container opening, grasp sites)
   and writes ``<class>_<variant>.npz`` (plain arrays) and ``classes.json`` (menus from the
   procedural catalogue, geometry facts).

Usage::

    git clone https://github.com/michaal94/MuBlE /tmp/MuBlE   # or any checkout of it
    python scripts/vendor_shop_vrb.py /tmp/MuBlE
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import subprocess
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path

import manifold3d as mf
import numpy as np
import trimesh
from scipy.spatial import ConvexHull

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "src" / "samplehd" / "catalogue" / "data" / "shop_vrb"
PROCEDURAL = ROOT / "src" / "samplehd" / "catalogue" / "data" / "classes.json"
STROKE = 0.085  # the gripper's stroke [m] (samplehd.robot.constants.GRIPPER_STROKE)

# class -> (how its facts are measured, MuBlE objects in variant order)
CLASSES: dict[str, tuple[str, list[str]]] = {
    "baking_tray": ("tray", ["baking_tray1", "baking_tray2"]),
    "bowl": ("revolved", ["bowl1", "bowl2", "bowl3"]),
    "chopping_board": ("board", ["chopping_board1", "chopping_board2", "chopping_board3"]),
    "food_box": ("box", ["food_box1", "food_box2"]),
    "fork": ("cutlery", ["fork1", "fork2"]),
    "glass": ("revolved", ["glass1", "glass2", "glass3", "glass4", "glass5"]),
    "knife": ("cutlery", ["knife1", "knife2"]),
    "mug": ("revolved", ["mug1", "mug2", "mug3"]),
    "pan": ("revolved", ["pan1", "pan2"]),
    "plate": ("revolved", ["plate1", "plate2"]),
    "scissors": ("scissors", ["scissors1", "scissors2"]),
    "soda_can": ("revolved", ["soda_can"]),
    "spoon": ("cutlery", ["spoon1", "spoon2"]),
    "thermos": ("revolved", ["thermos1", "thermos2"]),
    "wine_glass": ("revolved", ["wine_glass1", "wine_glass2", "wine_glass3"]),
}
# Size factors. MuBlE's food boxes are a 20 cm take-away clamshell and a 17 cm tub, wider than the
# UR5e's 85 mm gripper opens: at 0.38 and 0.45 they are a dip box and a yoghurt tub it can hold.
# MuBlE's can is 79 mm across (a real one 66 mm), its second thermos 86 mm, its first pan 51 cm long.
SCALE = {"food_box1": 0.38, "food_box2": 0.45, "pan1": 0.8, "soda_can": 0.84, "thermos2": 0.85}
KIND = {"food_box2": "revolved"}  # a round tub: measured like a closed round body
HULL_LOOK = {"plate1"}  # its mesh has 256 non-manifold edges; closing it leaves holes, its hulls look right
# MuBlE's mugs have walls up to a centimetre thick (one is nearly solid): their mass counts a wall of
# ``shell`` metres over the surface instead of the mesh volume (a real mug is 0.3-0.4 kg).
SHELL = {"mug": 0.002}
SIZES = {"small": 0.8, "medium": 1.0, "large": 1.2}  # samplehd/catalogue/data/sizes.json
GRIP_LIMIT = STROKE - 2 * 0.0015  # widest site the gripper takes with its least finger clearance [m]
HANDLED = {"mug", "pan", "thermos"}


def _clean(m: trimesh.Trimesh) -> trimesh.Trimesh:
    m.merge_vertices(digits_vertex=5)
    m.update_faces(m.nondegenerate_faces())
    m.update_faces(m.unique_faces())
    m.remove_unreferenced_vertices()
    return m


def _fill_loops(m: trimesh.Trimesh) -> trimesh.Trimesh:
    f = m.faces
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    _, inv, c = np.unique(np.sort(e, axis=1), axis=0, return_inverse=True, return_counts=True)
    boundary = e[c[inv.ravel()] == 1]
    nxt = defaultdict(list)
    for a, b in boundary:
        nxt[a].append(b)
    used: set[tuple[int, int]] = set()
    verts, faces = list(m.vertices), list(m.faces)
    for a0, b0 in boundary:
        if (a0, b0) in used:
            continue
        loop, a, b, ok = [a0], a0, b0, True
        while True:
            used.add((a, b))
            if b == a0:
                break
            loop.append(b)
            cand = [x for x in nxt[b] if (b, x) not in used]
            if not cand or len(loop) > 5000:
                ok = False
                break
            a, b = b, cand[0]
        if not ok or len(loop) < 3:
            continue
        centre = len(verts)
        verts.append(np.mean(m.vertices[loop], axis=0))
        faces += [[loop[(i + 1) % len(loop)], loop[i], centre] for i in range(len(loop))]
    return trimesh.Trimesh(np.array(verts), np.array(faces), process=True)


def repair(m: trimesh.Trimesh) -> trimesh.Trimesh | None:
    """Close the mesh; None when it stays open."""
    m = _clean(m)
    for _ in range(6):
        if m.is_watertight:
            break
        m = _clean(_fill_loops(m))
        f = m.faces
        e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        _, inv, c = np.unique(e, axis=0, return_inverse=True, return_counts=True)
        bad = (c[inv.ravel()] != 2).reshape(3, -1).any(axis=0)
        if not bad.any():
            continue
        m.update_faces(~bad)
        m.remove_unreferenced_vertices()
    if not m.is_watertight:
        return None
    trimesh.repair.fix_normals(m)
    return m


def hull_union(hulls: list[np.ndarray]) -> trimesh.Trimesh:
    solid = mf.Manifold()
    for pts in hulls:
        solid = solid + mf.Manifold.hull_points(pts.tolist())
    mesh = solid.to_mesh()
    return trimesh.Trimesh(np.asarray(mesh.vert_properties[:, :3]), np.asarray(mesh.tri_verts), process=False)


def enclosed(q: trimesh.Trimesh, outer: list[trimesh.Trimesh]) -> bool:
    """Whether an outward shell of ``outer`` holds ``q`` (bounding boxes, 0.1 mm slack) and is larger."""
    return any(bool(np.all(o.bounds[0] <= q.bounds[0] + 1e-4) and np.all(o.bounds[1] >= q.bounds[1] - 1e-4))
               and o.volume > -q.volume for o in outer)


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def frame(kind: str, cls: str, v: np.ndarray) -> np.ndarray:
    """3x3 rotation putting the object into samplehd's frame conventions."""
    r = np.eye(3)
    if kind in ("cutlery", "scissors", "board", "tray", "box"):
        xy = v[:, :2] - v[:, :2].mean(0)
        ext = xy.max(0) - xy.min(0)
        if ext[1] > ext[0]:
            r = rot_z(math.pi / 2) @ r
            v = v @ rot_z(math.pi / 2).T
        if kind in ("cutlery", "scissors", "board"):
            x = v[:, 0] - (v[:, 0].max() + v[:, 0].min()) / 2
            L = x.max() - x.min()
            lo, hi = v[x < x.min() + 0.25 * L], v[x > x.max() - 0.25 * L]
            width = lambda p: p[:, 1].max() - p[:, 1].min()  # noqa: E731
            thick = lambda p: p[:, 2].max() - p[:, 2].min()  # noqa: E731
            if cls == "knife":
                flip = thick(hi) > thick(lo) + 1e-4  # the handle is thicker than the blade
            elif kind == "scissors":
                flip = width(hi) > width(lo)  # the finger rings are wider than the blades
            elif kind == "cutlery":  # forks and spoons: the handle is the narrow end, towards -x
                flip = width(hi) < width(lo)
            else:  # a board's narrow end (its handle) goes to +x
                flip = width(lo) < width(hi)
            if flip:
                r = rot_z(math.pi) @ r
    elif kind == "revolved" and cls in HANDLED:
        axis = body_axis(v)
        d = v[:, :2] - axis
        k = int(np.argmax(np.einsum("ij,ij->i", d, d)))
        a = math.atan2(d[k, 1], d[k, 0])
        r = rot_z(-a) @ r
    return r


def body_axis(v: np.ndarray) -> np.ndarray:
    """(x, y) of a round body's axis: the centre of its bottom's bounding box."""
    z0 = v[:, 2].min()
    h = v[:, 2].max() - z0
    band = v[v[:, 2] < z0 + max(0.08 * h, 0.003)]
    return (band[:, :2].max(0) + band[:, :2].min(0)) / 2


def settle(hulls: list[np.ndarray]) -> np.ndarray:
    """3x3 tilt the object takes when dropped on a table (yaw removed): its natural rest pose."""
    import mujoco

    spec = mujoco.MjSpec()
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.6, 0.6, 0.02], pos=[0, 0, -0.02])
    body = spec.worldbody.add_body(name="o", pos=[0, 0, 0.002])
    body.add_freejoint()
    for k, h in enumerate(hulls):
        spec.add_mesh(name=f"h{k}", uservert=h.ravel().tolist())
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"h{k}", density=1000.0, condim=4)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 1500)
    rot = data.xmat[1].reshape(3, 3)
    yaw = math.atan2(rot[1, 0], rot[0, 0])
    return rot_z(-yaw) @ rot


def rim_wall(mesh: trimesh.Trimesh, axis: int, z: float) -> float:
    """Horizontal thickness of the outermost wall along ``axis`` (0: x, 1: y) at height ``z`` [m]."""
    normal = [0.0, 1.0, 0.0] if axis == 0 else [1.0, 0.0, 0.0]
    seg = np.asarray(trimesh.intersections.mesh_plane(mesh, normal, [0.0, 0.0, 0.0]))
    a, b = seg[:, 0], seg[:, 1]
    cross = (a[:, 2] - z) * (b[:, 2] - z) <= 0
    a, b = a[cross], b[cross]
    t = (z - a[:, 2]) / np.where(np.abs(b[:, 2] - a[:, 2]) > 1e-12, b[:, 2] - a[:, 2], 1.0)
    pos = np.sort((a + (b - a) * t[:, None])[:, axis])
    pos = pos[pos > 0]
    return float(pos[-1] - pos[-2]) if len(pos) >= 2 else 0.004


def ray_down(mesh: trimesh.Trimesh, xy: np.ndarray) -> np.ndarray:
    """Height of the highest surface above each (x, y) (a vertical ray from above); -1 for a miss."""
    tri = mesh.triangles  # (m, 3, 3)
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    out = np.full(len(xy), -1.0)
    for i, (px, py) in enumerate(xy):
        v0 = b[:, :2] - a[:, :2]
        v1 = c[:, :2] - a[:, :2]
        v2 = np.array([px, py]) - a[:, :2]
        den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
        ok = np.abs(den) > 1e-14
        den = np.where(ok, den, 1.0)
        u = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
        w = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
        hit = ok & (u >= -1e-9) & (w >= -1e-9) & (u + w <= 1 + 1e-9)
        if hit.any():
            z = a[hit, 2] + u[hit] * (b[hit, 2] - a[hit, 2]) + w[hit] * (c[hit, 2] - a[hit, 2])
            out[i] = float(z.max())
    return out


def interior_radius(mesh: trimesh.Trimesh, floor_z: float, depth: float, r_max: float) -> float:
    """Radius of the hollow around the axis that reaches below half the depth [m].

    Measured outwards from the axis (on the back half, away from a handle) and stopped at the first
    radius whose surface is higher: a foot or ledge outside the wall is not part of the opening.
    """
    rs = np.linspace(0.0, r_max, 400)
    prof = ray_down(mesh, np.column_stack([-rs, np.zeros_like(rs)]))
    deep = (prof >= 0) & (prof < floor_z + 0.5 * depth)
    k = len(rs) if deep.all() else int(np.argmin(deep))
    return float(rs[k - 1]) if k else 0.0


def hull_free_radius(hulls: list[np.ndarray], centre: Sequence[float], z_lo: float, z_hi: float,
                     r_max: float) -> float:
    """Radius of the widest upright cylinder about ``centre`` from ``z_lo`` to ``z_hi`` that no hull
    reaches into, grown outwards from the axis in 0.25 mm steps [m] (V-HACD's pieces are not
    round: every direction counts)."""
    a = np.linspace(0.0, 2.0 * math.pi, 72, endpoint=False)
    ring = np.column_stack([np.cos(a), np.sin(a)])
    zs = np.linspace(z_lo, z_hi, 8)
    planes = [ConvexHull(h).equations for h in hulls]
    free = 0.0
    for r in np.arange(0.00025, r_max, 0.00025):
        xy = np.asarray(centre) + r * ring
        pts = np.column_stack([np.tile(xy, (len(zs), 1)), np.repeat(zs, len(a))])
        if any(np.all(pts @ eq[:, :3].T + eq[:, 3] < -1e-4, axis=1).any() for eq in planes):
            break
        free = float(r)
    return free


def revolved_facts(cls: str, mesh: trimesh.Trimesh, hulls: list[np.ndarray]) -> dict:
    v = mesh.vertices
    back = v[v[:, 0] <= 0.002]  # the back half: no handle
    H = float(back[:, 2].max())  # the body's height (a pan's handle may rise above it)
    rad = np.hypot(back[:, 0], back[:, 1])

    def r_out(z: float, tol: float = 0.004) -> float:
        sel = np.abs(back[:, 2] - z) < tol
        return float(rad[sel].max()) if sel.any() else float(rad.max())

    rs = np.linspace(0.0, r_out(H, 0.006), 40)
    prof = ray_down(mesh, np.column_stack([-rs, np.zeros_like(rs)]))
    centre_z = float(prof[0])
    hollow = centre_z < H - max(0.006, 0.15 * H) and cls not in ("soda_can", "thermos", "food_box")
    grasps = []
    out: dict = {}
    if hollow:
        floor_z = centre_z
        floor = rs[(prof < floor_z + 0.003) & (prof >= 0)]
        r_floor = float(floor.max()) if len(floor) else 0.0
        depth = H - floor_z
        # The narrower of the visual wall and the collision hulls (V-HACD pieces bulge a few mm inwards):
        # what passes the opening must pass both.
        r_max = float(np.hypot(v[:, 0], v[:, 1]).max())
        r_open = min(interior_radius(mesh, floor_z, depth, r_max),
                     hull_free_radius(hulls, (0.0, 0.0), floor_z + 0.5 * depth, H, r_max)) or r_floor
        rim_band = back[back[:, 2] > H - 0.003]
        rr = np.hypot(rim_band[:, 0], rim_band[:, 1])
        rim_out = float(rr.max())
        below_rim = (prof < H - 0.004) & (prof >= 0)
        rim_in = float(rs[below_rim].max()) if below_rim.any() else rim_out - 0.004
        rim_in = min(rim_in, rim_out - 0.002)
        out["opening"] = {"radius": r_open, "floor_height": floor_z, "depth": depth, "center": [0.0, 0.0]}
        out["top"] = {"height": floor_z, "center": [0.0, 0.0], "half_extents": [r_floor, r_floor], "round": True,
                      "flat": r_floor >= 0.01}
        z_rim = H - min(0.015, 0.3 * depth)
        wall = max(r_out(z_rim) - rim_in, 0.003)
        rim = {"name": "rim", "position": [0.5 * (rim_out + rim_in), 0.0, z_rim], "approach": [0, 0, -1],
               "closing": [1, 0, 0], "width": wall, "axisymmetric": True}
        body_w = 2 * rim_out
        body = {"name": "body", "position": [0.0, 0.0, 0.6 * H], "approach": [-1, 0, 0], "closing": [0, 1, 0],
                "width": body_w, "axisymmetric": True}
        grasps += [body, rim] if body_w <= STROKE else [rim, body]
    else:
        r_top = r_out(H)
        out["opening"] = None
        out["top"] = {"height": H, "center": [0.0, 0.0], "half_extents": [r_top, r_top], "round": True,
                      "flat": r_top >= 0.01}
        z_grip = max(0.5 * H, H - 0.03)
        grasps.append({"name": "body", "position": [0.0, 0.0, z_grip], "approach": [0, 0, -1], "closing": [0, 1, 0],
                       "width": 2 * r_out(z_grip), "axisymmetric": True})
    if cls in ("mug", "pan"):
        r_body = float(rad.max())
        hv = v[v[:, 0] > r_body + 0.004]
        if len(hv):
            xmax = float(hv[:, 0].max())
            if cls == "mug":
                outer = hv[hv[:, 0] > xmax - 0.35 * (xmax - r_body)]
                zc = float((outer[:, 2].max() + outer[:, 2].min()) / 2)
                sel = outer[np.abs(outer[:, 2] - zc) < 0.012]
                x = float((sel[:, 0].max() + sel[:, 0].min()) / 2)
                w = float(sel[:, 1].max() - sel[:, 1].min())
            else:
                x = r_body + 0.65 * (xmax - r_body)
                sel = slice_x(mesh, x)
                zc = float((sel[:, 2].max() + sel[:, 2].min()) / 2)
                w = float(sel[:, 1].max() - sel[:, 1].min())
            grasps.insert(0, {"name": "handle", "position": [x, 0.0, zc], "approach": [0, 0, -1],
                              "closing": [0, 1, 0], "width": w, "axisymmetric": False})
    out["grasps"] = grasps
    return out


def slice_x(mesh: trimesh.Trimesh, x: float) -> np.ndarray:
    """Points where the surface crosses the plane at ``x`` (the mesh's cross-section outline)."""
    seg = trimesh.intersections.mesh_plane(mesh, [1.0, 0.0, 0.0], [x, 0.0, 0.0])
    return np.asarray(seg).reshape(-1, 3)


def flat_facts(kind: str, mesh: trimesh.Trimesh) -> dict:
    v = mesh.vertices
    lo, hi = v.min(0), v.max(0)
    sx, sy, sz = hi - lo
    out: dict = {"opening": None}
    if kind == "box":
        out["top"] = {"height": float(sz), "center": [0.0, 0.0], "half_extents": [float(sx / 2), float(sy / 2)],
                      "round": False, "flat": True}
        z = float(max(sz / 2, sz - 0.03))
        ay = {"name": "body", "position": [0.0, 0.0, z], "approach": [0, 0, -1], "closing": [0, 1, 0],
              "width": float(sy), "axisymmetric": False}
        ax = {"name": "body", "position": [0.0, 0.0, z], "approach": [0, 0, -1], "closing": [1, 0, 0],
              "width": float(sx), "axisymmetric": False}
        out["grasps"] = [ay, ax] if sy <= sx else [ax, ay]
    elif kind == "tray":
        rim_z = float(sz - min(0.004, sz / 3))
        rx, ry = rim_wall(mesh, 0, rim_z), rim_wall(mesh, 1, rim_z)
        gx, gy = np.meshgrid(np.linspace(-0.8, 0.8, 17) * hi[0], np.linspace(-0.8, 0.8, 17) * hi[1])
        grid = np.column_stack([gx.ravel(), gy.ravel()])
        h = ray_down(mesh, grid)
        floor = float(h[h >= 0].min())
        low = grid[(h >= 0) & (h < floor + 0.002)]
        if len(low) > 0.8 * len(grid):  # one flat floor
            centre = np.zeros(2)
            mid = 0.5 * (floor + float(sz))
            half = (0.85 * float(hi[0] - rim_wall(mesh, 0, mid)), 0.85 * float(hi[1] - rim_wall(mesh, 1, mid)))
        else:  # compartments: the one nearest the middle
            centre = low[int(np.argmin(np.hypot(low[:, 0], low[:, 1])))]
            half = (0.02, 0.02)
        out["top"] = {"height": floor, "center": centre.tolist(), "half_extents": list(half), "round": False,
                      "flat": True}
        out["opening"] = {"radius": min(half), "floor_height": floor, "depth": float(sz - floor),
                          "center": centre.tolist()}
        out["grasps"] = [
            {"name": "rim", "position": [float(hi[0] - rx / 2), 0.0, rim_z], "approach": [0, 0, -1],
             "closing": [1, 0, 0], "width": max(rx, 0.003), "axisymmetric": False},
            {"name": "rim", "position": [0.0, float(hi[1] - ry / 2), rim_z], "approach": [0, 0, -1],
             "closing": [0, 1, 0], "width": max(ry, 0.003), "axisymmetric": False},
        ]
    elif kind == "board":
        out["top"] = {"height": float(sz), "center": [0.0, 0.0],
                      "half_extents": [float(sx / 2 - 0.01), float(sy / 2 - 0.01)], "round": False, "flat": True}
        grasps = []
        right = v[v[:, 0] > hi[0] - 0.25 * sx]
        if right[:, 1].max() - right[:, 1].min() < 0.6 * sy:  # a paddle: the narrow end is a handle
            x = float(hi[0] - 0.08 * sx)
            sel = slice_x(mesh, x)
            grasps.append({"name": "handle", "position": [x, 0.0, float(sz / 2)], "approach": [0, 0, -1],
                           "closing": [0, 1, 0], "width": float(sel[:, 1].max() - sel[:, 1].min()),
                           "axisymmetric": False})
        grasps.append({"name": "edge", "position": [float(lo[0]), 0.0, float(sz / 2)], "approach": [1, 0, 0],
                       "closing": [0, 0, 1], "width": float(sz), "axisymmetric": False})
        out["grasps"] = grasps
    else:  # cutlery and scissors: handle (rings) at -x
        L = sx
        if kind == "cutlery":
            x = float(lo[0] + 0.2 * L)
            sel = slice_x(mesh, x)
            w = float(sel[:, 1].max() - sel[:, 1].min())
            zc = float((sel[:, 2].max() + sel[:, 2].min()) / 2)
            yc = float((sel[:, 1].max() + sel[:, 1].min()) / 2)
            out["grasps"] = [{"name": "handle", "position": [x, yc, zc], "approach": [0, 0, -1],
                              "closing": [0, 1, 0], "width": w, "axisymmetric": False}]
            out["top"] = {"height": float(sel[:, 2].max()), "center": [x, yc], "half_extents": [0.02, w / 2],
                          "round": False, "flat": False}
        else:
            x = float(lo[0] + 0.55 * L)
            sel = slice_x(mesh, x)
            w = float(sel[:, 1].max() - sel[:, 1].min())
            xr = float(lo[0] + 0.15 * L)
            ring = slice_x(mesh, xr)
            out["grasps"] = [
                {"name": "body", "position": [x, float((sel[:, 1].max() + sel[:, 1].min()) / 2),
                                              float((sel[:, 2].max() + sel[:, 2].min()) / 2)],
                 "approach": [0, 0, -1], "closing": [0, 1, 0], "width": w, "axisymmetric": False},
                {"name": "handle", "position": [xr, 0.0, float(sz / 2)], "approach": [0, 0, -1],
                 "closing": [0, 1, 0], "width": float(ring[:, 1].max() - ring[:, 1].min()), "axisymmetric": False},
            ]
            out["top"] = {"height": float(sz), "center": [xr, 0.0], "half_extents": [0.02, 0.02], "round": False,
                          "flat": False}
    return out


def _git_show(repo: Path, path: str) -> bytes:
    git_dir = repo / ".git" if (repo / ".git").exists() else repo
    return subprocess.run(["git", f"--git-dir={git_dir}", "show", f"HEAD:{path}"], capture_output=True,
                          check=True).stdout


def _git_ls(repo: Path, under: str) -> list[str]:
    git_dir = repo / ".git" if (repo / ".git").exists() else repo
    out = subprocess.run(["git", f"--git-dir={git_dir}", "ls-tree", "-r", "--name-only", "HEAD", under],
                         capture_output=True, check=True, text=True).stdout
    return out.split()


def _load(data: bytes) -> trimesh.Trimesh:
    import io

    return trimesh.load(io.BytesIO(data), file_type="stl", force="mesh", process=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mubl", type=Path, help="a MuBlE checkout or its git directory")
    args = ap.parse_args()
    git_dir = args.mubl / ".git" if (args.mubl / ".git").exists() else args.mubl
    commit = subprocess.run(["git", f"--git-dir={git_dir}", "rev-parse", "HEAD"], capture_output=True, text=True,
                            check=True).stdout.strip()
    procedural = json.loads(PROCEDURAL.read_text())["classes"]
    OUT.mkdir(parents=True, exist_ok=True)
    classes: dict = {}
    provenance: list[str] = []
    for cls, (cls_kind, names) in CLASSES.items():
        src = procedural[cls]
        mass = dict(src["mass"])
        if cls in SHELL:
            mass["shell"] = SHELL[cls]
        entry = {"description": src["description"], "affordances": src["affordances"], "mass": mass,
                 "variants": {}, "menu": src["menu"]}
        for k, name in enumerate(names, 1):
            files = [f for f in _git_ls(args.mubl, f"meshes/train/{name}") if f.endswith(".stl")]
            visual_path = f"meshes/train/{name}/simple_mesh.stl"
            hull_paths = sorted((f for f in files if "_hull_" in f), key=lambda p: int(p.rsplit("_", 1)[1][:-4]))
            raw = _load(_git_show(args.mubl, visual_path))
            hulls = [np.asarray(_load(_git_show(args.mubl, p)).vertices, float) for p in hull_paths]
            kind = KIND.get(name, cls_kind)
            mesh = None if name in HULL_LOOK else repair(raw.copy())
            note = "repaired (closed)" if not raw.is_watertight else "closed as published"
            if mesh is None:
                mesh = hull_union(hulls)
                note = "replaced by the union of its hulls (could not be closed cleanly)"
            r = frame(kind, cls, np.asarray(mesh.vertices))
            s = SCALE.get(name, 1.0)
            v = np.asarray(mesh.vertices) @ r.T * s
            hulls = [h @ r.T * s for h in hulls]
            for _ in range(2):  # centre, put the pieces' lowest point on z = 0, let it settle, again
                c = body_axis(v) if kind == "revolved" else (v[:, :2].max(0) + v[:, :2].min(0)) / 2
                shift = np.array([-c[0], -c[1], -min(float(h[:, 2].min()) for h in hulls)])
                v = v + shift
                hulls = [h + shift for h in hulls]
                tilt = settle(hulls)
                if tilt[2, 2] < math.cos(math.radians(20)):  # fell over: MuBlE's pose is the right one
                    print(f"{name}: tips over when dropped ({math.degrees(math.acos(tilt[2, 2])):.0f} deg)")
                    break
                v, hulls = v @ tilt.T, [h @ tilt.T for h in hulls]
            c = body_axis(v) if kind == "revolved" else (v[:, :2].max(0) + v[:, :2].min(0)) / 2
            shift = np.array([-c[0], -c[1], -min(float(h[:, 2].min()) for h in hulls)])
            v = v + shift
            hulls = [h + shift for h in hulls]
            mesh = trimesh.Trimesh(v, mesh.faces, process=False)
            if not mesh.is_winding_consistent or mesh.volume < 0:
                trimesh.repair.fix_normals(mesh)
            # Many MuBlE meshes carry an inward-facing copy of themselves 1 mm inside (a hollow skin, as
            # left by a solidify step): drawn, a glass then has eight surfaces per wall and a path tracer
            # sees black. The look keeps the outer shells; the mass keeps the skin's volume.
            # An inward-facing shell that no outer one encloses is a body wound the wrong way: turned.
            parts = mesh.split(only_watertight=False)
            outer = [p for p in parts if p.volume >= 0]

            inner = [p for p in parts if p.volume < 0 and enclosed(p, outer)]
            turned = [trimesh.Trimesh(p.vertices, p.faces[:, ::-1], process=False)
                      for p in parts if p.volume < 0 and not enclosed(p, outer)]
            net_volume = float(sum(p.volume for p in outer) + sum(p.volume for p in turned)
                               + sum(p.volume for p in inner))
            if inner or turned:
                mesh = trimesh.util.concatenate(outer + turned)
                note += "".join([f"; {len(inner)} inward-facing inner shell(s) removed" if inner else "",
                                 f"; {len(turned)} inside-out part(s) turned" if turned else ""])
            facts = revolved_facts(cls, mesh, hulls) if kind == "revolved" else flat_facts(kind, mesh)
            variant = f"shopvrb{k}"
            fname = f"{cls}_{variant}.npz"
            np.savez_compressed(
                OUT / fname,
                vertices=np.asarray(mesh.vertices, np.float64),
                faces=np.asarray(mesh.faces, np.int32),
                piece_counts=np.array([len(h) for h in hulls], np.int64),
                piece_points=np.vstack(hulls),
            )
            digest = hashlib.sha256((OUT / fname).read_bytes()).hexdigest()
            if mass.get("contents_density"):  # cans and boxes are hollow shells: their contents fill the hulls
                facts["volume"] = float(hull_union(hulls).volume)
            elif inner:  # the material is the skin between the shells
                facts["volume"] = net_volume
            entry["variants"][variant] = {"geometry": {"kind": "mesh", "file": fname, "sha256": digest, **facts}}
            narrowest = min(g["width"] for g in facts["grasps"])
            sizes = [z for z in src["menu"]["size"] if narrowest * SIZES[z] <= GRIP_LIMIT]
            if sizes != src["menu"]["size"]:  # only the sizes the gripper can hold
                entry["variants"][variant]["menu"] = {"size": sizes}
            turn = "" if np.allclose(r, np.eye(3)) else f"; rotated {np.round(r, 3).tolist()}"
            provenance.append(
                f"| {fname} | {visual_path}, {len(hull_paths)} hulls | visual mesh {note}{turn}; "
                f"scaled {s:g}; {len(mesh.faces)} triangles |"
            )
        classes[cls] = entry
    (OUT / "classes.json").write_text(json.dumps({"format": 1, "classes": classes}, indent=1) + "\n")
    (OUT / "files.md").write_text(
        "# SHOP-VRB shapes: provenance\n\n"
        f"Source: https://github.com/michaal94/MuBlE at commit {commit}, MIT licence (LICENSE, beside this\n"
        "file). MuBlE packages the SHOP-VRB objects of SAMPLE-HD for MuJoCo; where single models came from is not\n"
        "documented, so only their geometry and V-HACD hulls are used, with samplehd's own materials and textures.\n\n"
        "Written by `scripts/vendor_shop_vrb.py`. Changes to every file: the visual mesh (`simple_mesh.stl`) and the\n"
        "hulls (`<name>_hull_*.stl`) of one object are stored together as plain arrays in one `.npz`, turned into\n"
        "samplehd's object frame (z up, collision pieces resting on z = 0 in the tilt it settles in, body axis\n"
        "or footprint centre at the origin, handles "
        "towards +x, cutlery handles and scissor rings towards -x) and scaled as listed; the visual mesh has its\n"
        "vertices merged and degenerate/duplicate faces dropped, and is closed where it was open.\n\n"
        "| file | from | what changed |\n|---|---|---|\n" + "\n".join(provenance) + "\n"
    )
    print(f"wrote {len(provenance)} variants to {OUT}")


if __name__ == "__main__":
    main()

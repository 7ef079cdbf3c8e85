"""Vendor the UR5e's visual meshes into ``samplehd/robot/data/ur5e`` (visual only; physics stays primitive).

Run once by a maintainer; the package itself only reads the files this writes. Needs trimesh and the
quadric decimation of ``fast-simplification`` (a build-time tool, not a dependency of samplehd, e.g.
``pip install --target /tmp/meshtools fast-simplification`` and ``PYTHONPATH=/tmp/meshtools``).

Source: the robosuite 1.5.2 wheel (MIT), whose ``models/assets/robots/ur5e`` holds Universal Robots'
UR5e visual meshes split per material (``obj_meshes/<link>_vis/<link>_vis_<k>.obj``), the same split as
MuJoCo Menagerie's ``universal_robots_ur5e/assets/<link>_<k>.obj`` (BSD-3-Clause, ROS-Industrial's
``ur_description``), and ``robot.xml``, which places them on its link frames and names their materials.

For every link it:

1. finds the fixed transform from robosuite's link frame to samplehd's DH body ``robot_<link>``: both
   chains are posed at zero joint angles (robosuite's base frame is the URDF ``base_link``, turned by π
   about z from DH frame 0) and compared; the rotation is a signed axis permutation, the offset is kept
   along the joint axis and zeroed across it, so the mesh turns about exactly our joint axis (robosuite's
   rounded link lengths differ from the DH ones by at most 0.6 mm);
2. merges each part's duplicated vertices, decimates it with quadric error metrics to the fewest triangles
   that keep 99 % of its vertices within ``--tolerance`` of the decimated surface (bisection), moves it
   into the DH body frame and stores it as float32 vertices [m] and uint16 faces in ``<link>.npz``
   (``vertices_<k>``, ``faces_<k>``);
3. writes ``look.json`` (materials and which material each part has, from ``robot.xml``), ``files.md``
   (provenance) and the two licences beside them.

Usage::

    PYTHONPATH=/tmp/meshtools:src python scripts/vendor_ur5e.py robosuite-1.5.2-py3-none-any.whl --tolerance 1.5
"""

from __future__ import annotations

import argparse
import hashlib
import io
import json
import math
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import fast_simplification
import mujoco
import numpy as np
import trimesh
from scipy.spatial import cKDTree

from samplehd.robot.constants import JOINT_NAMES, LINK_NAMES, ROBOT_BODY
from samplehd.robot.ur5e import robot_spec

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "src" / "samplehd" / "robot" / "data" / "ur5e"
ASSETS = "robosuite/models/assets/robots/ur5e/"
LICENCE = "robosuite-1.5.2.dist-info/licenses/LICENSE"
# samplehd body -> robosuite body, in chain order
BODIES = dict(zip((ROBOT_BODY, *LINK_NAMES), ("fixed_base_link", "shoulder_link", "upper_arm_link", "forearm_link",
                                              "wrist_1_link", "wrist_2_link", "wrist_3_link"), strict=True))
MIN_FACES = 120
# Menagerie's universal_robots_ur5e/LICENSE, the licence of the meshes' origin (ROS-Industrial ur_description).
BSD3 = """Copyright 2018 ROS Industrial Consortium

Redistribution and use in source and binary forms, with or without modification,
are permitted provided that the following conditions are met:

1. Redistributions of source code must retain the above copyright notice, this
list of conditions and the following disclaimer.

2. Redistributions in binary form must reproduce the above copyright notice,
this list of conditions and the following disclaimer in the documentation and/or
other materials provided with the distribution.

3. Neither the name of the copyright holder nor the names of its contributors
may be used to endorse or promote products derived from this software without
specific prior written permission.

THIS SOFTWARE IS PROVIDED BY THE COPYRIGHT HOLDERS AND CONTRIBUTORS "AS IS" AND
ANY EXPRESS OR IMPLIED WARRANTIES, INCLUDING, BUT NOT LIMITED TO, THE IMPLIED
WARRANTIES OF MERCHANTABILITY AND FITNESS FOR A PARTICULAR PURPOSE ARE
DISCLAIMED. IN NO EVENT SHALL THE COPYRIGHT HOLDER OR CONTRIBUTORS BE LIABLE FOR
ANY DIRECT, INDIRECT, INCIDENTAL, SPECIAL, EXEMPLARY, OR CONSEQUENTIAL DAMAGES
(INCLUDING, BUT NOT LIMITED TO, PROCUREMENT OF SUBSTITUTE GOODS OR SERVICES;
LOSS OF USE, DATA, OR PROFITS; OR BUSINESS INTERRUPTION) HOWEVER CAUSED AND ON
ANY THEORY OF LIABILITY, WHETHER IN CONTRACT, STRICT LIABILITY, OR TORT
(INCLUDING NEGLIGENCE OR OTHERWISE) ARISING IN ANY WAY OUT OF THE USE OF THIS
SOFTWARE, EVEN IF ADVISED OF THE POSSIBILITY OF SUCH DAMAGE.
"""


def _pose(data: mujoco.MjData, model: mujoco.MjModel, body: str) -> np.ndarray:
    t = np.eye(4)
    b = model.body(body).id
    t[:3, :3] = data.xmat[b].reshape(3, 3)
    t[:3, 3] = data.xpos[b]
    return t


def robosuite_chain(xml: str) -> tuple[mujoco.MjModel, dict[str, list[tuple[str, str]]], dict[str, dict]]:
    """robosuite's kinematic chain without its meshes; per body its visual parts (mesh file, material);
    the materials."""
    root = ET.fromstring(xml)
    files = {m.get("name"): m.get("file") for m in root.iter("mesh")}
    materials = {m.get("name"): {"rgba": [float(v) for v in m.get("rgba").split()],
                                 "specular": float(m.get("specular")), "shininess": float(m.get("shininess"))}
                 for m in root.iter("material")}
    parts: dict[str, list[tuple[str, str]]] = {}
    for body in root.iter("body"):
        for geom in list(body.findall("geom")):
            if geom.get("mesh") is not None:
                if geom.get("group") == "1":
                    parts.setdefault(body.get("name"), []).append((files[geom.get("mesh")], geom.get("material")))
                body.remove(geom)
    asset = root.find("asset")
    for mesh in list(asset.findall("mesh")):
        asset.remove(mesh)
    return mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode")), parts, materials


def link_transforms(rs: mujoco.MjModel) -> dict[str, np.ndarray]:
    """Per samplehd body, the 4x4 pose of robosuite's link frame in it (both arms at zero joint angles)."""
    ours = robot_spec().compile()
    d_ours, d_rs = mujoco.MjData(ours), mujoco.MjData(rs)
    mujoco.mj_kinematics(ours, d_ours)
    mujoco.mj_kinematics(rs, d_rs)
    turn = np.diag([-1.0, -1.0, 1.0, 1.0])  # URDF base_link -> DH base frame: Rz(pi)
    base_ours = np.linalg.inv(_pose(d_ours, ours, ROBOT_BODY))
    base_rs = turn @ np.linalg.inv(_pose(d_rs, rs, BODIES[ROBOT_BODY]))
    out = {}
    for mine, theirs in BODIES.items():
        t = np.linalg.inv(base_ours @ _pose(d_ours, ours, mine)) @ base_rs @ _pose(d_rs, rs, theirs)
        rot = np.round(t[:3, :3])
        assert np.allclose(rot, t[:3, :3], atol=1e-6) and abs(np.linalg.det(rot) - 1) < 1e-9, (mine, t)
        fixed = np.eye(4)
        fixed[:3, :3] = rot
        fixed[2, 3] = round(float(t[2, 3]), 6)  # along the joint axis; across it zero (the axes coincide)
        assert np.abs(t[:2, 3]).max() < 1e-3, (mine, t)
        out[mine] = fixed
    return out


def check_joint_angles(rs: mujoco.MjModel, transforms: dict[str, np.ndarray], trials: int = 20) -> float:
    """Largest distance [m] between robosuite's link frames (through ``transforms``) and ours at random
    equal joint angles: the same joint zero and direction, so equal angles give the same arm."""
    ours = robot_spec().compile()
    d_ours, d_rs = mujoco.MjData(ours), mujoco.MjData(rs)
    rng = np.random.default_rng(0)
    worst = 0.0
    for _ in range(trials):
        q = rng.uniform(-math.pi, math.pi, len(JOINT_NAMES))
        for j, name in enumerate(JOINT_NAMES):
            d_ours.qpos[ours.joint(name).qposadr[0]] = q[j]
            d_rs.qpos[rs.joint(name).qposadr[0]] = q[j]
        mujoco.mj_kinematics(ours, d_ours)
        mujoco.mj_kinematics(rs, d_rs)
        base_rs = np.diag([-1.0, -1.0, 1.0, 1.0]) @ np.linalg.inv(_pose(d_rs, rs, BODIES[ROBOT_BODY]))
        for mine, theirs in BODIES.items():
            placed = _pose(d_ours, ours, mine) @ transforms[mine]
            real = base_rs @ _pose(d_rs, rs, theirs)
            assert np.allclose(placed[:3, :3], real[:3, :3], atol=1e-9), mine
            worst = max(worst, float(np.linalg.norm(placed[:3, 3] - real[:3, 3])))
    return worst


def _closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Distance from each point p[i] to the triangle (a[i], b[i], c[i]) (Ericson, Real-Time Collision
    Detection, 5.1.5: the closest point lies in one of the triangle's vertex, edge or face regions)."""
    ab, ac = b - a, c - a
    dot = lambda u, v: np.einsum("ij,ij->i", u, v)  # noqa: E731
    d1, d2 = dot(ab, p - a), dot(ac, p - a)
    d3, d4 = dot(ab, p - b), dot(ac, p - b)
    d5, d6 = dot(ab, p - c), dot(ac, p - c)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    safe = lambda x: np.where(np.abs(x) < 1e-30, 1e-30, x)  # noqa: E731
    denom = safe(va + vb + vc)
    q = a + ab * (vb / denom)[:, None] + ac * (vc / denom)[:, None]
    # Later regions override earlier ones, so the vertex regions come last.
    edges = (
        ((va <= 0) & (d4 >= d3) & (d5 >= d6), b, c - b, (d4 - d3) / safe(d4 - d3 + d5 - d6)),
        ((vb <= 0) & (d2 >= 0) & (d6 <= 0), a, ac, d2 / safe(d2 - d6)),
        ((vc <= 0) & (d1 >= 0) & (d3 <= 0), a, ab, d1 / safe(d1 - d3)),
    )
    for mask, start, along, t in edges:
        q[mask] = (start + along * t[:, None])[mask]
    for mask, corner in (((d6 >= 0) & (d5 <= d6), c), ((d3 >= 0) & (d4 <= d3), b), ((d1 <= 0) & (d2 <= 0), a)):
        q[mask] = corner[mask]
    return np.linalg.norm(p - q, axis=1)


def deviation(points: np.ndarray, verts: np.ndarray, faces: np.ndarray, k: int = 24) -> np.ndarray:
    """Distance [m] from each point to the mesh (verts, faces), over the k triangles with the nearest centroids
    (an upper bound where a long triangle's centroid lies far from the point)."""
    tri = verts[faces]
    _, idx = cKDTree(tri.mean(axis=1)).query(points, k=min(k, len(faces)))
    idx = idx.reshape(len(points), -1)
    best = np.full(len(points), np.inf)
    for j in range(idx.shape[1]):
        t = tri[idx[:, j]]
        best = np.minimum(best, _closest_on_triangles(points, t[:, 0], t[:, 1], t[:, 2]))
    return best


def decimate(mesh: trimesh.Trimesh, tolerance: float) -> trimesh.Trimesh:
    """The fewest triangles (found by bisection, to 3 %) whose quadric decimation keeps 99 % of the part's
    vertices within ``tolerance`` [m] of the decimated surface."""
    mesh.merge_vertices(digits_vertex=6)
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.remove_unreferenced_vertices()
    lo, hi = MIN_FACES, len(mesh.faces)
    best = (mesh.vertices, mesh.faces)
    while hi - lo > max(20, 0.03 * hi):
        mid = (lo + hi) // 2
        verts, faces = fast_simplification.simplify(mesh.vertices, mesh.faces, target_count=mid)
        if np.percentile(deviation(mesh.vertices, verts, faces), 99.0) <= tolerance:
            hi, best = mid, (verts, faces)
        else:
            lo = mid
    out = trimesh.Trimesh(*best, process=False)
    out.update_faces(out.nondegenerate_faces())
    out.remove_unreferenced_vertices()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("wheel", type=Path, help="robosuite-1.5.2-py3-none-any.whl")
    ap.add_argument("--tolerance", type=float, default=1.5, help="largest deviation of the decimated parts [mm] "
                    "(at 99 %% of the original vertices)")
    args = ap.parse_args()
    wheel = zipfile.ZipFile(args.wheel)
    xml_bytes = wheel.read(ASSETS + "robot.xml")
    rs, parts, materials = robosuite_chain(xml_bytes.decode())
    transforms = link_transforms(rs)
    drift = check_joint_angles(rs, transforms)
    OUT.mkdir(parents=True, exist_ok=True)
    look: dict = {"materials": {}, "links": {}}
    rows = []
    used = sorted({m for body in parts.values() for _, m in body})
    for name in used:
        look["materials"][name.lower()] = materials[name]
    total_in = total_out = 0
    for mine, theirs in BODIES.items():
        arrays: dict[str, np.ndarray] = {}
        link_parts = []
        t = transforms[mine]
        for k, (file, material) in enumerate(parts[theirs]):
            raw = wheel.read(ASSETS + file)
            mesh = trimesh.load(io.BytesIO(raw), file_type="obj", force="mesh", process=False)
            n_in = len(mesh.faces)
            mesh = decimate(mesh, args.tolerance / 1000)
            verts = mesh.vertices @ t[:3, :3].T + t[:3, 3]
            assert len(verts) < 65536
            arrays[f"vertices_{k}"] = verts.astype(np.float32)
            arrays[f"faces_{k}"] = mesh.faces.astype(np.uint16)
            link_parts.append(material.lower())
            total_in += n_in
            total_out += len(mesh.faces)
            rows.append(f"| {mine.removeprefix('robot_')}.npz | {ASSETS}{file} (sha256 "
                        f"{hashlib.sha256(raw).hexdigest()[:16]}…) | part {k}, {material.lower()}: {n_in} → "
                        f"{len(mesh.faces)} triangles |")
        look["links"][mine] = link_parts
        np.savez_compressed(OUT / f"{mine.removeprefix('robot_')}.npz", **arrays)
        pose = ", ".join(f"{v:g}" for v in t[:3, 3])
        rows.append(f"| | frame | robosuite `{theirs}` in samplehd `{mine}`: rotation "
                    f"{t[:3, :3].astype(int).tolist()}, offset ({pose}) m |")
    (OUT / "look.json").write_text(json.dumps(look, indent=1) + "\n")
    (OUT / "LICENSE").write_text(BSD3)
    (OUT / "LICENSE.robosuite").write_text(wheel.read(LICENCE).decode())
    (OUT / "files.md").write_text(_provenance(args, xml_bytes, rows, total_in, total_out, drift))
    print(f"{total_in} -> {total_out} triangles; frames within {drift * 1000:.2f} mm of robosuite's chain")


def _provenance(args: argparse.Namespace, xml: bytes, rows: list[str], n_in: int, n_out: int, drift: float) -> str:
    return f"""# UR5e visual meshes: provenance

Universal Robots' UR5e visual meshes, as split per material by MuJoCo Menagerie
(`universal_robots_ur5e/assets/<link>_<k>.obj`, BSD-3-Clause, from ROS-Industrial's `ur_description`:
LICENSE, beside this file), taken from the robosuite 1.5.2 wheel (`{args.wheel.name}`, MIT licence:
LICENSE.robosuite), which carries the same parts as `{ASSETS}obj_meshes/`. Materials (`look.json`) are
robosuite's `robot.xml` ones (sha256 {hashlib.sha256(xml).hexdigest()[:16]}…), the same colours as Menagerie's.

Written by `scripts/vendor_ur5e.py --tolerance {args.tolerance:g}`. Changes to every part: duplicated vertices
merged, quadric-decimated (fast-simplification) to the fewest triangles that keep 99 % of its vertices within
{args.tolerance:g} mm of the decimated surface, {n_in} → {n_out} triangles in all;
units metres (as published); moved from robosuite's link frame into samplehd's DH body frame by the fixed
transform listed under each link (robosuite's base frame is the URDF `base_link`, turned by π about z from
DH frame 0; rotations are axis permutations, offsets lie along the joint axis). At random joint angles the
placed link frames are within {drift * 1000:.2f} mm of robosuite's own chain (its link lengths are rounded
to the millimetre; samplehd's are the DH ones). Stored as float32 vertices and uint16 faces
(`vertices_<k>`, `faces_<k>`); part k has material `look.json["links"][body][k]`.

The meshes are drawn only: samplehd's collision geoms, masses and inertias stay those of the primitive arm.

| file | from | what changed |
|---|---|---|
""" + "\n".join(rows) + "\n"


if __name__ == "__main__":
    main()

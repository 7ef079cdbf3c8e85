"""The UR5e's vendored visual meshes (``data/ur5e``), drawn by the ``mesh`` look of the arm.

``data/ur5e/<link>.npz`` holds per material part ``k`` of one link ``vertices_<k>`` (n, 3) float32 [m],
already in samplehd's DH body frame ``robot_<link>``, and ``faces_<k>`` (m, 3) uint16;
``data/ur5e/look.json`` names each part's material and gives the materials' colours. Provenance and
licences are beside them (``files.md``, ``LICENSE``, ``LICENSE.robosuite``); ``scripts/vendor_ur5e.py``
wrote them. Reading needs numpy only.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from samplehd.errors import AssetError

__all__ = ["DATA_DIR", "ArmMeshes", "MeshMaterial", "MeshPart", "arm_meshes"]

DATA_DIR = Path(__file__).parent / "data" / "ur5e"


@dataclass(frozen=True)
class MeshMaterial:
    """A material of the meshes: ``rgba`` colour, ``specular`` and ``shininess`` (MuJoCo's meanings)."""

    rgba: tuple[float, float, float, float]
    specular: float
    shininess: float


@dataclass(frozen=True)
class MeshPart:
    """One material part of a link's mesh, in the link's DH body frame."""

    vertices: np.ndarray  # (n, 3) float32 [m]
    faces: np.ndarray  # (m, 3) int32
    material: str


@dataclass(frozen=True)
class ArmMeshes:
    """The meshes of every arm body (``robot_base`` … ``robot_wrist_3_link``) and their materials."""

    parts: dict[str, tuple[MeshPart, ...]]
    materials: dict[str, MeshMaterial]


@functools.cache
def arm_meshes() -> ArmMeshes:
    """Read the vendored meshes once per process.

    Raises:
        AssetError: a file is missing or malformed (a broken installation).
    """
    try:
        look = json.loads((DATA_DIR / "look.json").read_text())
        materials = {name: MeshMaterial(tuple(float(v) for v in m["rgba"]), float(m["specular"]),  # type: ignore[arg-type]
                                        float(m["shininess"])) for name, m in look["materials"].items()}
        parts: dict[str, tuple[MeshPart, ...]] = {}
        for body, names in look["links"].items():
            with np.load(DATA_DIR / f"{body.removeprefix('robot_')}.npz", allow_pickle=False) as z:
                parts[body] = tuple(MeshPart(z[f"vertices_{k}"], z[f"faces_{k}"].astype(np.int32), name)
                                    for k, name in enumerate(names))
    except (OSError, KeyError, ValueError, TypeError) as exc:
        raise AssetError(f"cannot read the UR5e meshes in {DATA_DIR}: {exc}; reinstall samplehd") from exc
    unknown = {p.material for ps in parts.values() for p in ps} - set(materials)
    if unknown:
        raise AssetError(f"{DATA_DIR / 'look.json'}: parts name unknown materials {sorted(unknown)}")
    return ArmMeshes(parts, materials)

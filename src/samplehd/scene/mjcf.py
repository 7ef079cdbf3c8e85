"""Export a world as an MJCF file that MuJoCo's own viewer (``python -m mujoco.viewer``) opens."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
from PIL import Image

from samplehd.errors import ConfigError

__all__ = ["export_mjcf"]


def _write_msh(mesh: mujoco.MjsMesh, path: Path) -> None:
    """Write a mesh given by arrays as MuJoCo's binary ``.msh``: counts of vertices, normals, texture
    coordinates and faces (int32), then the float32 vertices, normals, texture coordinates and the int32
    faces."""
    arrays = [np.asarray(mesh.uservert, np.float32), np.asarray(mesh.usernormal, np.float32),
              np.asarray(mesh.usertexcoord, np.float32), np.asarray(mesh.userface, np.int32)]
    counts = np.array([len(arrays[0]) // 3, len(arrays[1]) // 3, len(arrays[2]) // 2, len(arrays[3]) // 3],
                      np.int32)
    path.write_bytes(b"".join(a.tobytes() for a in (counts, *arrays)))


def export_mjcf(spec: mujoco.MjSpec, path: str | Path) -> Path:
    """Write `spec` as MJCF to `path`; textures and meshes made from arrays go to files in
    ``<stem>_assets/`` (PNGs, MuJoCo's binary ``.msh``), so the XML stays small.

    Returns:
        The path of the XML file.
    """
    out = Path(path)
    if out.suffix.lower() != ".xml":
        raise ConfigError(f"out={out}: the MJCF file must end in .xml", field="out")
    spec = spec.copy()
    asset_dir = out.parent / f"{out.stem}_assets"
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        for tex in spec.textures:
            if not tex.data:
                continue
            asset_dir.mkdir(exist_ok=True)
            img = np.frombuffer(tex.data, dtype=np.uint8).reshape(tex.height, tex.width, tex.nchannel)
            png = asset_dir / f"{tex.name}.png"
            Image.fromarray(img).save(png)
            tex.data = b""
            tex.file = str(png.relative_to(out.parent))
            tex.width = tex.height = 0
            tex.nchannel = 3
        # Meshes of an attached spec (the robot's) resolve files against that spec's directory, so they
        # are named by absolute paths here and made relative in the written XML.
        absolute = asset_dir.resolve()
        held = spec.assets  # in-memory mesh files (the robot's): written beside the XML
        for mesh in spec.meshes:
            if mesh.file in held:
                asset_dir.mkdir(exist_ok=True)
                (absolute / mesh.file).write_bytes(held[mesh.file])
                mesh.file = str(absolute / mesh.file)
                continue
            if not len(mesh.uservert) or len(mesh.userfacenormal) or len(mesh.userfacetexcoord):
                continue  # a file already, or per-face data that .msh cannot hold: stays inline
            asset_dir.mkdir(exist_ok=True)
            msh = absolute / f"{mesh.name}.msh"
            _write_msh(mesh, msh)
            mesh.uservert, mesh.userface, mesh.usernormal, mesh.usertexcoord = [], [], [], []
            mesh.file = str(msh)
        spec.modelfiledir = str(out.parent.resolve())
        spec.compile()  # resolves assets so the XML is complete
        out.write_text(spec.to_xml().replace(f'file="{absolute}/', f'file="{asset_dir.name}/'))
    except OSError as exc:
        raise ConfigError(f"cannot write {out}: {exc.strerror or exc}") from exc
    return out

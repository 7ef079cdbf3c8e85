"""Export a world as an MJCF file that MuJoCo's own viewer (``python -m mujoco.viewer``) opens."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
from PIL import Image

from samplehd.errors import ConfigError

__all__ = ["export_mjcf"]


def export_mjcf(spec: mujoco.MjSpec, path: str | Path) -> Path:
    """Write `spec` as MJCF to `path`; textures made from arrays go to PNGs in ``<stem>_assets/``.

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
        spec.modelfiledir = str(out.parent.resolve())
        spec.compile()  # resolves assets so the XML is complete
        out.write_text(spec.to_xml())
    except OSError as exc:
        raise ConfigError(f"cannot write {out}: {exc.strerror or exc}") from exc
    return out

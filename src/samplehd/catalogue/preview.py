"""Preview images of catalogue objects, rendered offscreen with MuJoCo's classic renderer.

A small studio scene: a neutral floor, a key light with shadows, a fill light and a camera framed
on the objects' bounding box, rendered by :class:`samplehd.render.renderer.SceneRenderer`. Used
by ``samplehd assets preview`` and for the contact sheet in ``docs/images/catalogue.png``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import mujoco
import numpy as np
from PIL import Image, ImageDraw

from samplehd.catalogue.builder import add_object
from samplehd.catalogue.facts import object_facts
from samplehd.catalogue.instance import ObjectInstance
from samplehd.catalogue.loader import resolve_catalogue
from samplehd.catalogue.model import Catalogue
from samplehd.errors import RenderError
from samplehd.render.renderer import SceneRenderer

_FOVY = 45.0  # vertical field of view of the preview camera [deg]

__all__ = [
    "PREFERRED_COLOUR",
    "catalogue_table",
    "preview_spec",
    "render_instances",
    "write_catalogue_table",
]

# The colour a material is shown in on the catalogue table, when the class's menu allows it.
PREFERRED_COLOUR = {
    "ceramic": ("white", "blue", "red", "yellow"),
    "glass": ("transparent", "green", "blue"),
    "metal": ("metallic", "black", "red"),
    "plastic": ("red", "blue", "green", "yellow", "black"),
    "rubber": ("black", "red"),
    "wooden": ("brown", "yellow"),
}


def preview_spec(
    instances: Sequence[ObjectInstance],
    gap: float = 0.03,
    yaw: float = math.radians(70.0),
    catalogue: Catalogue | None = None,
) -> tuple[mujoco.MjSpec, np.ndarray, np.ndarray]:
    """Build a studio scene with the instances standing in a row along y.

    Args:
        instances: objects to show, left to right in the image.
        gap: free space between neighbouring objects [m].
        yaw: rotation of every object about z [rad] (70 deg shows handles in profile).
        catalogue: catalogue (default: :func:`load_catalogue`).

    Returns:
        The spec, and the lower and upper corners of the objects' joint bounding box [m].
    """
    cat = resolve_catalogue(catalogue, [i.class_name for i in instances], instances[0].variant if instances else None)
    spec = mujoco.MjSpec()
    spec.visual.headlight.ambient = [0.3, 0.3, 0.3]
    spec.visual.headlight.diffuse = [0.25, 0.25, 0.25]
    spec.visual.headlight.specular = [0.1, 0.1, 0.1]
    floor_tex = spec.add_texture(
        name="floor_grid",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        rgb1=[0.72, 0.72, 0.70],
        rgb2=[0.67, 0.67, 0.65],
        width=256,
        height=256,
    )
    floor_mat = spec.add_material(name="floor", texrepeat=[200, 200], reflectance=0.0)
    floor_mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = floor_tex.name
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[20, 20, 0.1], material="floor")
    facts = [object_facts(i, cat) for i in instances]
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s], [s, c]])
    footprints = [np.asarray(f.footprint_polygon) @ rot.T for f in facts]
    widths = [float(fp[:, 1].max() - fp[:, 1].min()) for fp in footprints]
    y = -0.5 * (sum(widths) + gap * (len(widths) - 1))
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    quat = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
    for k, (inst, f, fp) in enumerate(zip(instances, facts, footprints, strict=True)):
        cy = y - float(fp[:, 1].min())
        add_object(spec, inst, f"object_{k}", pos=(0.0, cy, 0.0), quat=quat, catalogue=cat)
        lo = np.minimum(lo, (float(fp[:, 0].min()), y, f.bbox_min[2]))
        hi = np.maximum(hi, (float(fp[:, 0].max()), y + widths[k], f.bbox_max[2]))
        y += widths[k] + gap
    size = float(np.max(hi - lo))
    spec.worldbody.add_light(
        name="key",
        pos=[1.5 * size + 0.5, -1.0 * size - 0.3, 3.0 * size + 1.0],
        dir=[-0.45, 0.3, -0.85],
        diffuse=[0.62, 0.62, 0.6],
        specular=[0.3, 0.3, 0.3],
        castshadow=True,
    )
    spec.worldbody.add_light(
        name="fill", pos=[-1.0, 1.0, 2.0], dir=[0.3, -0.3, -0.9], diffuse=[0.25, 0.25, 0.27], castshadow=False
    )
    return spec, lo, hi


def render_instances(
    instances: Sequence[ObjectInstance],
    width: int = 320,
    height: int = 240,
    *,
    azimuth: float = 180.0,
    elevation: float | None = None,
    catalogue: Catalogue | None = None,
    preset: str = "hd",
) -> np.ndarray:
    """Render objects standing in a row on a neutral floor.

    Args:
        instances: objects to show.
        width: image width [px].
        height: image height [px].
        azimuth: camera azimuth [deg] (MuJoCo convention; 180 looks along +x).
        elevation: camera elevation [deg] (negative looks down); default -30, or -55 for flat rows.
        catalogue: catalogue (default: :func:`load_catalogue`).
        preset: render preset of :class:`samplehd.render.renderer.SceneRenderer` (``fast``, ``hd``
            or ``photo``).

    Returns:
        (height, width, 3) uint8 RGB image.

    Raises:
        RenderError: the offscreen GL context cannot be created or the size is invalid.

    Rendering uses :class:`samplehd.render.renderer.SceneRenderer`, by default with its ``hd`` preset
    (shadows, 4x MSAA), so previews look like the dataset's images.
    """
    if not (16 <= width <= 1024 and 16 <= height <= 1024):
        raise RenderError(f"preview size {width}x{height} px is out of range; use 16..1024 per side")
    spec, lo, hi = preview_spec(instances, catalogue=catalogue)
    if elevation is None:
        flat = (hi[2] - lo[2]) <= 0.12 * max(hi[0] - lo[0], (hi[1] - lo[1]) / len(instances))
        elevation = -55.0 if flat else -32.0
    center = 0.5 * (lo + hi)
    # Fit the bounding box: each corner must lie inside the horizontal and vertical field of view.
    tan_y = math.tan(math.radians(_FOVY) / 2)
    tan_x = tan_y * width / height
    az, el = math.radians(azimuth), math.radians(elevation)
    forward = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    right = np.cross(forward, (0.0, 0.0, 1.0))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    rel = corners - center
    distance = 1.06 * max(
        float(np.max(np.abs(rel @ right) / tan_x - rel @ forward)),
        float(np.max(np.abs(rel @ up) / tan_y - rel @ forward)),
    )
    quat = np.zeros(4)
    # A MuJoCo camera looks along its -z axis with +y up.
    mujoco.mju_mat2Quat(quat, np.column_stack([right, up, -forward]).ravel())
    spec.worldbody.add_camera(name="preview", pos=list(center - distance * forward), quat=list(quat), fovy=_FOVY)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)

    with SceneRenderer(model, width, height, preset) as renderer:
        return renderer.render(data, "preview", ("rgb",))["rgb"]


def _colour_for(cat: Catalogue, pairs: Sequence[tuple[str, str]], material: str) -> str | None:
    allowed = [c for c, m in pairs if m == material]
    for c in PREFERRED_COLOUR.get(material, ()):
        if c in allowed:
            return c
    return allowed[0] if allowed else None


def catalogue_table(
    catalogue: Catalogue | None = None,
    cell: tuple[int, int] = (176, 132),
    classes: Sequence[str] | None = None,
) -> Image.Image:
    """Render every class (rows; all its variants side by side) in every material of its menu (columns).

    Args:
        catalogue: catalogue (default: :func:`load_catalogue`).
        cell: (width, height) of one picture [px].
        classes: classes to show (default: all).

    Returns:
        The sheet as a PIL image; cells of materials a class's menu does not allow are left blank.
    """
    cat = resolve_catalogue(catalogue, classes or ())
    names = list(classes) if classes is not None else list(cat.classes)
    materials = list(cat.materials)
    cw, ch = cell
    label_w, head_h = 110, 22
    sheet = Image.new("RGB", (label_w + cw * len(materials), head_h + ch * len(names)), (250, 250, 250))
    draw = ImageDraw.Draw(sheet)
    for j, mat in enumerate(materials):
        draw.text((label_w + j * cw + 6, 5), mat, fill=(0, 0, 0))
    for i, name in enumerate(names):
        cls = cat.object_class(name)
        y0 = head_h + i * ch
        draw.text((6, y0 + ch // 2 - 12), name, fill=(0, 0, 0))
        draw.text((6, y0 + ch // 2 + 2), ", ".join(cls.variants), fill=(90, 90, 90))
        for j, mat in enumerate(materials):
            instances = []
            for v in cls.variants.values():
                colour = _colour_for(cat, v.menu.pairs, mat)
                if colour is not None:
                    size = "medium" if "medium" in v.menu.size else v.menu.size[0]
                    instances.append(ObjectInstance(name, v.name, colour, mat, size))
            if not instances:
                continue
            img = render_instances(instances, cw, ch, catalogue=cat)
            sheet.paste(Image.fromarray(img), (label_w + j * cw, y0))
            draw.text((label_w + j * cw + 4, y0 + ch - 14), instances[0].colour, fill=(40, 40, 40))
    return sheet


def write_catalogue_table(path: str | Path, catalogue: Catalogue | None = None) -> Path:
    """Render :func:`catalogue_table` and save it as a PNG (full colour, about 0.4 MB); returns the path.

    A 256-colour palette would halve the file but maps the rare wood browns to greys.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    catalogue_table(catalogue).save(path, optimize=True)
    return path

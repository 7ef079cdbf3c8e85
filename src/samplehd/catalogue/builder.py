"""Add catalogue objects to a ``mujoco.MjSpec``: meshes, materials, a free body and its geoms.

Conventions:
    * The body frame is the object frame: the object rests on its local z = 0 plane, so a body at
      ``pos = (x, y, table_height)`` with an upright ``quat`` stands on the table.
    * Visual geom ``{name}_visual``: geom group 2 (``VISUAL_GROUP``), contype = conaffinity = 0,
      no mass, the material's look and the colour.
    * Collision geoms ``{name}_collision_{k}``: group 3 (``COLLISION_GROUP``, hidden by MuJoCo's
      default geom-group visibility), condim 4, friction from the material. Their density is set so
      that the body's mass equals :func:`samplehd.catalogue.facts.mass_of` (material density times
      modelled volume, see :class:`~samplehd.catalogue.model.MassModel`), with the inertia of the
      collision shapes.
    * Free joint ``{name}_joint``.
    * Assets are named by class/variant/size (meshes), material/colour (materials) and texture
      name, and added once per spec, so several instances share them.

Convex pieces rely on MuJoCo's multi-point convex collisions (multi-CCD, on by default in MuJoCo 4;
do not set ``mjDSBL_MULTICCD``) to rest stably on boxes and on each other.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache

import mujoco

from samplehd.catalogue.facts import mass_of
from samplehd.catalogue.geometry import ObjectGeometry, build_geometry
from samplehd.catalogue.instance import ObjectInstance
from samplehd.catalogue.loader import resolve_catalogue
from samplehd.catalogue.model import Catalogue, Colour, Material
from samplehd.catalogue.textures import TEXTURES
from samplehd.errors import AssetError
from samplehd.physics import msh_file

__all__ = [
    "COLLISION_CONDIM",
    "COLLISION_GROUP",
    "VISUAL_GROUP",
    "add_object",
    "material_rgba",
]

VISUAL_GROUP = 2
COLLISION_GROUP = 3
COLLISION_CONDIM = 4
_COLLISION_RGBA = (0.9, 0.4, 0.1, 0.5)  # only seen when group 3 is switched on for debugging


def add_object(
    spec: mujoco.MjSpec,
    instance: ObjectInstance,
    name: str,
    pos: Sequence[float] = (0.0, 0.0, 0.0),
    quat: Sequence[float] = (1.0, 0.0, 0.0, 0.0),
    *,
    parent: mujoco.MjsBody | None = None,
    catalogue: Catalogue | None = None,
) -> mujoco.MjsBody:
    """Add an object as a free body to ``spec``.

    Args:
        spec: model being built.
        instance: which object.
        name: body name (unique in the spec); geoms and the joint are prefixed with it.
        pos: body position, the point under the object's origin on its resting plane [m].
        quat: body orientation (w, x, y, z).
        parent: parent body (default: the world body). A free body must be a child of the world.
        catalogue: catalogue (default: :func:`samplehd.catalogue.load_catalogue`).

    Returns:
        The new body.

    Raises:
        AssetError: the instance is invalid or a body called ``name`` already exists.
    """
    cat = resolve_catalogue(catalogue, (instance.class_name,), instance.variant)
    instance.validate(cat)
    if spec.body(name) is not None:
        raise AssetError(f"add_object: a body named {name!r} already exists in the spec")
    cls = cat.object_class(instance.class_name)
    variant = cls.variant(instance.variant)
    material = cat.material(instance.material)
    colour = cat.colour(instance.colour)
    geometry = build_geometry(variant.geometry, cat.size(instance.size).scale)
    mesh_prefix = f"{instance.class_name}_{instance.variant}_{instance.size}"
    visual_mesh = _ensure_meshes(spec, mesh_prefix, geometry)
    mat_name = _ensure_material(spec, material, colour)

    body = (parent or spec.worldbody).add_body(name=name, pos=list(map(float, pos)), quat=list(map(float, quat)))
    body.add_freejoint(name=f"{name}_joint")
    body.add_geom(
        name=f"{name}_visual",
        type=mujoco.mjtGeom.mjGEOM_MESH,
        meshname=visual_mesh,
        material=mat_name,
        group=VISUAL_GROUP,
        contype=0,
        conaffinity=0,
        mass=0.0,
    )
    mass = mass_of(geometry, material, cls.mass)
    density = mass / geometry.pieces_volume
    for k, piece in enumerate(geometry.pieces):
        common = dict(
            name=f"{name}_collision_{k}",
            group=COLLISION_GROUP,
            condim=COLLISION_CONDIM,
            friction=list(material.friction),
            density=density,
            rgba=list(_COLLISION_RGBA),
        )
        if piece.kind == "box" and min(piece.half_extents) < _THIN:
            common["solref"] = list(_THIN_SOLREF)
        if piece.kind == "box":
            body.add_geom(
                type=mujoco.mjtGeom.mjGEOM_BOX,
                pos=list(piece.pos),
                quat=list(piece.quat),
                size=list(piece.half_extents),
                **common,
            )
        else:
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"{mesh_prefix}_collision_{k}", **common)
    return body


# Thin pieces (blades, tray floors: half thickness under 2 mm) get stiff contacts, a time constant of
# 5 ms (2.5 physics steps) with critical damping: with MuJoCo's default 20 ms a dropped knife sinks
# through a 3 mm tray floor. Only thin pieces: stiffer contacts everywhere cost 28 % more CPU per path.
_THIN = 0.002  # [m]
_THIN_SOLREF = (0.005, 1.0)


def material_rgba(material: Material, colour: Colour) -> tuple[float, float, float, float]:
    """RGBA of an object of this material and colour.

    Glass takes the lower of the two alphas; wood is tinted lighter because its texture carries the
    grain's own darkness.
    """
    r, g, b, a = colour.rgba
    if material.texture == "wood_grain":
        r, g, b = (0.4 + 0.6 * c for c in (r, g, b))
    return (r, g, b, min(a, material.alpha))


def _ensure_meshes(spec: mujoco.MjSpec, prefix: str, geometry: ObjectGeometry) -> str:
    visual = f"{prefix}_visual"
    if spec.mesh(visual) is not None:
        return visual
    (visual_file, pieces), files = _mesh_files(geometry)
    spec.assets = {**spec.assets, **files}
    spec.add_mesh(name=visual, file=visual_file, inertia=mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL)
    for k, piece_file in pieces:
        spec.add_mesh(name=f"{prefix}_collision_{k}", file=piece_file)
    return visual


# Each geometry's meshes as in-memory ``.msh`` files (:func:`samplehd.physics.msh_file`), which MuJoCo
# processes once per process (a piece's convex hull, the visual mesh's normals), not at every compile:
# every world of a scene (the sampler compiles each twice, an episode unit once more) adds the same
# meshes. Keyed by the geometry's identity (``build_geometry`` caches geometries); the entry keeps its
# geometry alive, so no id is reused.
_MeshFiles = tuple[tuple[str, list[tuple[int, str]]], dict[str, bytes]]
_MESH_FILES: dict[int, tuple[ObjectGeometry, _MeshFiles]] = {}
_MESH_FILES_MAX = 256


def _mesh_files(geometry: ObjectGeometry) -> _MeshFiles:
    """(the visual mesh's file name, (piece index, file name) of each mesh piece) and the files."""
    hit = _MESH_FILES.get(id(geometry))
    if hit is not None and hit[0] is geometry:
        return hit[1]
    visual, data = msh_file(geometry.vertices, geometry.faces, geometry.texcoords)
    files = {visual: data}
    pieces = []
    for k, p in enumerate(geometry.pieces):
        if p.kind == "mesh":
            name, data = msh_file(p.vertices)
            files[name] = data
            pieces.append((k, name))
    entry = ((visual, pieces), files)
    if len(_MESH_FILES) >= _MESH_FILES_MAX:
        _MESH_FILES.pop(next(iter(_MESH_FILES)))
    _MESH_FILES[id(geometry)] = (geometry, entry)
    return entry


def _ensure_material(spec: mujoco.MjSpec, material: Material, colour: Colour) -> str:
    name = f"{material.name}_{colour.name}"
    if spec.material(name) is not None:
        return name
    mat = spec.add_material(
        name=name,
        rgba=list(material_rgba(material, colour)),
        specular=material.specular,
        shininess=material.shininess,
        reflectance=material.reflectance,
    )
    if material.texture is not None:
        tex = _ensure_texture(spec, material.texture)
        mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = tex
    return name


def _ensure_texture(spec: mujoco.MjSpec, texture: str) -> str:
    if spec.texture(texture) is not None:
        return texture
    if texture not in TEXTURES:  # the loader only accepts known textures
        raise AssetError(f"unknown texture {texture!r}; valid textures are {', '.join(TEXTURES)}")
    width, height, pixels = _texture_pixels(texture)
    tex = spec.add_texture(name=texture, type=mujoco.mjtTexture.mjTEXTURE_2D, width=width, height=height, nchannel=3)
    tex.data = pixels
    return texture


@lru_cache(maxsize=len(TEXTURES))
def _texture_pixels(texture: str) -> tuple[int, int, bytes]:
    """A material texture's width, height and RGB bytes, made once per process (the images are seeded)."""
    img = TEXTURES[texture]()
    return img.shape[1], img.shape[0], img.tobytes()

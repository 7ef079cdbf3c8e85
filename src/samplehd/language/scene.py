"""Scenes as the language package reads them: parsed and validated CLEVR-layout scene dicts.

A scenes file is ``{"info": {...}, "scenes": [scene, ...]}`` (CLEVR's layout with SAMPLE-HD's
fields). Only the fields instruction generation needs are parsed; every error names the file, the
scene index and the field, on one line.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from samplehd.errors import SceneError
from samplehd.fileio import read_json
from samplehd.scene.annotate import SceneAnnotation
from samplehd.world.layout import DIRECTIONS, TABLE_PARTS
from samplehd.world.relations import RELATIONS, compute_relationships

__all__ = ["Scene", "SceneObject", "load_scenes", "parse_scene"]

_AFFORDANCES = ("graspable", "handle_pickable", "container", "stackable_on", "stackable")


@dataclass(frozen=True)
class SceneObject:
    """One object of a scene, with the attributes instructions talk about.

    Attributes:
        index: position of the object in the scene's object list.
        name: class name ("mug", "wine_glass", or an imported class).
        colour: colour name.
        material: material name.
        size: size name (small, medium, large).
        table_part: table parts the object's centre lies in (subset of left/right/front/back).
        coords: centre position (x, y, z) in the world [m].
        extents: bounding box extents (dx, dy, dz) [m].
        graspable: the gripper can pick it up.
        handle_pickable: it is picked by a handle.
        container: things can be put into it.
        stackable_on: things can be stacked on it.
        stackable: it can be stacked on something.
        opening_radius: radius of a container's opening [m], or None.
        top_extent: extents (dx, dy) of a flat top things can stand on [m], or None.
        rotation: yaw about the vertical [deg], or None (older scene files: taken as 0).
        bbox_min: lower corner (x, y, z) of the world-aligned bounding box [m], or None.
        bbox_max: upper corner (x, y, z) of the world-aligned bounding box [m], or None.
        footprint_half_extents: half sizes (x, y) of the footprint rectangle in the object frame
            [m], or None (taken from ``extents``).
    """

    index: int
    name: str
    colour: str
    material: str
    size: str
    table_part: tuple[str, ...]
    coords: tuple[float, float, float]
    extents: tuple[float, float, float]
    graspable: bool = True
    handle_pickable: bool = False
    container: bool = False
    stackable_on: bool = False
    stackable: bool = False
    opening_radius: float | None = None
    top_extent: tuple[float, float] | None = None
    rotation: float | None = None
    bbox_min: tuple[float, float, float] | None = None
    bbox_max: tuple[float, float, float] | None = None
    footprint_half_extents: tuple[float, float] | None = None

    @property
    def footprint(self) -> tuple[float, float]:
        """Horizontal extents (dx, dy) [m]."""
        return (self.extents[0], self.extents[1])

    @property
    def yaw(self) -> float:
        """Yaw about the vertical [rad] (0 where the scene file gives no ``rotation``)."""
        return math.radians(self.rotation) if self.rotation is not None else 0.0

    @property
    def footprint_centre(self) -> tuple[float, float]:
        """Centre (x, y) of the footprint rectangle in the world [m].

        Objects stand upright, so it is the centre of the world bounding box; without one, the
        object's position ``coords``.
        """
        if self.bbox_min is None or self.bbox_max is None:
            return (self.coords[0], self.coords[1])
        return (0.5 * (self.bbox_min[0] + self.bbox_max[0]), 0.5 * (self.bbox_min[1] + self.bbox_max[1]))

    @property
    def footprint_half(self) -> tuple[float, float]:
        """Half sizes (x, y) of the footprint rectangle in the object frame [m], turned by ``yaw``."""
        if self.footprint_half_extents is not None:
            return self.footprint_half_extents
        return (0.5 * self.extents[0], 0.5 * self.extents[1])

    def attribute(self, kind: str) -> str | tuple[str, ...]:
        """Return the value of an attribute kind (name, colour, material, size, table_part)."""
        return getattr(self, kind)

    def to_dict(self) -> dict[str, object]:
        """Return the object in the scene-file layout (the fields this package reads)."""
        out: dict[str, Any] = {
            "name": self.name,
            "shape": self.name,
            "color": self.colour,
            "colour": self.colour,
            "material": self.material,
            "size": self.size,
            "table_part": list(self.table_part),
            "3d_coords": list(self.coords),
            "bbox": {"extents": list(self.extents)},
            "affordances": {a: getattr(self, a) for a in _AFFORDANCES},
        }
        if self.rotation is not None:
            out["rotation"] = self.rotation
        if self.bbox_min is not None and self.bbox_max is not None:
            out["bbox"]["min"] = list(self.bbox_min)
            out["bbox"]["max"] = list(self.bbox_max)
        if self.footprint_half_extents is not None:
            out["footprint_half_extents"] = list(self.footprint_half_extents)
        if self.opening_radius is not None:
            out["opening_radius"] = self.opening_radius
        if self.top_extent is not None:
            out["top_extent"] = list(self.top_extent)
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], index: int = 0, where: str = "object") -> SceneObject:
        """Parse one scene-file object; raises SceneError naming ``where`` and the field."""
        return _parse_object(data, index, where)


@dataclass(frozen=True)
class Scene:
    """A scene: its objects and their pairwise relationships.

    Attributes:
        image_index: the scene's index (CLEVR ``image_index``).
        image_filename: the scene image's file name.
        split: dataset split name ("train", "test", ...).
        objects: the objects, in scene order.
        relationships: relation -> per object i, the sorted indices j in that direction of i.
        directions: direction name -> unit vector in the world frame.
    """

    image_index: int
    image_filename: str
    split: str
    objects: tuple[SceneObject, ...]
    relationships: dict[str, tuple[tuple[int, ...], ...]] = field(default_factory=dict)
    directions: dict[str, tuple[float, float, float]] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.objects)

    def to_dict(self) -> dict[str, object]:
        """Return the scene in the scenes-file layout (the fields this package reads)."""
        return {
            "split": self.split,
            "image_index": self.image_index,
            "image_filename": self.image_filename,
            "directions": {k: list(v) for k, v in self.directions.items()},
            "objects": [o.to_dict() for o in self.objects],
            "relationships": {k: [list(js) for js in v] for k, v in self.relationships.items()},
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "scene") -> Scene:
        """Parse a scene dict; raises SceneError naming ``where`` and the field."""
        return parse_scene(data, where=where)


def _fail(where: str, field_name: str, message: str) -> SceneError:
    return SceneError(f"{where}: {field_name}: {message}")


def _string(data: Mapping[str, Any], keys: Sequence[str], where: str) -> str:
    for key in keys:
        if key in data:
            value = data[key]
            if not isinstance(value, str) or not value:
                raise _fail(where, key, f"expected a non-empty string, got {value!r}")
            return value
    raise _fail(where, keys[0], "missing")


def _vector(value: Any, n: int, where: str, field_name: str) -> tuple[float, ...]:
    if not isinstance(value, Sequence) or isinstance(value, str) or len(value) < n:
        raise _fail(where, field_name, f"expected a list of {n} numbers, got {value!r}")
    try:
        out = tuple(float(v) for v in value[:n])
    except (TypeError, ValueError):
        raise _fail(where, field_name, f"expected numbers, got {value!r}") from None
    if not all(math.isfinite(v) for v in out):
        raise _fail(where, field_name, f"expected finite numbers, got {value!r}")
    return out


def _number(value: Any, where: str, field_name: str, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise _fail(where, field_name, f"expected a finite number ({what}), got {value!r}")
    return float(value)


def _bbox_corners(
    bbox: Mapping[str, Any], where: str
) -> tuple[tuple[float, float, float] | None, tuple[float, float, float] | None]:
    """The optional world bounding box corners: both or neither, lower <= upper on every axis."""
    if "min" not in bbox and "max" not in bbox:
        return None, None
    for key in ("min", "max"):
        if key not in bbox:
            raise _fail(where, f"bbox.{key}", "missing (bbox.min and bbox.max go together)")
    lo = _vector(bbox["min"], 3, where, "bbox.min")
    hi = _vector(bbox["max"], 3, where, "bbox.max")
    if any(a > b for a, b in zip(lo, hi, strict=True)):
        raise _fail(where, "bbox.min", f"expected bbox.min <= bbox.max on every axis, got {lo!r} and {hi!r}")
    return (lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2])


def _parse_object(data: Mapping[str, Any], index: int, where: str) -> SceneObject:
    if not isinstance(data, Mapping):
        raise SceneError(f"{where}: expected an object dict, got {type(data).__name__}")
    name = _string(data, ("name", "shape"), where)
    colour = _string(data, ("colour", "color"), where)
    material = _string(data, ("material",), where)
    size = _string(data, ("size",), where)
    parts = data.get("table_part", [])
    if isinstance(parts, str):
        parts = [parts]
    if not isinstance(parts, Sequence) or any(p not in TABLE_PARTS for p in parts):
        raise _fail(where, "table_part", f"expected a list of {', '.join(TABLE_PARTS)}, got {parts!r}")
    if "3d_coords" not in data:
        raise _fail(where, "3d_coords", "missing")
    coords = _vector(data["3d_coords"], 3, where, "3d_coords")
    bbox = data.get("bbox")
    if not isinstance(bbox, Mapping) or "extents" not in bbox:
        raise _fail(where, "bbox.extents", "missing")
    extents = _vector(bbox["extents"], 3, where, "bbox.extents")
    bbox_min, bbox_max = _bbox_corners(bbox, where)
    rotation = data.get("rotation")
    if rotation is not None:
        rotation = _number(rotation, where, "rotation", "yaw in degrees")
    half = data.get("footprint_half_extents")
    if half is not None:
        half = _vector(half, 2, where, "footprint_half_extents")
        if min(half) <= 0:
            raise _fail(where, "footprint_half_extents", f"expected two positive half sizes [m], got {list(half)!r}")
    aff = data.get("affordances", {})
    if not isinstance(aff, Mapping):
        raise _fail(where, "affordances", f"expected a dict of booleans, got {aff!r}")
    flags: dict[str, bool] = {}
    for key in _AFFORDANCES:
        value = aff.get(key, key == "graspable")
        if not isinstance(value, bool):
            raise _fail(where, f"affordances.{key}", f"expected true or false, got {value!r}")
        flags[key] = value
    opening = data.get("opening_radius")
    if opening is not None:
        opening = _vector([opening], 1, where, "opening_radius")[0]
    top = data.get("top_extent")
    if top is not None:
        top = _vector(top, 2, where, "top_extent")
    return SceneObject(
        index=index,
        name=name,
        colour=colour,
        material=material,
        size=size,
        table_part=tuple(str(p) for p in parts),
        coords=(coords[0], coords[1], coords[2]),
        extents=(extents[0], extents[1], extents[2]),
        opening_radius=opening,
        top_extent=None if top is None else (top[0], top[1]),
        rotation=rotation,
        bbox_min=bbox_min,
        bbox_max=bbox_max,
        footprint_half_extents=None if half is None else (half[0], half[1]),
        **flags,
    )


def parse_scene(data: Mapping[str, Any], where: str = "scene") -> Scene:
    """Parse and validate one CLEVR-layout scene dict.

    Missing ``relationships`` are computed from the objects' ``3d_coords``; missing ``directions``
    default to :data:`samplehd.world.layout.DIRECTIONS`.

    Args:
        data: the scene dict.
        where: prefix for error messages, e.g. ``"scenes.json: scene 3"``.

    Raises:
        SceneError: a field is missing or malformed (the message names it).
    """
    if not isinstance(data, Mapping):
        raise SceneError(f"{where}: expected a scene dict, got {type(data).__name__}")
    raw_objects = data.get("objects")
    if not isinstance(raw_objects, Sequence) or isinstance(raw_objects, str):
        raise _fail(where, "objects", "missing or not a list")
    objects = tuple(_parse_object(o, i, f"{where}: objects[{i}]") for i, o in enumerate(raw_objects))
    image_index = data.get("image_index", 0)
    if not isinstance(image_index, int) or isinstance(image_index, bool):
        raise _fail(where, "image_index", f"expected an integer, got {image_index!r}")
    raw_dirs = data.get("directions") or DIRECTIONS
    if not isinstance(raw_dirs, Mapping):
        raise _fail(where, "directions", f"expected a dict of vectors, got {raw_dirs!r}")
    directions: dict[str, tuple[float, float, float]] = {}
    for key, value in raw_dirs.items():
        v = _vector(value, 3, where, f"directions.{key}")
        directions[str(key)] = (v[0], v[1], v[2])
    for rel in RELATIONS:
        if rel not in directions:
            raise _fail(where, f"directions.{rel}", "missing")
    raw_rel = data.get("relationships")
    if raw_rel is None:
        raw_rel = compute_relationships([{"3d_coords": o.coords} for o in objects], directions)
    if not isinstance(raw_rel, Mapping):
        raise _fail(where, "relationships", "expected a dict of lists")
    relationships: dict[str, tuple[tuple[int, ...], ...]] = {}
    n = len(objects)
    for rel in RELATIONS:
        rows = raw_rel.get(rel)
        if not isinstance(rows, Sequence) or len(rows) != n:
            raise _fail(where, f"relationships.{rel}", f"expected one list per object ({n})")
        parsed = []
        for i, row in enumerate(rows):
            if not isinstance(row, Sequence) or any(
                not isinstance(j, int) or isinstance(j, bool) or not 0 <= j < n or j == i for j in row
            ):
                raise _fail(where, f"relationships.{rel}[{i}]", f"expected object indices, got {row!r}")
            parsed.append(tuple(sorted(row)))
        relationships[rel] = tuple(parsed)
    filename = data.get("image_filename", f"{image_index:06d}.png")
    split = data.get("split", "none")
    if not isinstance(filename, str) or not isinstance(split, str):
        raise _fail(where, "image_filename/split", "expected strings")
    return Scene(
        image_index=image_index,
        image_filename=filename,
        split=split,
        objects=objects,
        relationships=relationships,
        directions=directions,
    )


def _scene_dicts(path: Path) -> tuple[dict[str, Any], list[tuple[str, Any]]]:
    data = read_json(path, SceneError)
    if isinstance(data, Mapping) and "scenes" in data:
        scenes = data["scenes"]
        if not isinstance(scenes, list):
            raise SceneError(f"{path}: scenes: expected a list")
        info = data.get("info")
        info = dict(info) if isinstance(info, Mapping) else {}
        return info, [(f"{path}: scene {i}", s) for i, s in enumerate(scenes)]
    if isinstance(data, Mapping) and "objects" in data:
        return {}, [(f"{path}", data)]
    raise SceneError(f"{path}: expected a scenes file {{info, scenes: [...]}} or one scene dict")


def load_scenes(path: str | Path) -> tuple[dict[str, Any], list[SceneAnnotation]]:
    """Read scene dicts from a scenes file or a folder.

    A folder is read as its ``scenes.json`` if it has one, else as every ``*.json`` in it (each a
    scenes file or a single scene), sorted by name. The dicts are returned unparsed (use
    :func:`parse_scene`); each is checked to be a dict.

    Args:
        path: a ``scenes.json`` file or a folder.

    Returns:
        ``(info, scenes)``: the first file's ``info`` dict (or ``{}``) and the scene dicts.

    Raises:
        SceneError: the path is missing, or a file is not a scenes file.
    """
    path = Path(path)
    if path.is_dir():
        files = [path / "scenes.json"] if (path / "scenes.json").is_file() else sorted(path.glob("*.json"))
        if not files:
            raise SceneError(f"{path}: no scenes.json and no *.json scene files in this folder")
    elif path.is_file():
        files = [path]
    else:
        raise SceneError(f"{path}: no such file or folder")
    info: dict[str, Any] = {}
    scenes: list[SceneAnnotation] = []
    for file in files:
        file_info, entries = _scene_dicts(file)
        info = info or file_info
        for where, scene in entries:
            if not isinstance(scene, Mapping):
                raise SceneError(f"{where}: expected a scene dict")
            scenes.append(dict(scene))
    return info, scenes

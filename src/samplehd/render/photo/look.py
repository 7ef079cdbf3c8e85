"""The photo preset's look: physically based materials by name, textures and kitchen lighting.

Materials are chosen from the compiled model's material names, which say what a surface is:
catalogue objects carry ``{material}_{colour}`` (``glass_transparent``, ``metal_red``, ...), the world
its own names (``table_wood``, ``floor``, ``wall``, ...) and the robot ``robot_*``. Colours are the
model's own (sRGB, converted to linear reflectance), so the robot keeps its real colours.

The look can be randomised for sim-to-real transfer (:class:`LookParams`): light intensity, colour
temperature and direction, table/floor/wall textures and exposure, all drawn from one seed.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any, TypedDict

import numpy as np

from samplehd.render.photo.geometry import Part
from samplehd.render.photo.runtime import load_mitsuba
from samplehd.render.photo.textures import can_label, food_box_print, srgb_to_linear, window_view
from samplehd.render.scene_lighting import SceneLighting

__all__ = ["LookParams", "bsdf_for", "default_look", "lights", "random_look"]

# Cutlery is polished; pans, trays and thermoses are brushed (rough) metal.
_POLISHED_CLASSES = ("knife", "fork", "spoon", "scissors")


@dataclass(frozen=True)
class LookParams:
    """Lighting, textures and exposure of a photo render (recorded in the scene annotation).

    Attributes:
        light_scale: multiplies every light's power.
        colour_temperature: of the ceiling lights [K] (the window stays daylight).
        key_offset: (x, y) shift of the main ceiling panel from above the table [m]: the light's direction.
        table_seed, floor_seed, wall_seed: seeds of where the textures start (0: as the GL presets).
        table_tint, floor_tint, wall_tint: RGB multipliers of those textures.
        exposure: exposure in stops (0 = the default).
        randomised: whether the values were drawn from a seed.
    """

    light_scale: float = 1.0
    colour_temperature: float = 5400.0
    key_offset: tuple[float, float] = (0.0, 0.0)
    table_seed: int = 0
    floor_seed: int = 0
    wall_seed: int = 0
    table_tint: tuple[float, float, float] = (1.0, 1.0, 1.0)
    floor_tint: tuple[float, float, float] = (1.0, 1.0, 1.0)
    wall_tint: tuple[float, float, float] = (1.0, 1.0, 1.0)
    exposure: float = 0.0
    randomised: bool = False
    extra: dict[str, Any] = field(default_factory=dict, compare=False)

    def to_dict(self) -> dict[str, object]:
        d = asdict(self)
        d.pop("extra")
        d["key_offset"] = list(self.key_offset)
        for k in ("table_tint", "floor_tint", "wall_tint"):
            d[k] = [round(float(c), 6) for c in d[k]]
        return d


def default_look() -> LookParams:
    """The fixed look (no randomisation)."""
    return LookParams()


def random_look(seed: int) -> LookParams:
    """A look drawn from ``seed``: the same seed gives the same look."""
    rng = np.random.default_rng([int(seed), 0x9107])

    def tint(spread: float) -> tuple[float, float, float]:
        return tuple(float(v) for v in np.clip(1.0 + rng.uniform(-spread, spread, 3), 0.6, 1.3))  # type: ignore[return-value]

    return LookParams(
        light_scale=float(rng.uniform(0.6, 1.5)),
        colour_temperature=float(rng.uniform(2700.0, 6500.0)),
        key_offset=(float(rng.uniform(-0.8, 0.8)), float(rng.uniform(-0.8, 0.8))),
        table_seed=int(rng.integers(1, 2**31)),
        floor_seed=int(rng.integers(1, 2**31)),
        wall_seed=int(rng.integers(1, 2**31)),
        table_tint=tint(0.25),
        floor_tint=tint(0.2),
        wall_tint=tint(0.12),
        exposure=float(rng.uniform(-0.5, 0.5)),
        randomised=True,
    )


def blackbody_rgb(kelvin: float) -> np.ndarray:
    """Linear RGB of a black body at ``kelvin``, normalised to luminance 1 (Tanner Helland's fit)."""
    t = kelvin / 100.0
    r = 1.0 if t <= 66 else 1.292936186 * (t - 60) ** -0.1332047592
    g = 0.390081578 * np.log(t) - 0.631841443 if t <= 66 else 1.129890861 * (t - 60) ** -0.0755148492
    b = 1.0 if t >= 66 else (0.0 if t <= 19 else 0.543206789 * np.log(t - 10) - 1.196254089)
    rgb = srgb_to_linear(np.clip([r, g, b], 0.0, 1.0))
    return rgb / float(rgb @ np.array([0.2126, 0.7152, 0.0722]))


class RgbSpectrum(TypedDict):
    """Mitsuba's ``rgb`` texture: ``type`` ``"rgb"`` and the linear RGB ``value`` (each 0..1 for a
    reflectance; radiance is unbounded)."""

    type: str
    value: list[float]


class AreaEmitter(TypedDict):
    """Mitsuba's ``area`` emitter: ``type`` ``"area"`` and its radiance."""

    type: str
    radiance: RgbSpectrum


def _rgb(v: Any) -> RgbSpectrum:
    return {"type": "rgb", "value": [float(c) for c in np.clip(v, 0.0, 1.0)]}


def _bitmap(img: np.ndarray, scale: tuple[float, float] = (1.0, 1.0), wrap: str = "repeat",
            offset: tuple[float, float] = (0.0, 0.0), swap: bool = False) -> dict[str, Any]:
    """A bitmap texture from a float linear image whose row 0 is v = 0; texture coordinates are
    scaled, then offset (``swap`` exchanges u and v first, to turn a grain direction)."""
    mi = load_mitsuba()
    arr = np.ascontiguousarray(np.flipud(img), dtype=np.float32)  # Mitsuba's row 0 is v = 1
    d: dict[str, Any] = {
        "type": "bitmap",
        "data": mi.TensorXf(arr if arr.ndim == 3 else arr[..., None]),  # copied: owned by the texture
        "raw": True,
        "filter_type": "bilinear",
        "wrap_mode": wrap,
    }
    if scale != (1.0, 1.0) or offset != (0.0, 0.0) or swap:
        tf = mi.ScalarTransform4f().translate([offset[0], offset[1], 0.0]).scale([scale[0], scale[1], 1.0])
        if swap:
            tf = tf @ mi.ScalarTransform4f(np.array([[0, 1, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float))
        d["to_uv"] = tf
    return d


def _texture(img: np.ndarray, tint: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> np.ndarray:
    """A model texture (uint8 sRGB) as linear reflectance, tinted."""
    lin = srgb_to_linear(img.astype(np.float64) / 255.0) * np.asarray(tint)[None, None, :]
    return np.clip(lin, 0.0, 1.0)


def _shift(seed: int) -> tuple[float, float]:
    """Where a texture starts, from a seed: another piece of the same wood, tiles or plaster."""
    if seed == 0:
        return (0.0, 0.0)
    u, v = np.random.default_rng(seed).random(2)
    return (float(u), float(v))


def _plastic(colour: Any, alpha: float, spec: float = 1.0) -> dict[str, Any]:
    reflect = colour if isinstance(colour, dict) else _rgb(colour)
    return {"type": "roughplastic", "distribution": "ggx", "alpha": alpha, "int_ior": 1.5,
            "diffuse_reflectance": reflect, "specular_reflectance": spec}


def _metal(colour: np.ndarray | None, alpha: float) -> dict[str, Any]:
    d: dict[str, Any] = {"type": "roughconductor", "material": "Al", "distribution": "ggx", "alpha": alpha}
    if colour is not None:
        d["specular_reflectance"] = _rgb(colour)
    return d


def _catalogue_bsdf(kind: str, colour_name: str, lin: np.ndarray, srgb: np.ndarray, part: Part,
                    image: np.ndarray | None) -> dict[str, Any]:
    cls = part.mesh_class
    if kind == "glass":
        tint = np.ones(3) if colour_name == "transparent" else np.clip(0.5 + 0.5 * lin / max(lin.max(), 1e-6), 0, 1)
        return {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0, "specular_transmittance": _rgb(tint)}
    if kind == "metal":
        coloured = colour_name not in ("metallic", "white", "black")
        tint = np.clip(0.15 + 0.85 * lin / max(lin.max(), 1e-6), 0, 1) if coloured else None
        if colour_name == "black":
            tint = np.full(3, 0.08)
        if cls == "soda_can":
            img, mask = can_label(tuple(float(c) for c in srgb[:3]))
            return {"type": "blendbsdf", "weight": _bitmap(mask),
                    "bsdf_0": _plastic(_bitmap(srgb_to_linear(img)), 0.08), "bsdf_1": _metal(None, 0.12)}
        return _metal(tint, 0.04 if cls in _POLISHED_CLASSES else 0.18)
    if kind == "ceramic":
        return {"type": "plastic", "int_ior": 1.5, "diffuse_reflectance": _rgb(lin)}
    if kind == "rubber":
        return _plastic(lin, 0.6, 0.3)
    if kind == "wooden" and image is not None:  # the grain texture, tinted by the colour
        return _plastic(_bitmap(_texture(image, tuple(lin))), 0.35, 0.5)
    if cls == "food_box":
        img = food_box_print(tuple(float(c) for c in srgb[:3]))
        return _plastic(_bitmap(srgb_to_linear(img), (1 / 3, 1.0), wrap="clamp"), 0.3, 0.6)
    return _plastic(lin, 0.15)  # plastic and anything unnamed


_CATALOGUE_MATERIALS = ("ceramic", "glass", "metal", "plastic", "rubber", "wooden")


def bsdf_for(part: Part, look: LookParams, image: np.ndarray | None = None) -> dict[str, Any]:
    """The Mitsuba BSDF of a part, from its material name, colour and RGB texture ``image`` (uint8)."""
    name = part.material
    srgb = np.asarray(part.rgba, dtype=np.float64)
    lin = srgb_to_linear(srgb[:3])
    if part.mesh_class == "food_box":
        return _catalogue_bsdf("paper", "", lin, srgb, part, image)
    head, _, colour = name.partition("_")
    if head in _CATALOGUE_MATERIALS and colour:
        return _catalogue_bsdf(head, colour, lin, srgb, part, image)
    if image is not None and name == "floor":  # tiles 40 cm across (the checker's 2×2 squares per image)
        floor = _texture(image, tuple(np.asarray(look.floor_tint) * np.array([1.0, 0.94, 0.84])))
        return _plastic(_bitmap(floor, (1 / 0.8, 1 / 0.8), offset=_shift(look.floor_seed)), 0.25, 0.6)
    if image is not None and name == "table_wood":
        # Grain along the table's long side; mirrored repeats, so no seams (the texture does not tile).
        wood = _texture(image, look.table_tint)
        off = np.add((0.5, 0.5), _shift(look.table_seed))
        return _plastic(_bitmap(wood, (1 / 0.7, 1 / 0.7), wrap="mirror", offset=tuple(off), swap=True), 0.2)
    if image is not None and name == "wall":
        plaster = _texture(image, look.wall_tint)
        return {"type": "diffuse", "reflectance": _bitmap(plaster, (1 / 1.5, 1 / 1.5), offset=_shift(look.wall_seed))}
    if image is not None and name == "backsplash":  # 15 cm glazed tiles
        return {"type": "plastic", "int_ior": 1.5, "nonlinear": True,
                "diffuse_reflectance": _bitmap(_texture(image), (1 / 0.6, 1 / 0.6))}
    if name in ("leg_metal", "handle", "robot_metal"):
        return _metal(None if name != "leg_metal" else np.full(3, 0.55), 0.15 if name == "leg_metal" else 0.08)
    if name == "countertop":
        return _plastic(lin * 0.9, 0.12)
    if name == "window":
        return {"type": "diffuse", "reflectance": _rgb(np.full(3, 0.8))}
    if name in ("robot_rubber", "robot_dark"):
        return _plastic(lin, 0.5, 0.4)
    if name.startswith("robot_"):
        return _plastic(lin, 0.25, 0.8)  # the UR's painted aluminium and plastic caps
    if name == "cabinet":
        return _plastic(lin, 0.3, 0.7)
    return {"type": "diffuse", "reflectance": _rgb(lin)}


def _emitter(rgb: np.ndarray) -> AreaEmitter:
    return {"type": "area", "radiance": {"type": "rgb", "value": [float(c) for c in rgb]}}


def lights(look: LookParams, scene: SceneLighting | None = None) -> dict[str, dict[str, Any]]:
    """Kitchen lighting: a bright window in the back wall, two ceiling panels and a closed ceiling.

    ``scene`` changes them as the GL presets' lights are changed (:mod:`samplehd.render.scene_lighting`):
    every emitter scaled by its intensity and tinted, the main panel (the key light) turned about the
    vertical through the table centre.

    Returns:
        Named Mitsuba shapes (emitting rectangles and the ceiling) to add to the scene.
    """
    mi = load_mitsuba()
    tf = mi.ScalarTransform4f
    down = tf().rotate([1, 0, 0], 180)  # a rectangle faces +z; ceiling parts face the floor
    scene = scene or SceneLighting()
    tint = np.asarray(scene.tint, dtype=float)
    warm = blackbody_rgb(look.colour_temperature) * tint
    day = blackbody_rgb(6500.0) * np.array([0.92, 0.97, 1.08]) * tint
    s = look.light_scale * scene.intensity
    kx, ky = look.key_offset
    key_x, key_y = 0.2 + kx, 0.3 + ky
    if scene.turn:
        c, t = np.cos(np.radians(scene.turn)), np.sin(np.radians(scene.turn))
        key_x, key_y = float(c * key_x - t * key_y), float(t * key_x + c * key_y)
    return {
        # Closed ceiling: light bounces back down as in a room (it is above every camera's view).
        "photo_ceiling": {"type": "rectangle",
                          "to_world": tf().translate([0.25, 0.0, 3.0]).scale([1.75, 3.0, 1.0]) @ down,
                          "bsdf": {"type": "diffuse", "reflectance": _rgb(np.full(3, 0.8))}},
        # The window pane, just in front of the modelled one (its face is at x = -1.42, the bar in front).
        # It shows a sky over trees, bright enough to light the room, not so bright that it burns out.
        "photo_window": {"type": "rectangle", "emitter": {"type": "area", "radiance": _bitmap(
                             window_view() * (day * 2.6 * s)[None, None, :])},
                         "to_world": tf().translate([-1.419, 0.0, 1.75]).rotate([0, 1, 0], 90)
                         .scale([0.36, 0.56, 1.0])},
        # Main panel above the table (its offset sets where the light comes from) and a softer fill.
        "photo_key": {"type": "rectangle", "emitter": _emitter(warm * 18.0 * s),
                      "to_world": tf().translate([key_x, key_y, 2.95]).scale([0.45, 0.3, 1.0]) @ down},
        "photo_fill": {"type": "rectangle", "emitter": _emitter(warm * 6.0 * s),
                       "to_world": tf().translate([1.2, -0.8, 2.95]).scale([0.4, 0.4, 1.0]) @ down},
    }

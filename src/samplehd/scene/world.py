"""Compose the kitchen world with ``mujoco.MjSpec``: floor, wooden table, kitchen backdrop, lights,
cameras, the UR5e with its gripper, and the scene's objects.

Model-building (which objects, which cameras → recompile) is kept apart from per-episode state
(poses → qpos): :func:`build_world` returns an ``MjSpec``; callers compile it once per scene.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import mujoco
import numpy as np

from samplehd.catalogue import add_object
from samplehd.errors import ConfigError
from samplehd.render.scene_lighting import SceneLighting, write_lighting
from samplehd.robot.constants import HOME_QPOS, ROBOT_BASE_QUAT, ROBOT_BODY, ROBOT_LOOKS, WRIST_CAMERA
from samplehd.robot.controller import ControlConfig, RobotController
from samplehd.robot.ur5e import add_robot
from samplehd.scene.textures import plaster_texture, recolour, tile_texture, wood_texture
from samplehd.schema import Config, bounded
from samplehd.world.bodies import object_body_name
from samplehd.world.layout import LAYOUT, TableLayout
from samplehd.world.transforms import look_at_quat

__all__ = [
    "CAMERA_NAMES",
    "OPERATOR_CAMERA",
    "SCENE_CAMERA",
    "CameraSpec",
    "Lighting",
    "PlacedObject",
    "Surfaces",
    "WorldConfig",
    "build_world",
    "compile_world",
    "fresh_state",
    "reset_robot_home",
]

_GEOM = mujoco.mjtGeom
_ROLE_RGB = mujoco.mjtTextureRole.mjTEXROLE_RGB


@dataclass(frozen=True)
class CameraSpec(Config, section="camera"):
    """A fixed camera looking at a target point.

    Attributes:
        name: camera name in the model.
        pos: camera position in the world [m].
        target: point the optical axis passes through [m].
        fovy: vertical field of view [deg].
    """

    name: str
    pos: tuple[float, float, float]
    target: tuple[float, float, float]
    fovy: float = bounded(45.0, lo=1.0, hi=170.0, unit="deg")

    def __post_init__(self) -> None:
        super().__post_init__()
        if np.allclose(self.pos, self.target):
            raise ConfigError(f"camera {self.name!r}: pos and target must differ")


# The operator's viewpoint: in front of the table (+x), at standing eye height, looking at the workspace.
OPERATOR_CAMERA = CameraSpec("operator", pos=(1.30, 0.0, 1.56), target=(-0.05, 0.0, 0.93), fovy=45.0)
# The camera the scene sampler places in a cone around the operator's viewpoint (samplehd.scene.sampler).
SCENE_CAMERA = "scene"
# The cameras of every sampled world: the scene camera, the fixed operator camera, the robot's wrist camera.
CAMERA_NAMES = (SCENE_CAMERA, OPERATOR_CAMERA.name, WRIST_CAMERA)


@dataclass(frozen=True)
class Lighting(Config, section="lighting"):
    """How the scene's lights differ from the kitchen's own (the default changes nothing).

    Lights only change images: the physics of a world is the same under any lighting.

    Attributes:
        intensity: factor on the diffuse and specular light of every light and of the headlight [1].
        turn: the key light (the one that casts shadows) turned about the vertical through the table
            centre, its position and direction together [deg, counter-clockwise seen from above].
        tint: factor per colour channel (red, green, blue) on every light's colour [1]; (1.2, 1, 0.8)
            is warmer, (0.8, 1, 1.2) cooler.
    """

    intensity: float = bounded(1.0, lo=0.0, hi=4.0)
    turn: float = bounded(0.0, lo=-180.0, hi=180.0, unit="deg")
    tint: tuple[float, float, float] = bounded((1.0, 1.0, 1.0), lo=0.0, hi=4.0)


DEFAULT_LIGHTING = Lighting()


@dataclass(frozen=True)
class Surfaces(Config, section="surfaces"):
    """How the table's and the walls' textures differ from the kitchen's own (the default changes nothing).

    Each surface's texture is moved in HSV (:func:`samplehd.scene.textures.recolour`): the table's wood
    (top and apron), and the walls' plaster with the backsplash tiles. Surfaces only change images: the
    physics of a world is the same under any of them.

    Attributes:
        table_hue: the table's wood turned round the colour wheel [deg of hue].
        table_saturation: factor on the wood's saturation [1].
        table_value: factor on the wood's brightness (HSV value) [1].
        wall_hue: the walls' plaster and tiles turned round the colour wheel [deg of hue].
        wall_saturation: factor on their saturation [1].
        wall_value: factor on their brightness [1].
    """

    table_hue: float = bounded(0.0, lo=-180.0, hi=180.0, unit="deg")
    table_saturation: float = bounded(1.0, lo=0.0, hi=10.0)
    table_value: float = bounded(1.0, lo=0.0, hi=4.0)
    wall_hue: float = bounded(0.0, lo=-180.0, hi=180.0, unit="deg")
    wall_saturation: float = bounded(1.0, lo=0.0, hi=10.0)
    wall_value: float = bounded(1.0, lo=0.0, hi=4.0)


DEFAULT_SURFACES = Surfaces()


@dataclass(frozen=True)
class PlacedObject:
    """An object instance at a pose: what the world builder needs to add one scene object.

    Attributes:
        instance: a ``samplehd.catalogue.ObjectInstance``.
        pos: position of the object's frame in the world [m].
        quat: orientation (w, x, y, z).
    """

    instance: Any
    pos: tuple[float, float, float]
    quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class WorldConfig(Config, section="world"):
    """Options of the world model.

    Attributes:
        timestep: physics step [s] (500 Hz by default).
        cameras: fixed cameras besides the robot's wrist camera.
        with_robot: include the UR5e and gripper.
        robot_look: how the arm is drawn: ``mesh`` (the UR5e's real meshes) or ``primitive``
            (the shapes its physics uses); the physics is the same for both.
        offscreen_size: largest offscreen render (width, height) [px].
        shadow_size: shadow map resolution [px].
        lighting: the scene lights (:class:`Lighting`; the default is the kitchen's own).
        surfaces: the table's and walls' textures (:class:`Surfaces`; the default is the kitchen's own).
        sleep: let resting objects sleep (MuJoCo's sleeping islands): a sleeping object costs no
            collision or constraint work until something awake touches it. Contacts of sleeping
            bodies are not in ``data.contact``; ``samplehd.world.bodies.contact_pairs`` computes them
            on an awake copy, and ``samplehd.physics.wake_all`` wakes everything (opening the
            gripper does).
    """

    timestep: float = bounded(0.002, lo=1e-4, hi=0.02, unit="s")
    cameras: tuple[CameraSpec, ...] = (OPERATOR_CAMERA,)
    with_robot: bool = True
    robot_look: str = bounded("mesh", choices=ROBOT_LOOKS)
    offscreen_size: tuple[int, int] = bounded((1920, 1080), lo=1, unit="px")
    shadow_size: int = bounded(4096, lo=1, unit="px")
    sleep: bool = True
    lighting: Lighting = DEFAULT_LIGHTING
    surfaces: Surfaces = DEFAULT_SURFACES

    def __post_init__(self) -> None:
        super().__post_init__()
        names = [c.name for c in self.cameras]
        if len(set(names)) != len(names) or WRIST_CAMERA in names:
            raise ConfigError(f"world.cameras={names!r}: names must be unique and not {WRIST_CAMERA!r}")


def _add_texture(spec: mujoco.MjSpec, name: str, image: tuple[int, int, bytes], cube: bool = False) -> None:
    # A cube texture with one image puts the same picture on every face of a box (the table top's
    # edges too); a 2-D texture is projected along the geom's local z and repeats with texrepeat.
    w, h, pixels = image
    kind = mujoco.mjtTexture.mjTEXTURE_CUBE if cube else mujoco.mjtTexture.mjTEXTURE_2D
    tex = spec.add_texture(name=name, type=kind, width=w, height=h, nchannel=3)
    tex.data = pixels


def _image(rgb: np.ndarray) -> tuple[int, int, bytes]:
    h, w, _ = rgb.shape
    return w, h, np.ascontiguousarray(rgb, dtype=np.uint8).tobytes()


@lru_cache(maxsize=16)
def _surface_images(surfaces: Surfaces) -> tuple[tuple[int, int, bytes], ...]:
    """The table's wood, the tiles' and the plaster's textures under ``surfaces`` (width, height, RGB
    bytes), made once per process and surfaces: every world of a dataset adds the same three."""
    wood, tiles, plaster = wood_texture(256), tile_texture(128), plaster_texture(128)
    if surfaces != DEFAULT_SURFACES:
        wood = recolour(wood, surfaces.table_hue, surfaces.table_saturation, surfaces.table_value)
        tiles, plaster = (recolour(t, surfaces.wall_hue, surfaces.wall_saturation, surfaces.wall_value)
                          for t in (tiles, plaster))
    return _image(wood), _image(tiles), _image(plaster)


def _add_material(
    spec: mujoco.MjSpec,
    name: str,
    rgba: Sequence[float] = (1, 1, 1, 1),
    texture: str | None = None,
    texrepeat: tuple[float, float] = (1.0, 1.0),
    specular: float = 0.2,
    shininess: float = 0.2,
    reflectance: float = 0.0,
    texuniform: bool = False,
) -> None:
    mat = spec.add_material(name=name, rgba=list(rgba), specular=specular, shininess=shininess)
    mat.reflectance = reflectance
    if texture:
        mat.textures[_ROLE_RGB] = texture
        mat.texrepeat = list(texrepeat)
        mat.texuniform = texuniform


def _add_materials(spec: mujoco.MjSpec, surfaces: Surfaces = DEFAULT_SURFACES) -> None:
    wood, tiles, plaster = _surface_images(surfaces)
    _add_texture(spec, "wood", wood, cube=True)
    _add_texture(spec, "tiles", tiles)
    _add_texture(spec, "plaster", plaster)
    floor = spec.add_texture(name="floor_tiles", type=mujoco.mjtTexture.mjTEXTURE_2D, width=256, height=256)
    floor.builtin = mujoco.mjtBuiltin.mjBUILTIN_CHECKER
    floor.rgb1 = [0.58, 0.55, 0.50]
    floor.rgb2 = [0.50, 0.47, 0.43]
    floor.mark = mujoco.mjtMark.mjMARK_EDGE
    floor.markrgb = [0.36, 0.34, 0.31]
    _add_material(spec, "floor", texture="floor_tiles", texrepeat=(3, 3), texuniform=True, specular=0.1)
    _add_material(spec, "table_wood", texture="wood", texrepeat=(1, 1), specular=0.25, shininess=0.35)
    _add_material(spec, "leg_metal", rgba=(0.30, 0.30, 0.32, 1), specular=0.6, shininess=0.6)
    _add_material(spec, "wall", texture="plaster", texrepeat=(3, 3), specular=0.05)
    _add_material(spec, "backsplash", texture="tiles", texrepeat=(1, 8), specular=0.4)
    _add_material(spec, "cabinet", rgba=(0.40, 0.52, 0.50, 1), specular=0.2, shininess=0.3)
    _add_material(spec, "countertop", rgba=(0.82, 0.80, 0.76, 1), specular=0.5, shininess=0.6)
    _add_material(spec, "handle", rgba=(0.75, 0.75, 0.76, 1), specular=0.9, shininess=0.9)
    _add_material(spec, "window", rgba=(0.80, 0.90, 1.0, 1), specular=0.0)
    _add_material(spec, "frame", rgba=(0.95, 0.95, 0.93, 1))


def _add_table(spec: mujoco.MjSpec, layout: TableLayout) -> None:
    sx, sy = layout.table_size
    t = layout.table_thickness
    table = spec.worldbody.add_body(name="table", pos=[0, 0, 0])
    table.add_geom(
        name="table_top",
        type=_GEOM.mjGEOM_BOX,
        size=[sx / 2, sy / 2, t / 2],
        pos=[0, 0, layout.table_height - t / 2],
        material="table_wood",
        friction=[0.8, 0.01, 0.001],
    )
    leg_h = layout.table_height - t
    for i, (lx, ly) in enumerate([(1, 1), (1, -1), (-1, 1), (-1, -1)]):
        table.add_geom(
            name=f"table_leg_{i}",
            type=_GEOM.mjGEOM_BOX,
            size=[0.03, 0.03, leg_h / 2],
            pos=[lx * (sx / 2 - 0.06), ly * (sy / 2 - 0.06), leg_h / 2],
            material="leg_metal",
        )
    # Apron under the top so the table reads as furniture, not a floating slab.
    for i, (px, py, hx, hy) in enumerate(
        [(sx / 2 - 0.06, 0, 0.015, sy / 2 - 0.06), (-(sx / 2 - 0.06), 0, 0.015, sy / 2 - 0.06),
         (0, sy / 2 - 0.06, sx / 2 - 0.06, 0.015), (0, -(sy / 2 - 0.06), sx / 2 - 0.06, 0.015)]
    ):
        table.add_geom(
            name=f"table_apron_{i}",
            type=_GEOM.mjGEOM_BOX,
            size=[hx, hy, 0.04],
            pos=[px, py, layout.table_height - t - 0.04],
            material="table_wood",
        )


# Turns a box's local z onto world x, so a 2-D texture lies flat on a wall facing +x.
_FACING_X = [np.sqrt(0.5), 0.0, np.sqrt(0.5), 0.0]


def _box(
    body: mujoco.MjsBody,
    name: str,
    center: Sequence[float],
    half: Sequence[float],
    material: str,
    facing_x: bool = False,
) -> None:
    """Add a visual-only box; `facing_x` rotates it so textures show on its ±x faces."""
    size = [half[2], half[1], half[0]] if facing_x else list(half)
    quat = _FACING_X if facing_x else [1.0, 0.0, 0.0, 0.0]
    body.add_geom(
        name=name, type=_GEOM.mjGEOM_BOX, size=size, pos=list(center), quat=quat, material=material,
        contype=0, conaffinity=0,
    )


def _add_backdrop(spec: mujoco.MjSpec) -> None:
    """Wall, base cabinets with a counter, tiled backsplash, wall cabinets and a window, behind the robot."""
    wb = spec.worldbody
    wall_x = -1.45
    _box(wb, "backdrop_wall", (wall_x - 0.05, 0, 1.5), (0.05, 3.0, 1.5), "wall", facing_x=True)
    _box(wb, "backdrop_wall_side", (0.2, -3.0, 1.5), (1.7, 0.05, 1.5), "wall")
    _box(wb, "backdrop_wall_side_right", (0.2, 3.0, 1.5), (1.7, 0.05, 1.5), "wall")
    _box(wb, "backdrop_wall_front", (1.95, 0, 1.5), (0.05, 3.0, 1.5), "wall", facing_x=True)
    # Base cabinets and countertop along the wall.
    depth, height = 0.6, 0.88
    cx = wall_x + depth / 2
    _box(wb, "backdrop_counter_body", (cx, 0, height / 2), (depth / 2, 2.4, height / 2), "cabinet")
    _box(wb, "backdrop_countertop", (cx + 0.02, 0, height + 0.02), (depth / 2 + 0.02, 2.42, 0.02), "countertop")
    for i, y in enumerate(np.arange(-2.1, 2.11, 0.6)):
        _box(wb, f"backdrop_door_{i}", (wall_x + depth + 0.005, y, 0.45), (0.005, 0.28, 0.36), "cabinet")
        _box(wb, f"backdrop_knob_{i}", (wall_x + depth + 0.02, y + 0.2, 0.7), (0.012, 0.05, 0.008), "handle")
    _box(wb, "backdrop_splash", (wall_x + 0.002, 0, height + 0.32), (0.004, 2.4, 0.30), "backsplash", facing_x=True)
    # Wall cabinets with a window between them.
    for i, y in enumerate((-1.6, 1.6)):
        _box(wb, f"backdrop_upper_{i}", (wall_x + 0.17, y, 1.85), (0.17, 0.75, 0.35), "cabinet")
        _box(wb, f"backdrop_upper_knob_{i}", (wall_x + 0.35, y - np.sign(y) * 0.6, 1.6),
             (0.012, 0.008, 0.05), "handle")
    _box(wb, "backdrop_window_frame", (wall_x + 0.01, 0, 1.75), (0.01, 0.62, 0.42), "frame")
    _box(wb, "backdrop_window", (wall_x + 0.02, 0, 1.75), (0.01, 0.56, 0.36), "window")
    _box(wb, "backdrop_window_bar", (wall_x + 0.03, 0, 1.75), (0.01, 0.02, 0.36), "frame")


def _add_lights(spec: mujoco.MjSpec, lighting: Lighting = DEFAULT_LIGHTING) -> None:
    wb = spec.worldbody
    key = wb.add_light(name="key_light", pos=[0.9, 0.6, 2.8], dir=[-0.35, -0.2, -1.0])
    key.diffuse = [0.56, 0.54, 0.52]
    key.specular = [0.5, 0.5, 0.5]
    key.castshadow = True
    key.cutoff = 60
    fill = wb.add_light(name="fill_light", pos=[1.5, -1.5, 2.2], dir=[-0.5, 0.5, -0.6])
    fill.diffuse = [0.30, 0.31, 0.34]
    fill.specular = [0.05, 0.05, 0.05]
    fill.castshadow = False
    fill.cutoff = 80
    # The window in the back wall: little light, but its reflection on glossy tops (plates, boards,
    # trays) faces the scene camera, so materials show by their highlights (see materials.json).
    window = wb.add_light(name="window_light", pos=[-1.40, 0.0, 1.75], dir=[1.0, 0.0, -0.62])
    window.diffuse = [0.10, 0.10, 0.11]
    window.specular = [0.25, 0.25, 0.25]
    window.castshadow = False
    window.cutoff = 60
    spec.visual.headlight.ambient = [0.28, 0.28, 0.28]
    spec.visual.headlight.diffuse = [0.12, 0.12, 0.12]
    # A camera-side highlight: broad on metal and plastic, sharp on ceramic, none on rubber.
    spec.visual.headlight.specular = [0.6, 0.6, 0.6]
    if lighting != DEFAULT_LIGHTING:
        _relight(spec, (key, fill, window), lighting)


def _relight(spec: mujoco.MjSpec, lights: Sequence[Any], lighting: Lighting) -> None:
    """Scale, tint and turn the kitchen's lights (``lights[0]`` is the key light) as ``lighting`` says."""
    tint = np.asarray(lighting.tint, dtype=float)
    for light in lights:
        light.diffuse = list(np.asarray(light.diffuse, dtype=float) * lighting.intensity * tint)
        light.specular = list(np.asarray(light.specular, dtype=float) * lighting.intensity * tint)
    head = spec.visual.headlight
    head.ambient = list(np.asarray(head.ambient, dtype=float) * lighting.intensity * tint)
    head.diffuse = list(np.asarray(head.diffuse, dtype=float) * lighting.intensity * tint)
    write_lighting(spec, SceneLighting(lighting.intensity, lighting.turn, lighting.tint))  # for the photo preset
    c, s = np.cos(np.radians(lighting.turn)), np.sin(np.radians(lighting.turn))
    key = lights[0]
    for attr in ("pos", "dir"):
        x, y, z = (float(v) for v in getattr(key, attr))
        setattr(key, attr, [c * x - s * y, s * x + c * y, z])


def build_world(
    objects: Sequence[PlacedObject] = (),
    config: WorldConfig | None = None,
    layout: TableLayout = LAYOUT,
) -> mujoco.MjSpec:
    """Compose the kitchen world as an ``MjSpec``.

    Args:
        objects: scene objects; object ``i`` becomes body ``object_{i}`` with a free joint.
        config: world options (timestep, cameras, robot).
        layout: table and workspace dimensions.

    Returns:
        The spec, ready for ``compile()`` (or :func:`compile_world`).
    """
    config = config or WorldConfig()
    spec = mujoco.MjSpec()
    spec.modelname = "samplehd_kitchen"
    spec.option.timestep = config.timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.noslip_iterations = 0
    if config.sleep:
        spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    spec.visual.global_.offwidth = config.offscreen_size[0]
    spec.visual.global_.offheight = config.offscreen_size[1]
    spec.visual.quality.shadowsize = config.shadow_size
    spec.visual.map.znear = 0.01
    spec.visual.map.zfar = 30.0
    spec.stat.center = [0.0, 0.0, layout.table_height]
    spec.stat.extent = 2.0

    _add_materials(spec, config.surfaces)
    spec.worldbody.add_geom(
        name="floor", type=_GEOM.mjGEOM_PLANE, size=[0, 0, 0.05], material="floor", pos=[0, 0, 0]
    )
    _add_table(spec, layout)
    _add_backdrop(spec)
    _add_lights(spec, config.lighting)
    for cam in config.cameras:
        spec.worldbody.add_camera(
            name=cam.name, pos=list(cam.pos), quat=list(look_at_quat(cam.pos, cam.target)), fovy=cam.fovy
        )
    if config.with_robot:
        add_robot(spec.worldbody, layout.robot_base_position, ROBOT_BASE_QUAT, config.robot_look, spec=spec)
    if objects:
        for i, placed in enumerate(objects):
            add_object(spec, placed.instance, object_body_name(i), placed.pos, placed.quat)
    return spec


def compile_world(
    objects: Sequence[PlacedObject] = (),
    config: WorldConfig | None = None,
    layout: TableLayout = LAYOUT,
) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """Build and compile the world; returns the model and fresh data after ``mj_forward``, with the
    arm holding its home configuration and the gripper open."""
    spec = build_world(objects, config, layout)
    model = spec.compile()
    return model, fresh_state(model)


def fresh_state(model: mujoco.MjModel) -> mujoco.MjData:
    """A new state of a compiled world as :func:`compile_world` returns it: objects where the model
    puts them, the arm holding still at home with the gripper open, after ``mj_forward``."""
    data = mujoco.MjData(model)
    reset_robot_home(model, data)
    mujoco.mj_forward(model, data)
    return data


def reset_robot_home(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Put the arm (if the model has one) at its home configuration, holding still, gripper open."""

    if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, ROBOT_BODY) < 0:
        return

    physics_hz = round(1.0 / model.opt.timestep)
    RobotController(model, data, ControlConfig(physics_hz=physics_hz, safety=None)).reset(HOME_QPOS, gripper=1.0)



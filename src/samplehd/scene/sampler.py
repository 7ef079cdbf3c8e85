"""Sample randomised scenes: objects drawn from the asset menus, placed one after another on the
table, a camera drawn around the operator viewpoint, occlusion and physics-settling checks.

Every rejection is counted by reason. The same seed gives the same scene (bit for bit).
"""

from __future__ import annotations

import math
import threading
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np

from samplehd.catalogue import Catalogue, ObjectFacts, ObjectInstance, catalogue_for, object_facts
from samplehd.errors import ConfigError, SceneError
from samplehd.fixedmath import matmul, norm
from samplehd.render.image_spec import ImageSpec
from samplehd.render.renderer import SEG_OBJECT_OFFSET, project_points, segmentation_lut
from samplehd.render.renderer_cache import MeshSharingRenderers, RendererCache
from samplehd.robot.constants import GRIPPER_STROKE, HOME_QPOS, ROBOT_BODY
from samplehd.scene.config import SceneConfig
from samplehd.scene.spec import SceneObject, SceneSpec, compile_scene, object_qpos_addresses
from samplehd.scene.world import OPERATOR_CAMERA, SCENE_CAMERA, CameraSpec
from samplehd.world.bodies import SceneBodies, object_body_name
from samplehd.world.collision import CollisionChecker
from samplehd.world.layout import LAYOUT, TableLayout
from samplehd.world.robot_info import RobotInfo
from samplehd.world.transforms import quat_from_yaw, quat_to_mat

__all__ = ["SampleResult", "add_objects", "check_scene_config", "draw_instance", "sample_camera", "sample_scene"]

@dataclass
class SampleResult:
    """A sampled scene and the bookkeeping of how it was found.

    Attributes:
        scene: the accepted scene.
        rejections: rejected candidates by reason.
        attempts: scene attempts used (1 = the first candidate scene was accepted).
        visible_pixels: per object, segmentation pixels in the occlusion check.
        model: the scene compiled (``compile_scene(scene)``'s model), or None.
    """

    scene: SceneSpec
    rejections: Counter[str] = field(default_factory=Counter)
    attempts: int = 1
    visible_pixels: list[int] = field(default_factory=list)
    model: mujoco.MjModel | None = field(default=None, compare=False, repr=False)


def _menu_values(cat: Catalogue, config: SceneConfig, class_name: str, variant: str) -> tuple[list, list]:
    menu = cat.object_class(class_name).variant(variant).menu
    pairs = list(menu.pairs)
    sizes = list(menu.size)
    override = (config.menu_overrides or {}).get(class_name)
    if override:
        unknown = sorted(set(override) - {"colour", "material", "size"})
        if unknown:
            raise ConfigError(f"scene.menu_overrides.{class_name}: unknown properties {unknown}; "
                              "valid: colour, material, size")
        if "colour" in override:
            pairs = [p for p in pairs if p[0] in override["colour"]]
        if "material" in override:
            pairs = [p for p in pairs if p[1] in override["material"]]
        if "size" in override:
            sizes = [s for s in sizes if s in override["size"]]
    return pairs, sizes


def _validate_classes(cat: Catalogue, config: SceneConfig) -> list[str]:
    classes = list(config.classes) or list(cat.classes)
    for where, names in (("classes", classes), ("menu_overrides", list(config.menu_overrides or {}))):
        for name in names:
            if name not in cat.classes:
                raise ConfigError(f"scene.{where}: unknown object class {name!r}; valid: {', '.join(cat.classes)}")
    vocab = {"colour": cat.colours, "material": cat.materials, "size": cat.sizes}
    for name, menu in (config.menu_overrides or {}).items():
        for prop, values in menu.items():
            bad = [v for v in values if v not in vocab[prop]]
            if bad:
                raise ConfigError(f"scene.menu_overrides.{name}.{prop}: unknown {bad}; valid: {', '.join(vocab[prop])}")
        if not any(all(_menu_values(cat, config, name, v)) for v in cat.object_class(name).variants):
            raise ConfigError(f"scene.menu_overrides.{name}={menu}: leaves no colour/material/size combination "
                              f"of the {name} menu")
    usable = []
    for name in classes:
        cls = cat.object_class(name)
        if any(all(_menu_values(cat, config, name, v)) for v in cls.variants):
            usable.append(name)
    if not usable:
        raise ConfigError("scene.menu_overrides leave no colour/material/size combination for any class")
    return usable


def check_scene_config(config: SceneConfig, catalogue: Catalogue | None = None) -> None:
    """Check the names a sampler config uses against the catalogue (classes, override colours,
    materials and sizes), so a command can refuse a bad config before it writes anything.

    Raises:
        ConfigError: one line naming the field, the unknown name and the valid ones.
    """
    _validate_classes(catalogue or catalogue_for(config.named_classes, config.catalogue), config)


def draw_instance(rng: np.random.Generator, cat: Catalogue, config: SceneConfig, classes: list[str]) -> ObjectInstance:
    """Draw a class uniformly, then a variant, then the menu's properties (colour/material pair, size)."""
    while True:
        name = classes[int(rng.integers(len(classes)))]
        variants = list(cat.object_class(name).variants)
        variant = variants[int(rng.integers(len(variants)))]
        pairs, sizes = _menu_values(cat, config, name, variant)
        if pairs and sizes:
            colour, material = pairs[int(rng.integers(len(pairs)))]
            size = sizes[int(rng.integers(len(sizes)))]
            return ObjectInstance(name, variant, colour, material, size)


def _footprint_corners(facts: ObjectFacts, xy: np.ndarray, yaw: float, margin: float) -> np.ndarray:
    cx, cy = facts.footprint_center
    hx, hy = facts.footprint_half_extents
    hx, hy = hx + margin, hy + margin
    local = np.array([[cx - hx, cy - hy], [cx + hx, cy - hy], [cx + hx, cy + hy], [cx - hx, cy + hy]])
    c, s = np.cos(yaw), np.sin(yaw)
    rot = np.array([[c, -s], [s, c]])
    return matmul(local, rot.T) + xy


def _rects_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Separating-axis test of two convex quadrilaterals (4×2 corner arrays), in Python floats (each
    projection ``x ax + y ay`` rounded as :func:`~samplehd.fixedmath.matmul` rounds it)."""
    pa_corners, pb_corners = a.tolist(), b.tolist()
    for poly in (pa_corners, pb_corners):
        for i in range(4):
            (x0, y0), (x1, y1) = poly[i], poly[(i + 1) % 4]
            ax, ay = -(y1 - y0), x1 - x0
            pa = [x * ax + y * ay for x, y in pa_corners]
            pb = [x * ax + y * ay for x, y in pb_corners]
            if max(pa) < min(pb) or max(pb) < min(pa):
                return False
    return True


def _place(
    rng: np.random.Generator, facts: ObjectFacts, placed: list[np.ndarray], config: SceneConfig, layout: TableLayout,
    rejections: Counter[str],
) -> tuple[np.ndarray, float, np.ndarray] | None:
    lo, hi = np.asarray(layout.workspace_min), np.asarray(layout.workspace_max)
    half_table = np.asarray(layout.table_size) / 2 - 0.02
    for _ in range(config.placement_tries):
        xy = rng.uniform(lo, hi)
        yaw = float(rng.uniform(-np.pi, np.pi))
        if not layout.in_reach(xy):
            rejections["placement_out_of_reach"] += 1
            continue
        corners = _footprint_corners(facts, xy, yaw, 0.0)
        if np.any(np.abs(corners) > half_table):
            rejections["placement_off_table"] += 1
            continue
        padded = _footprint_corners(facts, xy, yaw, config.placement_margin / 2)
        if any(_rects_overlap(padded, other) for other in placed):
            rejections["placement_intersects"] += 1
            continue
        return xy, yaw, padded
    return None


def sample_camera(rng: np.random.Generator, config: SceneConfig, base: CameraSpec = OPERATOR_CAMERA) -> CameraSpec:
    """A camera drawn in a cone around `base`: yaw about the target, elevation, distance, target jitter."""
    target = np.asarray(base.target, float) + np.append(rng.uniform(-1, 1, 2) * config.camera_target_jitter, 0.0)
    offset = np.asarray(base.pos, float) - np.asarray(base.target, float)
    dist = norm(offset) * (1.0 + rng.uniform(-1, 1) * config.camera_distance_jitter)
    yaw = math.atan2(float(offset[1]), float(offset[0])) + np.deg2rad(rng.uniform(-1, 1) * config.camera_yaw_deg)
    pitch = (math.asin(max(-1.0, min(1.0, float(offset[2]) / norm(offset))))
             + np.deg2rad(rng.uniform(-1, 1) * config.camera_pitch_deg))
    pos = target + dist * np.array([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), np.sin(pitch)])
    return CameraSpec(SCENE_CAMERA, tuple(float(v) for v in pos), tuple(float(v) for v in target), base.fovy)


def _tilt_deg(quat: np.ndarray) -> float:
    return math.degrees(math.acos(max(-1.0, min(1.0, float(quat_to_mat(quat)[2, 2])))))


def _settle(
    scene: SceneSpec, config: SceneConfig, rejections: Counter[str]
) -> tuple[SceneSpec, mujoco.MjModel, mujoco.MjData] | None:
    # Settling draws nothing: the arm's visual meshes (no mass, no contacts, the same physics bit for bit)
    # would only cost compiling and posing them at every step. The settled scene is compiled as drawn.
    model, data = compile_scene(scene, robot_look="primitive")
    adr = object_qpos_addresses(model, len(scene.objects))
    start = np.stack([data.qpos[a : a + 7] for a in adr])
    mujoco.mj_step(model, data, int(round(config.settle_time / model.opt.timestep)))
    end = np.stack([data.qpos[a : a + 7] for a in adr])
    if not np.all(np.isfinite(end)):
        rejections["settle_unstable"] += 1
        return None
    if np.any(end[:, 2] < start[:, 2] - 0.03):
        rejections["settle_fell"] += 1
        return None
    if any(_tilt_deg(e[3:]) - _tilt_deg(s[3:]) > config.max_settle_tilt_deg for s, e in zip(start, end, strict=True)):
        rejections["settle_tipped"] += 1
        return None
    if np.any(np.linalg.norm(end[:, :2] - start[:, :2], axis=1) > config.max_settle_shift):
        rejections["settle_drifted"] += 1
        return None
    dof = [int(model.jnt_dofadr[model.body_jntadr[model.body(object_body_name(i)).id]]) for i in range(len(adr))]
    speeds = [norm(data.qvel[d : d + 3]) for d in dof]
    if max(speeds) > config.max_rest_speed:
        rejections["settle_still_moving"] += 1
        return None
    objects = tuple(
        SceneObject(o.instance, tuple(float(v) for v in e[:3]), tuple(float(v) for v in e[3:] / norm(e[3:])))
        for o, e in zip(scene.objects, end, strict=True)
    )
    settled = SceneSpec(scene.index, scene.seed, objects, scene.camera)
    model, data = compile_scene(settled)
    return settled, model, data


def _home_clear(model: mujoco.MjModel, data: mujoco.MjData, count: int) -> bool:
    """Whether the arm at home, gripper fully open, touches no object (every path starts there), and no
    settled object touches the robot at all. The planner's checker ignores the base, which never moves
    (a shop-vrb pan's handle settled 11 mm deep in it, and the first step stopped on a 2.7 kN contact),
    and tolerates grazes of the arm; an object that came to rest leaning on an arm link (a saucepan's
    handle on the upper arm, 0.07 mm deep) falls into the arm's home volume once the arm leaves, and
    the way back home is then in collision."""

    if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, ROBOT_BODY) < 0:
        return True
    bodies = SceneBodies(model, count)
    objects = {int(b) for b in bodies.object_body}
    robot = bodies.robot_bodies
    for c in data.contact[: data.ncon]:
        b1, b2 = int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])
        if c.dist < 0 and ((b1 in robot and b2 in objects) or (b2 in robot and b1 in objects)):
            return False
    # one query: copying the model to prune its static pairs would cost more than it saves
    checker = CollisionChecker(model, data, bodies, RobotInfo.from_model(model, data), prune=False)
    return checker.free(HOME_QPOS, GRIPPER_STROKE)


# Corners of the unit box, to bound a geom by its local bounding box.
_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
# Pixels added around each object's projected bounds before they are compared.
_BOUNDS_MARGIN_PX = 2.0


def _screen_bounds(model: mujoco.MjModel, data: mujoco.MjData, count: int, width: int, height: int
                   ) -> list[tuple[float, float, float, float] | None]:
    """Per object, (u0, u1, v0, v1): pixel bounds in the scene camera enclosing every geom of it (the
    corners of each geom's bounding box projected, widened by a margin); None where a corner lies
    behind the camera."""
    lut = segmentation_lut(model)
    out: list[tuple[float, float, float, float] | None] = []
    for i in range(count):
        corners = []
        for g in np.flatnonzero(lut == SEG_OBJECT_OFFSET + i):
            local = model.geom_aabb[g, :3] + model.geom_aabb[g, 3:] * _CORNERS
            corners.append(data.geom_xpos[g] + matmul(local, data.geom_xmat[g].reshape(3, 3).T))
        if not corners:
            out.append(None)
            continue
        uvd = project_points(model, data, SCENE_CAMERA, width, height, np.concatenate(corners))
        if np.any(uvd[:, 2] <= 1e-3):
            out.append(None)
            continue
        m = _BOUNDS_MARGIN_PX
        out.append((float(uvd[:, 0].min()) - m, float(uvd[:, 0].max()) + m,
                    float(uvd[:, 1].min()) - m, float(uvd[:, 1].max()) + m))
    return out


def _apart(a: tuple[float, float, float, float] | None, b: tuple[float, float, float, float] | None) -> bool:
    """Whether two objects' pixel bounds cannot share a pixel."""
    return a is not None and b is not None and (a[1] < b[0] or b[1] < a[0] or a[3] < b[2] or b[3] < a[2])


def _alone_groups(bounds: list[tuple[float, float, float, float] | None]) -> list[list[int]]:
    """Objects in groups whose members' pixel bounds are pairwise apart, in order (first fit): drawn
    together, no member can hide another, so each one's pixels are those it has alone."""
    groups: list[list[int]] = []
    for i, box in enumerate(bounds):
        group = next((g for g in groups if all(_apart(box, bounds[j]) for j in g)), None)
        if group is None:
            groups.append([i])
        else:
            group.append(i)
    return groups


# Per thread, the occlusion check's renderers when the caller passes none: one GL context whose scene
# meshes are swapped from scene to scene (the arm's are uploaded once).
_OCCLUSION = threading.local()


def _occlusion_renderers() -> MeshSharingRenderers:
    kept = getattr(_OCCLUSION, "renderers", None)
    if kept is None:
        kept = _OCCLUSION.renderers = MeshSharingRenderers()
    return kept


def _visible_pixels(
    model: mujoco.MjModel, data: mujoco.MjData, count: int, config: SceneConfig,
    renderers: RendererCache | MeshSharingRenderers,
) -> tuple[list[int], list[int]]:
    """Pixels of each object in the scene camera's segmentation, with all objects and alone (the others
    out of view; objects that cannot hide each other are drawn in one render, :func:`_alone_groups`)."""
    w, h = config.occlusion_resolution
    adr = object_qpos_addresses(model, count)
    r = renderers.get(model, ImageSpec(w, h, "fast", (SCENE_CAMERA,), ("segmentation",)))
    seg = r.render(data, SCENE_CAMERA, ("segmentation",))["segmentation"]
    visible = [int(np.count_nonzero(seg == SEG_OBJECT_OFFSET + i)) for i in range(count)]
    alone = [0] * count
    saved = data.qpos.copy()
    for group in _alone_groups(_screen_bounds(model, data, count, w, h)):
        for j in range(count):
            if j not in group:  # park the others far below the floor, out of view
                data.qpos[adr[j] : adr[j] + 3] = (50.0 + j, 50.0, -50.0)
        mujoco.mj_kinematics(model, data)
        mujoco.mj_camlight(model, data)
        seg_g = r.render(data, SCENE_CAMERA, ("segmentation",))["segmentation"]
        for i in group:
            alone[i] = int(np.count_nonzero(seg_g == SEG_OBJECT_OFFSET + i))
        data.qpos[:] = saved
    mujoco.mj_forward(model, data)
    return visible, alone


def sample_scene(
    index: int,
    seed: int,
    config: SceneConfig | None = None,
    catalogue: Catalogue | None = None,
    layout: TableLayout = LAYOUT,
    renderers: RendererCache | None = None,
) -> SampleResult:
    """Sample one scene.

    Args:
        index: scene index (recorded in the spec).
        seed: the scene's seed; the same seed gives the same scene.
        config: sampler options.
        catalogue: object catalogue (default: the built-in classes plus the imported classes
            ``config.classes`` names).
        layout: table and workspace.
        renderers: where the occlusion check gets its renderer; pass the cache that renders the
            scene's images next (with ``result.model``) to make the GL resources once. Default: this
            thread's :class:`~samplehd.render.renderer_cache.MeshSharingRenderers`, one GL context
            kept from scene to scene.

    Returns:
        The accepted scene with rejection counts.

    Raises:
        SceneError: no acceptable scene within ``config.scene_attempts``.
    """
    config = config or SceneConfig()
    # Built-in classes, plus imported ones only where the config names them.
    cat = catalogue or catalogue_for(config.named_classes, config.catalogue)
    classes = _validate_classes(cat, config)
    rng = np.random.default_rng(seed)
    rejections: Counter[str] = Counter()
    ref_pixels = 640 * 360
    w, h = config.occlusion_resolution
    min_pixels = config.min_visible_pixels * (w * h) / ref_pixels
    for attempt in range(1, config.scene_attempts + 1):
        n = int(rng.integers(config.min_objects, config.max_objects + 1))
        objects: list[SceneObject] = []
        footprints: list[np.ndarray] = []
        redraws = 0
        while len(objects) < n and redraws < config.object_tries:
            inst = draw_instance(rng, cat, config, classes)
            facts = object_facts(inst, cat)
            spot = _place(rng, facts, footprints, config, layout, rejections)
            if spot is None:
                rejections["object_no_free_spot"] += 1
                redraws += 1
                continue
            xy, yaw, padded = spot
            z = layout.table_height - facts.bbox_min[2] + 0.001
            objects.append(SceneObject(inst, (float(xy[0]), float(xy[1]), float(z)), tuple(quat_from_yaw(yaw))))
            footprints.append(padded)
        if len(objects) < n:
            rejections["scene_table_full"] += 1
            continue
        camera = sample_camera(rng, config)
        settled = _settle(SceneSpec(index, seed, tuple(objects), camera), config, rejections)
        if settled is None:
            continue
        scene, model, data = settled
        if not _home_clear(model, data, len(objects)):
            rejections["robot_home_blocked"] += 1
            continue
        visible, alone = _visible_pixels(model, data, len(objects), config, renderers or _occlusion_renderers())
        occluded = [
            i for i in range(len(objects))
            if visible[i] < min_pixels or visible[i] < config.min_visible_fraction * max(alone[i], 1)
        ]
        if occluded:
            rejections["occluded"] += 1
            continue
        return SampleResult(scene, rejections, attempt, visible, model)
    raise SceneError(
        f"scene {index} (seed {seed}): no acceptable scene in {config.scene_attempts} attempts; "
        f"rejections {dict(rejections)}; try fewer objects or a smaller placement_margin"
    )


def _yaw(quat: tuple[float, float, float, float]) -> float:
    rot = quat_to_mat(np.asarray(quat, dtype=float))
    return math.atan2(float(rot[1, 0]), float(rot[0, 0]))


def add_objects(
    scene: SceneSpec,
    classes: Sequence[Sequence[str] | None],
    rng: np.random.Generator,
    config: SceneConfig | None = None,
    layout: TableLayout = LAYOUT,
    renderers: RendererCache | None = None,
) -> SceneSpec:
    """The scene with more objects, drawn and placed in free spots as :func:`sample_scene` places its own
    and settled; the scene's own objects keep their poses exactly and stay in view of the scene camera,
    and the new ones come after them (they may be partly hidden).

    Args:
        scene: a sampled (settled) scene.
        classes: one entry per added object: the classes it is drawn from (None: ``config``'s classes);
            an object without a free spot is redrawn up to ``config.object_tries`` times.
        rng: the only source of randomness.
        config: sampler options (catalogue, menus, placement margin, settling and visibility limits).
        layout: table and workspace.
        renderers: where the visibility check gets its renderer (default: as :func:`sample_scene`).

    Raises:
        SceneError: one line saying why: no free spot, the new objects do not settle, one of them
            touches an object of the scene, the arm at home touches one, or one hides an object of the scene.
    """
    config = config or SceneConfig()
    cat = catalogue_for(config.named_classes, config.catalogue)
    usable = _validate_classes(cat, config)
    rejections: Counter[str] = Counter()
    margin = config.placement_margin / 2
    footprints = [_footprint_corners(object_facts(o.instance, cat), np.asarray(o.pos[:2], dtype=float), _yaw(o.quat),
                                     margin) for o in scene.objects]
    objects = list(scene.objects)
    for names in classes:
        for _ in range(config.object_tries):  # a redrawn object may fit where a large one did not
            inst = draw_instance(rng, cat, config, list(names) if names else usable)
            facts = object_facts(inst, cat)
            spot = _place(rng, facts, footprints, config, layout, rejections)
            if spot is not None:
                break
        else:
            raise SceneError("no free spot for an added object")
        xy, yaw, padded = spot
        z = layout.table_height - facts.bbox_min[2] + 0.001
        objects.append(SceneObject(inst, (float(xy[0]), float(xy[1]), float(z)), tuple(quat_from_yaw(yaw))))
        footprints.append(padded)
    settled = _settle(SceneSpec(scene.index, scene.seed, tuple(objects), scene.camera), config, rejections)
    if settled is None:
        raise SceneError(f"the added objects do not settle ({', '.join(rejections)})")
    own = len(scene.objects)
    moved = [np.subtract(a.pos, b.pos) for a, b in zip(settled[0].objects, scene.objects, strict=False)]
    if any(np.max(np.abs(d)) > 0.002 for d in moved):  # settling from their own poses leaves them within µm
        raise SceneError("an added object touches an object of the scene")
    out = SceneSpec(scene.index, scene.seed, (*scene.objects, *settled[0].objects[own:]), scene.camera,
                    scene.lighting, scene.surfaces)
    model, data = compile_scene(out)
    if not _home_clear(model, data, len(out.objects)):
        raise SceneError("the arm at home touches an added object")
    visible, alone = _visible_pixels(model, data, len(out.objects), config, renderers or _occlusion_renderers())
    w, h = config.occlusion_resolution
    min_pixels = config.min_visible_pixels * (w * h) / (640 * 360)
    # The scene's own objects must stay in view; an added one may hide behind them.
    hidden = [i for i in range(own)
              if visible[i] < min_pixels or visible[i] < config.min_visible_fraction * max(alone[i], 1)]
    if hidden:
        raise SceneError(f"an added object hides {len(hidden)} of the scene's objects from the scene camera")
    return out

"""Objects in MuJoCo: compile, rest upright after a drop, realistic masses, containers hold things."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from samplehd.catalogue import (
    COLLISION_GROUP,
    VISUAL_GROUP,
    ObjectInstance,
    add_object,
    load_catalogue,
    object_facts,
)

# The procedural catalogue's own shapes (shop-vrb's are tested in test_shop_vrb.py).
PROCEDURAL = "procedural"

# Plausible mass ranges of the real objects at medium size, in their first menu material [kg].
MASS_RANGE = {
    "baking_tray": (0.3, 1.5),
    "bowl": (0.15, 0.6),
    "chopping_board": (0.3, 1.8),
    "food_box": (0.1, 1.0),
    "fork": (0.02, 0.12),
    "glass": (0.1, 0.4),
    "knife": (0.03, 0.3),
    "mug": (0.2, 0.45),
    "pan": (0.4, 2.5),
    "plate": (0.2, 0.7),
    "scissors": (0.02, 0.2),
    "soda_can": (0.25, 0.45),
    "spoon": (0.02, 0.1),
    "thermos": (0.15, 1.0),
    "wine_glass": (0.08, 0.35),
}


def _variants():
    cat = load_catalogue(name=PROCEDURAL)
    return [(c.name, v.name) for c in cat.classes.values() for v in c.variants.values()]


def _instance(cls: str, variant: str, size: str = "medium") -> ObjectInstance:
    menu = load_catalogue(name=PROCEDURAL).classes[cls].variants[variant].menu
    colour, material = menu.pairs[0]
    return ObjectInstance(cls, variant, colour, material, size if size in menu.size else menu.size[-1])


def _world(table: bool = True) -> mujoco.MjSpec:
    spec = mujoco.MjSpec()
    if table:  # a box, like the kitchen table top
        spec.worldbody.add_geom(name="table", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.6, 0.6, 0.02], pos=[0, 0, -0.02])
    else:
        spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2, 2, 0.1])
    return spec


def _up(quat: np.ndarray) -> float:
    """z component of the body's z axis."""
    w, x, y, z = quat
    return 1.0 - 2.0 * (x * x + y * y)


@pytest.mark.parametrize(("cls", "variant"), _variants())
def test_drop_comes_to_rest_upright(cls: str, variant: str) -> None:
    inst = _instance(cls, variant)
    spec = _world(table=True)
    yaw = 0.6
    add_object(spec, inst, "object_0", pos=(0.05, -0.03, 0.02), quat=(np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)))
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 1000)  # 2 s
    assert abs(data.qpos[2]) < 2e-3, "rests on the surface"
    assert np.linalg.norm(data.qpos[:2] - (0.05, -0.03)) < 5e-3, "does not slide or roll away"
    assert _up(data.qpos[3:7]) > 0.999, "stays upright"
    assert np.abs(data.qvel).max() < 0.02, "at rest"


def test_model_structure_and_mass() -> None:
    cat = load_catalogue(name=PROCEDURAL)
    spec = _world()
    instances = [_instance(c, v) for c, v in _variants()]
    for i, inst in enumerate(instances):
        add_object(spec, inst, f"object_{i}", pos=(i * 0.5, 0.0, 0.0))
    # two instances of one (class, variant, size) share their meshes
    add_object(spec, instances[0], "object_dup", pos=(0.0, 2.0, 0.0))
    model = spec.compile()
    assert model.nmesh == len({(i.class_name, i.variant, i.size) for i in instances}) + sum(
        sum(p.kind == "mesh" for p in __import__("samplehd").catalogue.instance_geometry(i).pieces)
        for i in {(i.class_name, i.variant, i.size): i for i in instances}.values()
    )
    for i, inst in enumerate(instances):
        body = model.body(f"object_{i}")
        facts = object_facts(inst, cat)
        assert body.mass[0] == pytest.approx(facts.mass, rel=1e-3)
        lo, hi = MASS_RANGE[inst.class_name]
        assert lo <= facts.mass <= hi, (inst, facts.mass)
        assert facts.weight == cat.weight_class(facts.mass)
        geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == body.id]
        visual = [g for g in geoms if model.geom_group[g] == VISUAL_GROUP]
        collision = [g for g in geoms if model.geom_group[g] == COLLISION_GROUP]
        assert len(visual) == 1 and len(collision) == facts.num_collision_pieces
        assert model.geom_contype[visual[0]] == 0 and model.geom_conaffinity[visual[0]] == 0
        for g in collision:
            assert model.geom_contype[g] == 1 and model.geom_condim[g] in (4, 6)
            assert model.geom_friction[g][0] == pytest.approx(facts.friction[0])
        assert model.jnt_type[model.body_jntadr[body.id]] == mujoco.mjtJoint.mjJNT_FREE


def test_glass_is_transparent_and_wood_is_textured() -> None:
    spec = _world()
    add_object(spec, ObjectInstance("wine_glass", "red", "transparent", "glass", "medium"), "a")
    add_object(spec, ObjectInstance("chopping_board", "rectangular", "brown", "wooden", "medium"), "b", pos=(0, 0.5, 0))
    model = spec.compile()
    glass = model.geom("a_visual")
    board = model.geom("b_visual")
    assert model.mat_rgba[glass.matid[0]][3] < 0.5
    assert model.mat_rgba[board.matid[0]][3] == 1.0
    texid = model.mat_texid[board.matid[0]][mujoco.mjtTextureRole.mjTEXROLE_RGB]
    assert texid >= 0 and model.tex_width[texid] > 1


@pytest.mark.parametrize(("cls", "variant"), [("bowl", "round"), ("bowl", "wide"), ("mug", "straight"),
                                              ("pan", "saucepan"), ("baking_tray", "square")])  # fmt: skip
def test_container_holds_a_small_object(cls: str, variant: str) -> None:
    inst = _instance(cls, variant)
    facts = object_facts(inst)
    spec = _world()
    add_object(spec, inst, "container")
    radius = 0.015
    ball = spec.worldbody.add_body(
        name="ball", pos=[0.01, 0.005, facts.opening.floor_height + facts.opening.depth + 0.04]
    )
    ball.add_freejoint()
    ball.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[radius, 0, 0], mass=0.03, condim=4)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 1500)
    pos = data.body("ball").xpos
    assert pos[2] < facts.opening.floor_height + facts.opening.depth, "the ball is below the rim"
    assert pos[2] > facts.opening.floor_height + radius - 3e-3, "the ball lies on the inner floor, not below"
    assert np.hypot(pos[0], pos[1]) < facts.opening.radius, "the ball stays inside"
    assert _up(data.body("container").xquat) > 0.999


@pytest.mark.parametrize(
    ("lower", "upper"),
    [
        (
            ("chopping_board", "rectangular", "brown", "wooden", "medium"),
            ("plate", "dinner", "white", "ceramic", "small"),
        ),
        (("plate", "dinner", "white", "ceramic", "medium"), ("plate", "dinner", "red", "plastic", "medium")),
        (("plate", "dinner", "white", "ceramic", "large"), ("bowl", "round", "blue", "plastic", "medium")),
        (("baking_tray", "rectangular", "black", "metal", "medium"), ("mug", "straight", "red", "ceramic", "medium")),
        (("food_box", "flat", "red", "plastic", "medium"), ("soda_can", "standard", "red", "metal", "small")),
    ],
)
def test_stacks_rest_on_the_top_surface(lower: tuple, upper: tuple) -> None:
    low, up = ObjectInstance(*lower), ObjectInstance(*upper)
    top = object_facts(low).top
    assert top.flat and object_facts(low).affordances.stackable_on and object_facts(up).affordances.stackable
    spec = _world()
    add_object(spec, low, "lower")
    add_object(spec, up, "upper", pos=(top.center[0], top.center[1], top.height + 0.005))
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 1000)
    assert data.body("upper").xpos[2] == pytest.approx(top.height, abs=3e-3)
    assert _up(data.body("upper").xquat) > 0.999 and _up(data.body("lower").xquat) > 0.999
    assert np.abs(data.qvel).max() < 0.02


@pytest.mark.slow
def test_every_class_variant_size_and_material_rests_upright() -> None:
    cat = load_catalogue(name=PROCEDURAL)
    for cls in cat.classes.values():
        for v in cls.variants.values():
            for size in v.menu.size:
                for material in v.menu.material:
                    colour = next(c for c, m in v.menu.pairs if m == material)
                    spec = _world()
                    add_object(spec, ObjectInstance(cls.name, v.name, colour, material, size), "o", pos=(0, 0, 0.01))
                    model = spec.compile()
                    data = mujoco.MjData(model)
                    mujoco.mj_step(model, data, 1000)
                    where = (cls.name, v.name, size, material)
                    assert abs(data.qpos[2]) < 2e-3 and _up(data.qpos[3:7]) > 0.999, where
                    assert np.abs(data.qvel).max() < 0.02, where


def test_duplicate_body_name_is_an_error() -> None:
    from samplehd.errors import AssetError

    spec = _world()
    inst = _instance("mug", "straight")
    add_object(spec, inst, "object_0")
    with pytest.raises(AssetError, match="object_0"):
        add_object(spec, inst, "object_0")


def test_add_object_is_deterministic() -> None:
    def build() -> mujoco.MjModel:
        spec = _world()
        for i, (c, v) in enumerate(_variants()):
            add_object(spec, _instance(c, v), f"object_{i}", pos=(i * 0.4, 0, 0))
        return spec.compile()

    a, b = build(), build()
    for field in (
        "mesh_vert",
        "mesh_face",
        "geom_size",
        "geom_pos",
        "body_mass",
        "body_inertia",
        "mat_rgba",
        "tex_data",
    ):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))

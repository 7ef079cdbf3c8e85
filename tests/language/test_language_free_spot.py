"""Room at a destination: the planner's oriented-rectangle free-spot test, on hand-made scenes."""

from __future__ import annotations

import math
from typing import Any

import pytest

from samplehd.errors import ConfigError
from samplehd.language.constraints import CONSTRAINTS, ConstraintContext
from samplehd.language.scene import parse_scene
from samplehd.world.free_spot import SpotSearch
from samplehd.world.layout import LAYOUT, table_parts_of

TABLE = LAYOUT.table_height


def _obj(name: str, xy: tuple[float, float], size: tuple[float, float], yaw: float = 0.0,
         new_fields: bool = True) -> dict[str, Any]:
    """An upright object with a size (x, y) [m] footprint centred on its origin, turned by yaw [deg]."""
    hx, hy = size[0] / 2, size[1] / 2
    c, s = abs(math.cos(math.radians(yaw))), abs(math.sin(math.radians(yaw)))
    ex, ey = c * hx + s * hy, s * hx + c * hy
    out: dict[str, Any] = {
        "name": name, "colour": "red", "material": "plastic", "size": "medium",
        "table_part": table_parts_of(xy), "3d_coords": [xy[0], xy[1], TABLE],
        "bbox": {"extents": [size[0], size[1], 0.05]},
    }
    if new_fields:
        out["rotation"] = yaw
        out["footprint_half_extents"] = [hx, hy]
        out["bbox"].update(min=[xy[0] - ex, xy[1] - ey, TABLE], max=[xy[0] + ex, xy[1] + ey, TABLE + 0.05])
    return out


def _holds(name: str, objects: list[dict[str, Any]], *params: Any) -> bool:
    ctx = ConstraintContext(parse_scene({"objects": objects}))
    return CONSTRAINTS[name].check(ctx, list(params))


def _cans(skip: tuple[float, float] | None = None) -> list[dict[str, Any]]:
    """Cans 13 cm apart over the right part: the gaps are too narrow for a plate, even turned."""
    grid = [(x, y) for x in (-0.12, 0.01, 0.14, 0.27) for y in (0.06, 0.19, 0.32)]
    return [_obj("can", xy, (0.06, 0.06)) for xy in grid if xy != skip]


def test_no_rectangle_spot_although_the_part_is_two_thirds_empty() -> None:
    cans = _cans()
    plate = _obj("plate", (0.10, -0.20), (0.12, 0.12))
    lo, hi = LAYOUT.part_bounds("right")
    covered = (len(cans) * 0.06**2 + 0.12**2) / float((hi - lo).prod())
    assert covered < 0.5  # the former area test let this through
    assert not _holds("room_in_part", [*cans, plate], len(cans), "right")
    assert _holds("room_in_part", [*cans, plate], len(cans), "left")


def test_one_plate_fits_the_hole_but_not_two() -> None:
    cans = _cans(skip=(0.01, 0.19))
    plates = [_obj("plate", (0.10, -0.20), (0.12, 0.12)), _obj("plate", (0.0, -0.30), (0.12, 0.12))]
    objects = [*cans, *plates]
    a, b = len(cans), len(cans) + 1
    assert _holds("room_in_part", objects, a, "right")
    assert _holds("room_in_part", objects, b, "right")
    assert not _holds("room_in_part", objects, a, b, "right")
    assert not _holds("room_in_part", objects, (a, b), "right")  # as an object set


def test_a_spot_too_small_to_be_found_reliably_is_no_spot() -> None:
    # cans 12 cm apart: the plate's hole is 1 cm wide each way, a few of the planner's samples
    cans = [_obj("can", (x, y), (0.06, 0.06)) for x in (-0.11, 0.01, 0.13, 0.25) for y in (0.07, 0.19, 0.31)
            if (x, y) != (0.01, 0.19)]
    objects = [*cans, _obj("plate", (0.10, -0.20), (0.12, 0.12))]
    scene = parse_scene({"objects": objects})
    strict = ConstraintContext(scene)
    lenient = ConstraintContext(scene, spot_search=SpotSearch.from_planner(min_hits=0.01))
    assert not CONSTRAINTS["room_in_part"].check(strict, [len(cans), "right"])
    assert CONSTRAINTS["room_in_part"].check(lenient, [len(cans), "right"])


def test_a_long_object_fits_only_turned() -> None:
    # boards along y leave 8 cm wide lanes: a 22 cm knife lying along x fits once turned 90 degrees
    boards = [_obj("board", (x, 0.215), (0.05, 0.36)) for x in (-0.12, 0.01, 0.14, 0.27)]
    knife = _obj("knife", (0.10, -0.20), (0.22, 0.02))
    box = _obj("box", (0.10, -0.20), (0.08, 0.08))
    assert _holds("room_in_part", [*boards, knife], 4, "right")
    assert not _holds("room_in_part", [*boards, box], 4, "right")


def test_a_long_object_beside_a_reference_turns_into_the_lane() -> None:
    plate = _obj("plate", (0.08, 0.0), (0.12, 0.12))
    boards = [_obj("board", (x, 0.27), (0.05, 0.40)) for x in (0.0, 0.16)]
    knife = _obj("knife", (0.10, -0.25), (0.22, 0.02))
    cup = _obj("cup", (0.10, -0.25), (0.08, 0.08))
    assert _holds("free_beside", [knife, plate, *boards], 0, 1, "right")
    assert not _holds("free_beside", [cup, plate, *boards], 0, 1, "right")


def test_free_beside_blocked_and_free() -> None:
    cup = _obj("cup", (0.10, -0.25), (0.08, 0.08))
    plate = _obj("plate", (0.08, 0.0), (0.12, 0.12))
    tray = _obj("tray", (0.08, 0.33), (0.40, 0.30))
    assert _holds("free_beside", [cup, plate], 0, 1, "right")
    assert not _holds("free_beside", [cup, plate, tray], 0, 1, "right")
    assert _holds("free_beside", [cup, plate, tray], 0, 1, "front")


def test_free_beside_needs_room_inside_the_workspace() -> None:
    cup = _obj("cup", (0.10, -0.25), (0.08, 0.08))
    plate = _obj("plate", (0.08, 0.36), (0.12, 0.12))  # at the right edge of the workspace
    assert not _holds("free_beside", [cup, plate], 0, 1, "right")
    assert _holds("free_beside", [cup, plate], 0, 1, "left")


def test_remove_frees_the_cleared_part_and_fills_the_opposite() -> None:
    cans = _cans(skip=(0.01, 0.19))
    plate = _obj("plate", (0.10, -0.20), (0.12, 0.12))
    assert _holds("room_opposite", [*cans, plate], "left")
    second = _obj("plate", (0.0, -0.30), (0.12, 0.12))
    assert not _holds("room_opposite", [*cans, plate, second], "left")


def test_an_object_of_the_footprint_centre_off_its_origin() -> None:
    # a pan whose handle sticks out: its footprint centre is 8 cm off its origin along x
    boards = [_obj("board", (x, 0.215), (0.05, 0.36)) for x in (-0.12, 0.01, 0.14, 0.27)]
    pan = _obj("pan", (0.10, -0.20), (0.22, 0.02))
    pan["3d_coords"][0] -= 0.08
    scene = parse_scene({"objects": [*boards, pan]})
    obj = scene.objects[4]
    assert obj.footprint_centre == pytest.approx((0.10, -0.20))
    assert obj.coords[0] == pytest.approx(0.02)
    assert CONSTRAINTS["room_in_part"].check(ConstraintContext(scene), [4, "right"])


def test_old_scene_files_without_the_rectangle_fields() -> None:
    old = [_obj("can", (x, y), (0.06, 0.06), new_fields=False)
           for x in (-0.12, 0.01, 0.14, 0.27) for y in (0.06, 0.19, 0.32)]
    plate = _obj("plate", (0.10, -0.20), (0.12, 0.12), new_fields=False)
    scene = parse_scene({"objects": [*old, plate]})
    can = scene.objects[0]
    assert can.rotation is None and can.bbox_min is None and can.footprint_half_extents is None
    assert can.yaw == 0.0
    assert can.footprint_centre == (can.coords[0], can.coords[1])
    assert can.footprint_half == (0.03, 0.03)
    assert set(can.to_dict()) & {"rotation", "footprint_half_extents"} == set()
    assert set(can.to_dict()["bbox"]) == {"extents"}
    assert not _holds("room_in_part", [*old, plate], len(old), "right")
    holed = [o for o in old if o["3d_coords"][:2] != [0.01, 0.19]]
    assert _holds("room_in_part", [*holed, plate], len(holed), "right")


def test_spot_search_settings_are_checked() -> None:
    with pytest.raises(ConfigError, match="step"):
        SpotSearch(0.02, 0.03, 0.03, 400, step=0.0)
    with pytest.raises(ConfigError, match="min_hits"):
        SpotSearch(0.02, 0.03, 0.03, 400, min_hits=-1.0)
    search = SpotSearch.from_planner()
    assert (search.spot_margin, search.part_margin, search.samples) == (0.02, 0.03, 400)


def test_rect_overlap_broadcasts_like_pairwise_calls() -> None:
    import numpy as np

    from samplehd.world.free_spot import rect_overlap

    def rot(yaw: float) -> np.ndarray:
        return np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])

    eye = np.eye(2)
    half = np.array([0.05, 0.01])
    # 2 cm apart edge to edge: clear with a smaller margin, overlapping with a larger one
    assert not rect_overlap(np.zeros(2), eye, half, np.array([0.12, 0.0]), eye, half, 0.0199)
    assert rect_overlap(np.zeros(2), eye, half, np.array([0.12, 0.0]), eye, half, 0.0201)
    # a bar that crosses another one clears it once turned 90 degrees (1 cm apart)
    assert rect_overlap(np.zeros(2), eye, half, np.array([0.07, 0.0]), eye, half, 0.0)
    assert not rect_overlap(np.zeros(2), eye, half, np.array([0.07, 0.0]), rot(math.pi / 2), half, 0.0099)
    assert rect_overlap(np.zeros(2), eye, half, np.array([0.07, 0.0]), rot(math.pi / 2), half, 0.0101)
    rng = np.random.default_rng(0)
    c1, c2 = rng.uniform(-0.2, 0.2, (50, 2)), rng.uniform(-0.2, 0.2, (50, 2))
    r1, r2 = rot(0.3)[None].repeat(50, 0), np.stack([rot(y) for y in rng.uniform(-3, 3, 50)])
    h1, h2 = rng.uniform(0.01, 0.1, (50, 2)), rng.uniform(0.01, 0.1, (50, 2))
    many = rect_overlap(c1, r1, h1, c2, r2, h2, 0.02)
    assert many.shape == (50,) and 0 < many.sum() < 50
    assert many.tolist() == [bool(rect_overlap(*pair, 0.02)) for pair in zip(c1, r1, h1, c2, r2, h2, strict=True)]
    one_rotation = rect_overlap(c1, rot(0.3), h1, c2, r2, h2, 0.02)
    assert one_rotation.tolist() == many.tolist()


@pytest.fixture(scope="module")
def sampled_scene() -> tuple[Any, ...]:
    """A scene from the real sampler, compiled, with its annotation (the language stage's input)."""
    from samplehd.catalogue import object_facts
    from samplehd.motion.assist import compile_scene_with_assist
    from samplehd.scene.annotate import annotate_scene
    from samplehd.scene.sampler import sample_scene
    from samplehd.world.bodies import SceneBodies

    spec = sample_scene(8, 120008).scene
    model, data = compile_scene_with_assist(spec)
    facts = [object_facts(o.instance) for o in spec.objects]
    annotation = annotate_scene(spec, model, data, 64, 36)
    return data, SceneBodies(model, len(facts)), facts, annotation


def test_accepted_destinations_are_found_by_the_planner(sampled_scene: tuple[Any, ...]) -> None:
    import numpy as np

    from samplehd.motion.planner import destination_candidates
    from samplehd.tasks.task import Task
    from samplehd.world.planner_config import PlannerConfig

    data, bodies, facts, annotation = sampled_scene
    scene = parse_scene(annotation)
    ctx = ConstraintContext(scene)
    # five times the planner's samples, its first try only (no relaxed margins): a spot the
    # language stage accepts holds at least 10 of them on average
    config = PlannerConfig(spot_samples=5 * PlannerConfig().spot_samples)
    accepted = rejected = 0
    for i, obj in enumerate(scene.objects):
        tasks = [(Task("place", (i,), part=p), [i, p]) for p in ("left", "right", "front", "back")
                 if p not in obj.table_part]
        tasks += [(Task("place_relative", (i,), reference=j, direction=rel), [i, j, rel])
                  for j in range(len(scene.objects)) if j != i for rel in ("left", "right", "front", "behind")]
        for task, params in tasks:
            name = "room_in_part" if task.family == "place" else "free_beside"
            if not CONSTRAINTS[name].check(ctx, params):
                rejected += 1
                continue
            accepted += 1
            spots = destination_candidates(data, bodies, facts, i, task, np.random.default_rng(0), config,
                                           directions=annotation["directions"], relaxed=True)
            assert spots, (task, name)
    assert accepted >= 10 and rejected >= 3


def test_reach_annulus_from_squares_answers_as_the_hypotenuse() -> None:
    """The annulus test on squared distances decides every point as ``hypot`` and the bounds do,
    including points within a few units in the last place of either bound."""
    import numpy as np

    from samplehd.world.free_spot import _in_annulus

    rng = np.random.default_rng(4)
    near = []
    for bound in (LAYOUT.reach_min, LAYOUT.reach_max):
        r = np.array([bound])
        for _ in range(6):  # the bound and the numbers a few units in the last place either side of it
            near += [r, 2 * bound - r]
            r = np.nextafter(r, np.inf)
    radii = np.concatenate([rng.uniform(0.0, 1.0, 1000), np.repeat(np.concatenate(near), 50)])
    angles = rng.uniform(0, 2 * np.pi, len(radii))
    x, y = radii * np.cos(angles), radii * np.sin(angles)
    reach = np.hypot(x, y)
    expected = (reach >= LAYOUT.reach_min) & (reach <= LAYOUT.reach_max)
    assert expected.any() and not expected.all()
    np.testing.assert_array_equal(_in_annulus(x[:, None], y[:, None], (len(x), 1), LAYOUT)[:, 0], expected)
    # broadcast over a grid of rows and columns, as the part grids use it
    gx, gy = x[:60, None], y[None, :70]
    reach = np.hypot(gx, gy)
    np.testing.assert_array_equal(_in_annulus(gx, gy, (60, 70), LAYOUT),
                                  (reach >= LAYOUT.reach_min) & (reach <= LAYOUT.reach_max))


def test_best_first_is_a_prefix_of_the_stable_order_long_enough() -> None:
    """The best spots come as the start of the stable argsort, ties included, at least as many as asked
    for, whether the bound found among every 8th key holds enough keys or not."""
    import numpy as np

    from samplehd.world.free_spot import _best_first

    rng = np.random.default_rng(5)
    for n, needed, levels in ((4910, 221, 0), (3000, 2000, 0), (500, 400, 0), (2000, 150, 7), (64, 63, 3), (40, 50, 0)):
        key = rng.normal(size=n) if not levels else rng.integers(0, levels, n).astype(float)  # many ties
        if n == 3000:
            key[::8] = -10.0  # every 8th key the smallest: the bound among them holds too few, the fallback runs
        got = _best_first(key, needed)
        order = np.argsort(key, kind="stable")
        assert len(got) >= min(needed, n)
        np.testing.assert_array_equal(got, order[: len(got)])


def test_counted_room_and_marked_runs_match_the_spots_one_by_one() -> None:
    """Runs of columns marked on the spots, and free spots counted per turn outside each rectangle's runs
    with their samples summed from the counts, give what a spot-by-spot mask and sum give."""
    import numpy as np

    from samplehd.world.free_spot import _counts_outside, _covered

    objects = [_obj("mug", (0.05, -0.25), (0.08, 0.1), 30.0), _obj("plate", (0.15, -0.15), (0.2, 0.2)),
               _obj("bowl", (-0.05, 0.2), (0.14, 0.14))]
    scene = parse_scene({"objects": objects})
    spots_of = ConstraintContext(scene).free_spots()
    spots = spots_of._part_spots(0, "left")
    nt, nr, nc = len(spots.turns), len(spots.grid.u), len(spots.grid.v)
    rng = np.random.default_rng(6)
    col = np.arange(nc)
    for _ in range(20):
        first = rng.integers(0, nc + 1, (4, nt, nr)).astype(float)
        last = rng.integers(-1, nc, (4, nt, nr)).astype(float)
        last[:, :, ::5] = nc - 1  # runs that end their row
        runs = (col >= first[..., None]) & (col <= last[..., None])  # (R, t, r, c)
        np.testing.assert_array_equal(_covered(spots, first, last), runs.any(axis=0).ravel())
        free = rng.random(nt * nr * nc) < 0.7
        counts = _counts_outside(spots, free, first, last)
        for i in range(len(first)):
            left = free & ~runs[i].ravel()
            np.testing.assert_array_equal(counts[i], left.reshape(nt, -1).sum(axis=1))
            assert spots_of._hits_counted(spots, counts[i].tolist()) == spots_of._hits(spots, left)

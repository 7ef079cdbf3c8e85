"""Room at a destination: the planner's oriented-rectangle free-spot test, on hand-made scenes."""

from __future__ import annotations

import math
from typing import Any

import pytest

from samplehd.errors import ConfigError
from samplehd.fixedmath import matmul
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
    keep = np.ones((1, len(x), 1), bool)
    _in_annulus(keep, x[None, :, None], y[None, :, None], LAYOUT)
    np.testing.assert_array_equal(keep[0, :, 0], expected)
    # broadcast over a grid of rows and columns, as the part grids use it, on the spots kept only
    gx, gy = x[None, :60, None], y[None, None, :70]
    reach = np.hypot(gx, gy)
    keep = rng.random((1, 60, 70)) < 0.8
    want = keep & (reach >= LAYOUT.reach_min) & (reach <= LAYOUT.reach_max)
    _in_annulus(keep, gx, gy, LAYOUT)
    np.testing.assert_array_equal(keep, want)


def test_best_spots_are_a_prefix_of_the_stable_order_long_enough() -> None:
    """The best spots come as the start of the stable argsort of their scores, ties included, at least
    as many as asked for; the gap to the nearest neighbour (on a part grid from its rows and columns, past
    a reference from the centres), the cap and the shortlist's running sum are numpy's numbers."""
    import numpy as np

    from samplehd.world.spot_kernels import best_spots

    rng = np.random.default_rng(5)
    objects = [_obj("mug", (0.05, -0.25), (0.08, 0.1), 30.0), _obj("plate", (0.15, -0.15), (0.2, 0.2)),
               _obj("bowl", (-0.05, 0.2), (0.14, 0.14))]
    fs = ConstraintContext(parse_scene({"objects": objects})).free_spots()
    for spots in (fs._part_spots(0, "right"), fs._beside_spots(0, 2, (1.0, 0.0))):
        assert spots is not None
        g, m = spots.grid, len(spots.keep)
        for needed, levels, n_near in ((221, 0, 2), (2000, 0, 3), (50, 7, 1), (10**6, 3, 0), (400, 0, 2)):
            free = spots.keep & (rng.random(m) < 0.7)
            score = rng.normal(size=m) if not levels else rng.integers(0, levels, m).astype(float)  # many ties
            neighbours = rng.uniform(-0.4, 0.4, (n_near, 2))
            shares = rng.uniform(0.0, 0.05, m)
            # the score given whole (no reach or turn term)
            ranked, count = best_spots(free, g.on_axes, g.u, g.v, spots.centre, neighbours, score, np.zeros((1, 1, 1)),
                                       np.zeros((1, 1, 1)), spots.turns, spots.turn, np.zeros(3), shares, 0.25,
                                       needed, 12.0)
            idx = np.flatnonzero(free)
            gap = np.full(len(idx), np.inf)
            if n_near:
                gap = np.linalg.norm(spots.centre[idx, None, :] - neighbours[None], axis=-1).min(axis=1)
            order = idx[np.argsort(-np.minimum(gap, 0.25) + score[idx], kind="stable")]
            assert len(ranked) >= min(needed, len(idx))
            np.testing.assert_array_equal(ranked, order[: len(ranked)])
            want = max(1, int(np.searchsorted(np.cumsum(shares[ranked]), 12.0, side="right")))
            assert count == want


def test_counted_room_and_marked_runs_match_the_spots_one_by_one() -> None:
    """Runs of columns marked on the spots, and free spots counted per turn outside each rectangle's runs
    with their samples summed from the counts, give what a spot-by-spot mask and sum give."""
    import numpy as np

    from samplehd.world.spot_kernels import counts_outside, uncovered, uncovered_weight

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
        free = rng.random(nt * nr * nc) < 0.7
        use = np.array([True, False, True, True])
        np.testing.assert_array_equal(uncovered(free, first, last, use, nc), free & ~runs[use].any(axis=0).ravel())
        left = free & ~runs[use].any(axis=0).ravel()
        total, found = uncovered_weight(free, first, last, use, nc, spots.weight)
        assert found == left.any() and abs(total - spots.weight[left].sum()) < 1e-12
        counts = counts_outside(free, first, last, nc)
        for i in range(len(first)):
            left = free & ~runs[i].ravel()
            np.testing.assert_array_equal(counts[i], left.reshape(nt, -1).sum(axis=1))
            assert spots_of._hits_counted(spots, counts[i].tolist()) == spots_of._hits(spots, left)


def _runs_by_arrays(q0, along, across, lim, u, lo, width, count):  # type: ignore[no-untyped-def]
    """The runs of columns computed on whole arrays, the four slabs' bounds per row then their
    intersection: the reference the compiled loop must equal bit for bit."""
    import numpy as np

    q = q0[..., None] - along[..., None] * u  # (R, t, 4, r)
    lim, across = lim[..., None], across[..., None]
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = (q - lim) / across, (q + lim) / across
    inside = np.abs(q) <= lim
    low = np.where(across == 0, np.where(inside, -np.inf, np.inf), np.minimum(a, b)).max(axis=2)
    high = np.where(across == 0, np.where(inside, np.inf, -np.inf), np.maximum(a, b)).min(axis=2)
    first = np.clip(np.ceil((low - lo) / width - 0.5), 0, count)
    last = np.clip(np.floor((high - lo) / width - 0.5), -1, count - 1)
    return first, last


def _axes_reach_by_arrays(rt, half, r, h, grow):  # type: ignore[no-untyped-def]
    """The separating-axis test's four axes of an object turned by each of ``rt`` (t, 2, 2) against each
    rectangle (rotations r (R, 2, 2), half sizes h (R, 2)) and how far apart the centres may be along
    each: (R, t, 4, 2) and (R, t, 4), by samplehd.fixedmath's products (the compiled loop's reference)."""
    import numpy as np

    axes = np.empty((len(r), len(rt), 4, 2))
    axes[:, :, :2] = np.swapaxes(rt, -1, -2)
    axes[:, :, 2:] = np.swapaxes(r, -1, -2)[:, None]
    reach = (matmul(np.abs(matmul(axes, rt[None])), half + grow)
             + matmul(np.abs(matmul(axes, r[:, None])), (h + grow)[:, None, :, None])[..., 0])
    return axes, reach


def test_compiled_runs_equal_the_array_computation_bit_for_bit() -> None:
    """The compiled runs of columns equal the whole-array computation exactly, on the spots of real
    scenes (part grids and grids past a reference, along axes and not) against every object and against
    the spots themselves, from the poses (samplehd.fixedmath's matrix products, whose rounding the loop follows) as
    from given projections; rows outside those asked for are left without a run; and on random slabs
    including axes that ignore the columns."""
    import numpy as np

    from samplehd.bench.language import _scenes
    from samplehd.world.spot_kernels import column_runs, rect_runs

    checked = 0
    for n in (5, 12):
        for scene in _scenes(n, 2, 4):
            fs = ConstraintContext(scene).free_spots()
            grow = fs.search.spot_margin / 2
            for k in range(len(scene.objects)):
                grids = [fs._part_spots(k, part) for part in ("left", "front")]
                grids += [s for s in (fs._beside_spots(k, (k + 1) % n, d) for d in ((1.0, 0.0), (0.6, -0.8)))
                          if s is not None]
                for spots in grids:
                    g = spots.grid
                    poses = [(fs.rot, fs.half, fs.centre)]
                    # the object's own spots as rectangles: the turns of another object put there
                    at = np.arange(0, len(spots.turn), 97)
                    poses.append((spots.rots[spots.turn[at]], np.broadcast_to(fs.half[(k + 1) % n], (len(at), 2)),
                                  spots.centre[at]))
                    for rots, halves, centres in poses:
                        axes, reach = _axes_reach_by_arrays(spots.rots, fs.half[k], rots, halves, grow)
                        q0 = np.einsum("rtad,rtd->rta", axes, centres[:, None, :] - g.base[None])
                        along, across = matmul(axes, g.axes[0]), matmul(axes, g.axes[1])
                        args = (q0, along, across, reach, g.u)
                        want = _runs_by_arrays(*args, g.lo, g.width, len(g.v))
                        got = column_runs(*args, 0, len(g.u), float(g.lo), float(g.width), len(g.v))
                        np.testing.assert_array_equal(got[0], want[0])
                        np.testing.assert_array_equal(got[1], want[1])
                        index = np.arange(len(rots))
                        rh, ch = np.ascontiguousarray(rots), np.ascontiguousarray(halves)
                        posed = rect_runs(spots.rots, fs.half[k], rh, ch, np.ascontiguousarray(centres), index, grow,
                                          g.base, g.axes, g.u, 0, len(g.u), float(g.lo), float(g.width), len(g.v))
                        np.testing.assert_array_equal(posed[0], want[0])
                        np.testing.assert_array_equal(posed[1], want[1])
                        r0, r1 = len(g.u) // 3, len(g.u) // 2
                        part = column_runs(*args, r0, r1, float(g.lo), float(g.width), len(g.v))
                        np.testing.assert_array_equal(part[0][:, :, r0:r1], want[0][:, :, r0:r1])
                        assert (part[0][:, :, :r0] == len(g.v)).all() and (part[1][:, :, r1:] == -1).all()
                        some = index[::2]
                        part = rect_runs(spots.rots, fs.half[k], rh, ch, np.ascontiguousarray(centres), some, grow,
                                         g.base, g.axes, g.u, r0, r1, float(g.lo), float(g.width), len(g.v))
                        np.testing.assert_array_equal(part[1][:, :, r0:r1], want[1][some][:, :, r0:r1])
                        assert (part[0][:, :, :r0] == len(g.v)).all() and (part[1][:, :, r1:] == -1).all()
                        checked += int(((want[0] <= want[1]) & (want[1] < len(g.v) - 1)).sum())
    assert checked > 1000  # runs ending inside the rows, not only empty or whole rows
    rng = np.random.default_rng(12)
    for _ in range(20):  # random poses and grid directions: every rounding of the products exercised
        turn = rng.uniform(-np.pi, np.pi, (5, 1, 1))
        rt = np.concatenate([np.cos(turn), -np.sin(turn), np.sin(turn), np.cos(turn)], -1).reshape(5, 2, 2)
        yaw = rng.uniform(-np.pi, np.pi, (30, 1, 1))
        rots = np.concatenate([np.cos(yaw), -np.sin(yaw), np.sin(yaw), np.cos(yaw)], -1).reshape(30, 2, 2)
        half, halves, centres = rng.uniform(0.01, 0.2, 2), rng.uniform(0.01, 0.2, (30, 2)), rng.normal(size=(30, 2))
        ang = rng.uniform(-np.pi, np.pi)
        grid_axes = np.array([[np.cos(ang), np.sin(ang)], [-np.sin(ang), np.cos(ang)]])
        base, u = rng.normal(size=(5, 2)) * 0.2, np.linspace(-0.4, 0.4, 60)
        axes, reach = _axes_reach_by_arrays(rt, half, rots, halves, 0.01)
        q0 = np.einsum("rtad,rtd->rta", axes, centres[:, None, :] - base[None])
        want = _runs_by_arrays(q0, matmul(axes, grid_axes[0]), matmul(axes, grid_axes[1]), reach, u, -0.3, 0.01,
                               60)
        got = rect_runs(rt, half, rots, halves, centres, np.arange(30), 0.01, base, grid_axes, u, 0, len(u), -0.3,
                        0.01, 60)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])
    rng = np.random.default_rng(8)
    q0, along, across = rng.normal(size=(3, 6, 5, 4)) * 0.3
    across[:, :, ::2] = 0.0  # axes that ignore the column
    lim, u = rng.random((6, 5, 4)) * 0.2, np.linspace(-0.3, 0.3, 40)
    want = _runs_by_arrays(q0, along, across, lim, u, -0.25, 0.01, 50)
    got = column_runs(q0, along, across, lim, u, 0, len(u), -0.25, 0.01, 50)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
    assert (want[0] <= want[1]).any() and (want[0] > want[1]).any()


def test_compiled_near_objects_and_farthest_picks_equal_the_array_computation() -> None:
    """The objects near a grid's kept spots and the farthest-point picks equal their whole-array
    computation exactly: on real scenes' grids, and on random points with ties and twins."""
    import numpy as np

    from samplehd.bench.language import _scenes
    from samplehd.world.spot_kernels import farthest_picks, near_objects

    some = 0
    for scene in _scenes(12, 2, 5):
        fs = ConstraintContext(scene).free_spots()
        for k in range(len(scene.objects)):
            for spots in [fs._part_spots(k, part) for part in ("right", "back")] + [
                    s for s in (fs._beside_spots(k, (k + 3) % 12, (0.0, -1.0)),) if s is not None]:
                g, nt = spots.grid, len(spots.turns)
                kept = spots.keep.reshape(nt, len(g.u), len(g.v)).any(axis=0)
                rows, cols = np.flatnonzero(kept.any(axis=1)), np.flatnonzero(kept.any(axis=0))
                near, r0, r1 = near_objects(spots.keep, nt, g.base, g.axes, g.u, g.v, fs.centre, fs._radius, k)
                if not len(rows):
                    assert (len(near), r0, r1) == (0, 0, 0)
                    continue
                corners = (g.base[:, None, None, :] + g.u[[rows[0], rows[-1]]][None, :, None, None] * g.axes[0]
                           + g.v[[cols[0], cols[-1]]][None, None, :, None] * g.axes[1]).reshape(-1, 2)
                lo, hi = corners.min(axis=0), corners.max(axis=0)
                grow = (fs._radius[k] + fs._radius + 1e-9)[:, None]
                close = np.abs(fs.centre - (lo + hi) / 2) <= (hi - lo) / 2 + grow
                want = np.flatnonzero(close[:, 0] & close[:, 1])
                np.testing.assert_array_equal(near, want[want != k])
                assert (r0, r1) == (rows[0], rows[-1] + 1)
                some += 0 < len(near) < len(scene.objects) - 1
    assert some > 5  # some objects near, some not

    def norms(rows: np.ndarray) -> np.ndarray:
        return np.sqrt(np.add.reduce(rows * rows, axis=1))

    rng = np.random.default_rng(9)
    for n in (1, 2, 7, 40, 300):
        where = rng.normal(size=(n, 3)) * 0.1
        where[n // 2 :: 3] = where[0]  # twins of the first
        where[:, 2] = np.round(where[:, 2], 1)  # ties
        picks, dist = [0], norms(where - where[0])
        while len(picks) < 6 and dist.max() > 0:
            picks.append(int(dist.argmax()))
            dist = np.minimum(dist, norms(where - where[picks[-1]]))
        np.testing.assert_array_equal(farthest_picks(where, 6), picks)


def test_compiled_part_tests_and_annulus_equal_the_array_computation() -> None:
    """A part's spot tests (bounds, table, reach annulus) from the compiled loops equal the whole-array
    computation, the annulus decided on the distance itself where the squared one is too near a bound."""
    import numpy as np

    from samplehd.world.free_spot import _in_annulus
    from samplehd.world.layout import TableLayout
    from samplehd.world.spot_kernels import part_keep

    layout = TableLayout()
    rng = np.random.default_rng(10)
    table, base = np.asarray(layout.table_size) / 2 - 0.02, np.asarray(layout.robot_base)
    for _ in range(10):
        u, v = np.sort(rng.uniform(-0.8, 0.8, 30)), np.sort(rng.uniform(-0.6, 0.6, 25))
        offsets, half = rng.normal(size=(4, 2)) * 0.03, rng.uniform(0.01, 0.1, (4, 2))
        lo, hi = np.array([-0.5, -0.4]), np.array([0.4, 0.3])
        keep, rel_x, rel_y = part_keep(u, v, offsets, half, lo, hi, table, base)
        ok = []
        for a, coords in enumerate((u, v)):
            o = coords[None] - offsets[:, a, None]
            ok.append((o >= lo[a]) & (o <= hi[a]) & (coords[None] - half[:, a, None] >= -table[a])
                      & (coords[None] + half[:, a, None] <= table[a]))
            np.testing.assert_array_equal((rel_x[:, :, 0], rel_y[:, 0, :])[a], o - base[a])
        want = ok[0][:, :, None] & ok[1][:, None, :]
        np.testing.assert_array_equal(keep, want)
        # points on the annulus' bounds and a rounding away from them: the distance itself decides
        ang = rng.uniform(-np.pi, np.pi, (4, 30, 25))
        radius = rng.choice([layout.reach_min, layout.reach_max], ang.shape) * (1 + rng.choice([-1, 0, 1], ang.shape)
                                                                                 * rng.choice([1e-16, 1e-12, 1e-3],
                                                                                              ang.shape))
        rx, ry = radius * np.cos(ang), radius * np.sin(ang)
        got = want.copy()
        _in_annulus(got, rx, ry, layout)
        reach = np.hypot(rx, ry)
        np.testing.assert_array_equal(got, want & (reach >= layout.reach_min) & (reach <= layout.reach_max))
        got = want.copy()
        _in_annulus(got, rel_x, rel_y, layout)  # broadcast offsets
        reach = np.hypot(rel_x, rel_y)
        np.testing.assert_array_equal(got, want & (reach >= layout.reach_min) & (reach <= layout.reach_max))


def _beside_tests_by_arrays(fs, x, ref, direction):  # type: ignore[no-untyped-def]
    """The tests of object x's spots past object ref that involve no other object and no distance from the
    base, on whole arrays (each coordinate on the axes it depends on): the compiled loop's reference.
    Returns keep (t, r, c), the footprint centres (m, 2) and the origins less the base, x and y."""
    import numpy as np

    from samplehd.world import placement
    from samplehd.world.free_spot import _flat_xy

    d, lateral, _, dists, lats, *_ = fs._beside_grid(direction)
    ext_ref, ext_x = fs._extent_along(ref, direction, False), fs._extent_along(x, direction, True)
    _, offsets, half = fs._turned(x)
    along = ((ext_ref + ext_x) + fs.search.spot_margin)[:, None, None] + dists[None, :, None]
    across = lats[None, None, :]
    lo, hi = fs._workspace
    centre, origin, rel, tests = [], [], [], []
    for a in range(2):
        c = fs.centre[ref, a]
        if d[a] != 0:
            c = c + along * d[a]
        if lateral[a] != 0:
            c = c + across * lateral[a]
        o = c - offsets[:, a, None, None]
        h = half[:, a, None, None]
        tests.append((o >= lo[a]) & (o <= hi[a]) & (c - h >= -fs._table[a]) & (c + h <= fs._table[a]))
        centre.append(c)
        origin.append(o)
        rel.append(o - fs._base[a])
    shape = (len(fs.turns), len(dists), len(lats))
    keep = np.broadcast_to(tests[0] & tests[1], shape).copy()
    need = fs.search.relation_gap + placement.BESIDE_NEED
    if d[0] == 0 or d[1] == 0:
        a = 0 if d[0] != 0 else 1
        keep &= (origin[a] - fs.origin[ref, a]) * d[a] >= need
    else:
        keep &= (matmul(_flat_xy(origin, shape) - fs.origin[ref], d) >= need).reshape(shape)
    return keep, _flat_xy(centre, shape), [np.broadcast_to(r, shape) for r in rel]


def test_compiled_beside_tests_equal_the_array_computation() -> None:
    """The tests of the spots past a reference from the compiled loop equal the whole-array computation
    exactly (spots kept, centres, origins), along the axes and slanted, on real scenes; and the spots past
    a reference are those of that computation with the reach annulus."""
    import numpy as np

    from samplehd.bench.language import _scenes
    from samplehd.world import placement
    from samplehd.world.free_spot import _flat_xy, _in_annulus
    from samplehd.world.spot_kernels import beside_keep

    kept = 0
    for n in (5, 12):
        for scene in _scenes(n, 2, 6):
            fs = ConstraintContext(scene).free_spots()
            for x in range(n):
                ref = (x + 1) % n
                for direction in ((1.0, 0.0), (0.0, -1.0), (0.6, -0.8), (-0.28, 0.96)):
                    want, centre, (rel_x, rel_y) = _beside_tests_by_arrays(fs, x, ref, direction)
                    d, lateral, _, dists, lats, *_ = fs._beside_grid(direction)
                    ext = fs._extent_along(ref, direction, False) + fs._extent_along(x, direction, True)
                    _, offsets, half = fs._turned(x)
                    lo, hi = fs._workspace
                    weight = fs._beside_grid(direction)[8]
                    got = beside_keep(d, lateral, dists, lats, ext + fs.search.spot_margin, fs.centre[ref],
                                      fs.origin[ref], offsets, half, lo, hi, fs._table, fs._base,
                                      fs.search.relation_gap + placement.BESIDE_NEED, weight)
                    np.testing.assert_array_equal(got[0], want)
                    np.testing.assert_array_equal(_flat_xy(got[1:3], want.shape), centre)
                    np.testing.assert_array_equal(np.broadcast_to(got[3], want.shape), rel_x)
                    np.testing.assert_array_equal(np.broadcast_to(got[4], want.shape), rel_y)
                    assert abs(got[5] - float(weight @ want.ravel())) < 1e-13
                    kept += int(want.sum())
                    spots = fs._beside_spots(x, ref, direction)
                    if spots is not None:
                        _in_annulus(want, rel_x, rel_y, fs.layout)
                        np.testing.assert_array_equal(spots.keep, want.ravel())
                        np.testing.assert_array_equal(spots.centre, centre)
    assert kept > 1000


def test_sums_of_weights_decide_as_numpy_sums_them() -> None:
    """Whether enough samples land on a set of spots, decided from a sum taken in another order where it is
    far from the bound, equals the comparison of numpy's sum: on real spots, on random sets and on sets
    whose sum lies on the bound or a rounding away from it."""
    import numpy as np

    from samplehd.bench.language import _scenes

    rng = np.random.default_rng(13)
    near = 0
    for scene in _scenes(8, 2, 7):
        fs = ConstraintContext(scene).free_spots()
        for spots in [fs._part_spots(k, part) for k in range(3) for part in ("left", "back")]:
            w = spots.weight
            for _ in range(30):
                mask = rng.random(len(w)) < rng.choice([0.001, 0.01, 0.1, 0.5])
                exact = fs._hits(spots, mask)
                for bound in (exact, np.nextafter(exact, 0), np.nextafter(exact, 1), fs.search.min_hits,
                              exact * (1 + 1e-13), exact * (1 - 1e-13)):
                    assert fs._hits_below(spots, mask, bound) == (exact < bound, bool(mask.any()))
                    near += abs(exact - bound) < 1e-9
    assert near > 100


def test_compiled_scores_equal_the_array_computation() -> None:
    """The planner's score terms that do not depend on the neighbours, computed per spot in the compiled
    loop, equal the whole-array expression exactly, on parts' spots and on spots past a reference."""
    import numpy as np

    from samplehd.bench.language import _scenes
    from samplehd.world import placement

    checked = 0
    for scene in _scenes(6, 2, 8):
        fs = ConstraintContext(scene).free_spots()
        for k in range(6):
            grids = [fs._part_spots(k, part) for part in ("left", "right", "front", "back")]
            grids += [s for s in (fs._beside_spots(k, (k + 1) % 6, d) for d in ((0.0, 1.0), (0.6, -0.8)))
                      if s is not None]
            for spots in grids:
                score, rel_x, rel_y = spots.score_terms
                reach = np.broadcast_to(np.hypot(rel_x, rel_y), (len(spots.turns), len(spots.grid.u),
                                                                 len(spots.grid.v))).ravel()
                want = ((score if len(score) > 1 else float(score[0]))
                        + placement.SPOT_REACH_WEIGHT * np.abs(reach - placement.SPOT_COMFORT_REACH)
                        + placement.SPOT_TURN_WEIGHT * np.abs(spots.turns[spots.turn]))
                np.testing.assert_array_equal(spots.score(), want)
                checked += len(want)
    assert checked > 100000


def test_compiled_spot_options_equal_the_steps_they_stand_for() -> None:
    """One compiled call for the planner's options (enough samples on the free spots, the best ranked, the
    picks spread over them, the reach annulus surely holding them) gives what the steps give one by one:
    numpy's sum of weights, :func:`best_spots`, :func:`farthest_picks` on the centres and turns, and the
    origins' distances from the base by ``np.hypot``; on real scenes' parts and spots past a reference,
    with random free spots, among them sums near the bound."""
    import numpy as np

    from samplehd.bench.language import _scenes
    from samplehd.world import placement
    from samplehd.world.free_spot import _SCORE_WEIGHTS, _SURE_REACH, _TURN_SPREAD
    from samplehd.world.spot_kernels import best_spots, farthest_picks, spot_options

    rng = np.random.default_rng(11)
    counted = {0: 0, 1: 0, 2: 0}
    sure_seen = set()
    for scene in _scenes(8, 2, 4):
        fs = ConstraintContext(scene).free_spots()
        samples, min_hits = float(fs.search.samples), fs.search.min_hits
        lo, hi = fs.layout.reach_min + _SURE_REACH, fs.layout.reach_max - _SURE_REACH
        for k in range(len(scene.objects)):
            grids = [fs._part_spots(k, part) for part in ("left", "front")]
            grids += [s for s in (fs._beside_spots(k, (k + 1) % 8, (0.6, 0.8)),) if s is not None]
            for spots in grids:
                g = spots.grid
                for density, top in ((0.9, hi), (0.3, 0.55), (0.02, hi), (0.0005, 0.55)):  # (also bounds cut)
                    free = spots.keep & (rng.random(len(spots.keep)) < density)
                    neighbours = rng.uniform(-0.4, 0.4, (int(rng.integers(0, 5)), 2))
                    args = (g.on_axes, g.u, g.v, spots.centre, neighbours, *spots.score_terms, spots.turns,
                            spots.turn, _SCORE_WEIGHTS, spots.shares(int(samples)), placement.SPOT_ROOM_CAP,
                            fs._ranks_needed(spots), float(placement.SPOT_SHORTLIST), _TURN_SPREAD,
                            placement.SPOT_OPTIONS, spots.offsets, fs._base, lo, top)
                    # the sum's test, by numpy's sum, and near the bound: the bound set to the sum itself
                    exact = samples * float(spots.weight[free].sum())
                    for bound in (min_hits, exact):
                        status, ranked, count, picks, sure = spot_options(free, spots.weight, samples, bound, False,
                                                                          *args)
                        counted[status] += 1
                        if status == 1:
                            assert abs(exact - bound) < 1e-9
                            status, ranked, count, picks, sure = spot_options(free, spots.weight, samples, bound,
                                                                              True, *args)
                        if status == 0:
                            assert exact < bound or not free.any()
                            continue
                        assert status == 2 and not exact < bound
                        want_ranked, want_count = best_spots(free, *args[:15])
                        np.testing.assert_array_equal(ranked, want_ranked)
                        assert count == want_count
                        best = want_ranked[:want_count]
                        where = np.empty((len(best), 3))
                        where[:, :2] = spots.centre[best]
                        where[:, 2] = _TURN_SPREAD * spots.turns[spots.turn[best]]
                        want_picks = farthest_picks(where, placement.SPOT_OPTIONS)
                        np.testing.assert_array_equal(picks, want_picks)
                        origin = spots.centre[best[want_picks]] - spots.offsets[spots.turn[best[want_picks]]]
                        reach = np.hypot(origin[:, 0] - fs._base[0], origin[:, 1] - fs._base[1])
                        assert sure == bool(((reach >= lo) & (reach <= top)).all())
                        sure_seen.add(sure)
    assert min(counted.values()) > 10 and sure_seen == {True, False}


def test_best_spots_with_the_reach_and_turn_terms_rank_as_the_whole_array_scores() -> None:
    """With the score's reach and turn terms (first taken with a square root, then exactly where a spot may
    rank), the ranking is the start of the stable order of the whole-array scores (:meth:`_Spots.score`
    less the capped gap), every score up to the ``needed``-th smallest and no other; on real scenes' parts
    and spots past a reference, with ties from twin neighbours and cells shared by the turns."""
    import numpy as np

    from samplehd.bench.language import _scenes
    from samplehd.world import placement
    from samplehd.world.free_spot import _SCORE_WEIGHTS
    from samplehd.world.spot_kernels import best_spots

    rng = np.random.default_rng(12)
    checked = 0
    for scene in _scenes(6, 2, 14):
        fs = ConstraintContext(scene).free_spots()
        for k in range(6):
            grids = [fs._part_spots(k, part) for part in ("right", "back")]
            grids += [s for s in (fs._beside_spots(k, (k + 2) % 6, (-1.0, 0.0)),) if s is not None]
            for spots in grids:
                g, m = spots.grid, len(spots.keep)
                whole = spots.score()
                for needed, n_near in ((221, 2), (12, 1), (3000, 4), (40, 0)):
                    free = spots.keep & (rng.random(m) < 0.6)
                    neighbours = rng.uniform(-0.4, 0.4, (n_near, 2))
                    if n_near > 1:
                        neighbours[1] = neighbours[0]
                    shares = spots.shares(fs.search.samples)
                    ranked, count = best_spots(free, g.on_axes, g.u, g.v, spots.centre, neighbours,
                                               *spots.score_terms, spots.turns, spots.turn, _SCORE_WEIGHTS, shares,
                                               placement.SPOT_ROOM_CAP, needed, float(placement.SPOT_SHORTLIST))
                    idx = np.flatnonzero(free)
                    gap = np.full(len(idx), np.inf)
                    if n_near:
                        gap = np.linalg.norm(spots.centre[idx, None, :] - neighbours[None], axis=-1).min(axis=1)
                    key = -np.minimum(gap, placement.SPOT_ROOM_CAP) + whole[idx]
                    order = idx[np.argsort(key, kind="stable")]
                    size = len(idx) if needed >= len(idx) else int((key <= np.sort(key)[needed - 1]).sum())
                    np.testing.assert_array_equal(ranked, order[:size])
                    want = max(1, int(np.searchsorted(np.cumsum(shares[ranked]), placement.SPOT_SHORTLIST,
                                                      side="right")))
                    assert count == want
                    checked += len(ranked)
    assert checked > 5000


def test_compiled_free_spots_equal_the_runs_marked_step_by_step() -> None:
    """An object's free spots in one compiled call (outside the runs of the objects where they are and of the
    rectangles already placed) equal the two steps they stand for: :func:`uncovered` of the scene's
    objects, then :func:`uncovered` of :func:`rect_runs` of the placed rectangles on every row."""
    import numpy as np

    from samplehd.bench.language import _scenes
    from samplehd.world.spot_kernels import free_spots, rect_runs, uncovered

    rng = np.random.default_rng(13)
    differ = 0
    for scene in _scenes(7, 2, 21):
        fs = ConstraintContext(scene).free_spots()
        for k in range(7):
            for spots in [fs._part_spots(k, part) for part in ("left", "back")] + [
                    s for s in (fs._beside_spots(k, (k + 1) % 7, (0.0, 1.0)),) if s is not None]:
                g, grow = spots.grid, fs.search.spot_margin / 2
                for n_placed in (0, 1, 3):
                    use = rng.random(len(spots.near)) < 0.7
                    pick = rng.choice(len(spots.keep), n_placed)
                    centres = np.ascontiguousarray(spots.centre[pick] + rng.normal(0, 0.02, (n_placed, 2)))
                    rots = np.ascontiguousarray(spots.rots[spots.turn[pick]])
                    halves = np.ascontiguousarray(rng.uniform(0.02, 0.1, (n_placed, 2)))
                    want = uncovered(spots.keep, spots.first, spots.last, use, len(g.v))
                    before = want
                    if n_placed:
                        first, last = rect_runs(spots.rots, fs.half[k], rots, halves, centres, np.arange(n_placed),
                                                grow, g.base, g.axes, g.u, 0, len(g.u), float(g.lo), float(g.width),
                                                len(g.v))
                        want = uncovered(want, first, last, np.ones(n_placed, bool), len(g.v))
                    got = free_spots(spots.keep, spots.first, spots.last, use, spots.rots, fs.half[k], rots, halves,
                                     centres, grow, g.base, g.axes, g.u, float(g.lo), float(g.width), len(g.v))
                    np.testing.assert_array_equal(got, want)
                    differ += bool((want != before).any())
    assert differ > 10  # the placed rectangles take spots


def test_compiled_option_counts_equal_the_runs_of_the_options_counted() -> None:
    """The runs an object on each of its options blocks on the next object's grid, and the free spots each
    leaves per turn, in one compiled call, equal :func:`rect_runs` of the options' rectangles taken from the
    arrays and :func:`counts_outside` of them, bit for bit."""
    import numpy as np

    from samplehd.bench.language import _scenes
    from samplehd.world.spot_kernels import counts_outside, option_counts, rect_runs

    rng = np.random.default_rng(14)
    blocked = 0
    for scene in _scenes(6, 2, 23):
        fs = ConstraintContext(scene).free_spots()
        for k in range(6):
            nxt = (k + 1) % 6
            for part in ("left", "front"):
                spots, nxt_spots = fs._part_spots(k, part), fs._part_spots(nxt, part)
                g, grow = nxt_spots.grid, fs.search.spot_margin / 2
                nxt_free = nxt_spots.keep & (rng.random(len(nxt_spots.keep)) < 0.8)
                at = rng.choice(np.flatnonzero(spots.keep), 6) if spots.keep.any() else np.zeros(0, np.int64)
                first, last, counts = option_counts(nxt_free, nxt_spots.rots, fs.half[nxt], spots.centre, spots.rots,
                                                    spots.turn, at, fs.half[k], grow, g.base, g.axes, g.u,
                                                    float(g.lo), float(g.width), len(g.v))
                c = np.ascontiguousarray(spots.centre[at])
                r = np.ascontiguousarray(spots.rots[spots.turn[at]])
                h = np.ascontiguousarray(np.broadcast_to(fs.half[k], (len(at), 2)))
                want = rect_runs(nxt_spots.rots, fs.half[nxt], r, h, c, np.arange(len(at)), grow, g.base, g.axes,
                                 g.u, 0, len(g.u), float(g.lo), float(g.width), len(g.v))
                np.testing.assert_array_equal(first, want[0])
                np.testing.assert_array_equal(last, want[1])
                np.testing.assert_array_equal(counts, counts_outside(nxt_free, want[0], want[1], len(g.v)))
                blocked += int((counts < nxt_free.reshape(len(nxt_spots.turns), -1).sum(axis=1)).sum())
    assert blocked > 50


def test_compiled_blockers_equal_the_near_objects_and_their_runs() -> None:
    """The objects near an object's kept spots and the runs they block, in one compiled call, equal
    :func:`near_objects` and then :func:`rect_runs` of those objects on the rows it names: the same runs,
    column for column (rows too far from an object for any overlap are left without computing them)."""
    import numpy as np

    from samplehd.bench.language import _scenes
    from samplehd.world.spot_kernels import blockers, near_objects, rect_runs

    some = skipped = 0
    for scene in _scenes(9, 2, 31):
        fs = ConstraintContext(scene).free_spots()
        for k in range(9):
            for spots in [fs._part_spots(k, part) for part in ("right", "front")] + [
                    s for s in (fs._beside_spots(k, (k + 4) % 9, (0.0, -1.0)),) if s is not None]:
                g, grow = spots.grid, fs.search.spot_margin / 2
                near, first, last = blockers(spots.keep, g.base, g.axes, g.u, g.v, fs.centre, fs._radius, k,
                                             spots.rots, fs.half[k], fs.rot, fs.half, grow, float(g.lo),
                                             float(g.width), len(g.v))
                want_near, r0, r1 = near_objects(spots.keep, len(spots.turns), g.base, g.axes, g.u, g.v, fs.centre,
                                                 fs._radius, k)
                want = rect_runs(spots.rots, fs.half[k], fs.rot, fs.half, fs.centre, want_near, grow, g.base, g.axes,
                                 g.u, r0, r1, float(g.lo), float(g.width), len(g.v))
                np.testing.assert_array_equal(near, want_near)
                assert first.shape == last.shape == (len(want_near), len(spots.turns), len(g.u))
                runs = first <= last
                np.testing.assert_array_equal(runs, want[0] <= want[1])
                np.testing.assert_array_equal(first[runs], want[0][runs])
                np.testing.assert_array_equal(last[runs], want[1][runs])
                some += bool(runs.any())
                skipped += int(((first == len(g.v)) & (last == -1) & (want[0] != len(g.v))).sum())
    assert some > 10 and skipped > 100  # rows left without computing them


def test_compiled_blocked_weight_equals_the_blockers_and_the_weights_outside_their_runs() -> None:
    """The weights of the spots outside every near object's runs, in one compiled call, equal
    :func:`blockers` then :func:`uncovered_weight` of its runs with every near object counting, bit for bit;
    and ``_Spots.blocked_weight`` gives the same before and after the runs are kept."""
    import numpy as np

    from samplehd.bench.language import _scenes
    from samplehd.world.spot_kernels import blocked_weight, blockers, uncovered_weight

    some = partial = 0
    for scene in _scenes(12, 3, 41):
        fs = ConstraintContext(scene).free_spots()
        for k in range(12):
            for spots in [fs._part_spots(k, part) for part in ("right", "front", "back")] + [
                    s for d in ((0.0, -1.0), (1.0, 0.0), (0.6, 0.8))
                    for s in (fs._beside_spots(k, (k + 5) % 12, d),) if s is not None]:
                g, grow = spots.grid, fs.search.spot_margin / 2
                args = (spots.keep, g.base, g.axes, g.u, g.v, fs.centre, fs._radius, k, spots.rots, fs.half[k],
                        fs.rot, fs.half, grow, float(g.lo), float(g.width), len(g.v))
                near, first, last = blockers(*args)
                want = uncovered_weight(spots.keep, first, last, np.ones(len(near), bool), len(g.v), spots.weight)
                got = blocked_weight(*args, spots.weight)
                assert type(got[0]) is float and got[0].hex() == want[0].hex() and got[1] == want[1]
                before = spots.blocked_weight()  # the runs not yet kept: the fused call
                assert "_blockers" not in spots.__dict__
                spots.near  # noqa: B018 (keeps the runs)
                assert before == spots.blocked_weight() == want
                some += bool(len(near))
                all_weight = uncovered_weight(spots.keep, first, last, np.zeros(len(near), bool), len(g.v),
                                              spots.weight)[0]
                partial += want[1] and want[0] < all_weight
    assert some > 50 and partial > 20  # near objects that block some kept spots, and spots left free


def test_compiled_runs_on_slab_bounds_at_whole_columns_equal_the_quotients() -> None:
    """Rows whose slab bounds fall on a column's coordinate, or a few units in the last place beside it (where
    the reciprocals the loop takes first could round the other way), give the quotients' own runs."""
    import numpy as np

    from samplehd.world.spot_kernels import column_runs

    rng = np.random.default_rng(15)
    lo, width, count = -0.25, 0.01, 50
    u = np.linspace(-0.3, 0.3, 40)
    n = 300
    across = rng.choice([1.0, -1.0, 0.7, -0.3, 3.0, 1e-3], (n, 1, 4)) * rng.uniform(0.5, 1.5, (n, 1, 4))
    along = rng.normal(size=(n, 1, 4)) * rng.choice([0.0, 1.0], (n, 1, 4))
    lim = rng.uniform(0.0, 0.2, (n, 1, 4))
    # q0 so that on row 7 the bound (q - lim) / across lands on column j's coordinate, nudged by a few ulps
    j = rng.integers(0, count, (n, 1, 4))
    coord = lo + (j + 0.5) * width
    q0 = coord * across + lim + along * u[7]
    q0 = q0 + rng.integers(-3, 4, q0.shape) * np.spacing(q0)
    want = _runs_by_arrays(q0, along, across, lim, u, lo, width, count)
    got = column_runs(q0, along, across, lim, u, 0, len(u), lo, width, count)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
    assert (want[0][:, :, 7] <= want[1][:, :, 7]).any()


def test_a_part_surely_crowded_by_the_clearance_bound_has_no_room() -> None:
    """Where the bound from the clearance of the grid points says object k (moved first) finds too few free
    spots in a part, the full test finds too few as well: no options, not enough samples on free spots, no
    room for it alone; and the bound does decide on crowded scenes (the test would pass vacuously else)."""
    import numpy as np

    from samplehd.bench.language import _scenes
    from samplehd.world.free_spot import _NONE_PLACED
    from samplehd.world.layout import TABLE_PARTS

    decided = checked = 0
    for n in (5, 12, 20):
        for scene in _scenes(n, 2, 8):
            fs = ConstraintContext(scene).free_spots()
            present = np.ones(n, bool)
            for part in TABLE_PARTS:
                for k in range(n):
                    crowded = fs._surely_crowded(k, part)
                    spots = fs._part_spots(k, part)
                    free = fs._free(k, spots, present, _NONE_PLACED)
                    options = fs._options(k, spots, free, fs._neighbours(k, present, _NONE_PLACED))
                    checked += 1
                    if crowded:
                        decided += 1
                        assert options == [] and not fs._enough(spots, free), (n, k, part)
    assert decided > checked // 4

"""Free spots for moved objects: the ground-truth planner's destination test, run on a grid.

The planner (:func:`samplehd.motion.planner.destination_candidates`) puts a moved object down by
sampling positions of its frame origin and turns about the vertical, and keeping the samples where
its footprint rectangle stays ``spot_margin`` clear of every other object's, inside the table's
edges, with the origin in reach (and, for place and remove, inside the destination part shrunk by
``part_margin``; for place_relative, past the reference object). Instruction constraints run the
same test on a deterministic grid of spots instead of random samples, and accept a destination
only when enough of the planner's samples would land on a free spot: a spot too small for its
first try to find reliably counts as no spot. Objects stand upright: a footprint is the rectangle
of half sizes ``footprint_half`` about ``footprint_centre``, turned by the object's yaw.

Rectangles are tested by :func:`rect_overlap`, the planner's own test, and the margins are the
planner's :class:`~samplehd.world.planner_config.PlannerConfig` defaults. Nothing here loads
MuJoCo (the planner's footprints in a compiled state come from
:func:`samplehd.world.bodies.object_footprint`), so reading scenes and checking constraints stays light.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from samplehd.errors import ConfigError
from samplehd.world import placement
from samplehd.world.layout import TableLayout
from samplehd.world.planner_config import PlannerConfig
from samplehd.world.transforms import yaw_rotation_2d

__all__ = ["FreeSpots", "Footprinted", "SpotSearch", "rect_overlap", "table_and_reach"]


class Footprinted(Protocol):
    """What the free-spot test reads of a scene object (e.g. :class:`samplehd.language.scene.SceneObject`)."""

    @property
    def coords(self) -> tuple[float, float, float]: ...

    @property
    def yaw(self) -> float: ...

    @property
    def footprint_centre(self) -> tuple[float, float]: ...

    @property
    def footprint_half(self) -> tuple[float, float]: ...

_TURN_SPREAD = 0.06  # weight of a turn against a distance when spreading the options [m/rad]

_Rect = tuple[np.ndarray, np.ndarray, np.ndarray]  # footprint centre, 2x2 rotation, half sizes


@dataclass(frozen=True)
class SpotSearch:
    """Settings of the free-spot test.

    Attributes:
        spot_margin: free space between the placed object and its neighbours [m].
        part_margin: placed origin and centre at least this far inside the destination part [m].
        relation_gap: place_relative: origin past the reference's origin by this plus 2 cm [m].
        samples: spots the planner samples in its first try.
        step: grid spacing of the spots tested [m].
        min_hits: fewest of the planner's first-try samples expected on a free spot; with 2, its
            first try misses about one time in seven and its relaxed second try almost never.
    """

    spot_margin: float
    part_margin: float
    relation_gap: float
    samples: int
    step: float = 0.01
    min_hits: float = 2.0

    def __post_init__(self) -> None:
        for name in ("spot_margin", "part_margin", "relation_gap", "samples", "min_hits"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ConfigError(f"spot search {name}={value!r} must be a finite non-negative number")
        if not (math.isfinite(self.step) and 0 < self.step <= 0.05):
            raise ConfigError(f"spot search step={self.step!r} must be in (0, 0.05] m")

    @classmethod
    def from_planner(cls, config: PlannerConfig | None = None, step: float = 0.01,
                     min_hits: float = 2.0) -> SpotSearch:
        """The search with a planner config's margins and sample count (default: its defaults)."""
        c = config if config is not None else PlannerConfig()
        return cls(c.spot_margin, c.part_margin, c.relation_gap, int(c.spot_samples), step, min_hits)


def _cells(lo: float, hi: float, step: float) -> np.ndarray:
    """Centres of equal cells about ``step`` wide covering [lo, hi] (one cell if it is narrower)."""
    n = max(1, math.ceil((hi - lo) / step - 1e-9))
    return lo + (np.arange(n) + 0.5) * (hi - lo) / n


def _yaw_weights() -> tuple[np.ndarray, np.ndarray]:
    """The distinct turns the planner samples and how often it samples each."""
    turns, counts = np.unique(np.array(placement.SPOT_TURNS), return_counts=True)
    return turns, counts / len(placement.SPOT_TURNS)


@dataclass(frozen=True)
class _Spots:
    """Candidate spots of one object, and which other objects (where the scene has them) each one
    overlaps. Spots come in groups by the turn the object makes about the vertical."""

    centre: np.ndarray  # (m, 2) footprint centres [m]
    origin: np.ndarray  # (m, 2) frame origins [m]
    turn: np.ndarray  # (m,) index into turns
    turns: np.ndarray  # (t,) turns about the vertical [rad]
    rots: np.ndarray  # (t, 2, 2) the object's rotation after each turn
    weight: np.ndarray  # (m,) share of the planner's first-try samples landing on the spot
    score: np.ndarray  # (m,) the planner's score terms that do not depend on the neighbours
    blocked: np.ndarray  # (m, n) overlaps scene object j
    by_turn: tuple[np.ndarray, ...]  # indices of the spots of each turn
    middle: np.ndarray  # (2,) centre of the box around the spots' centres [m]
    spread: np.ndarray  # (2,) half sizes of that box [m]


class FreeSpots:
    """The planner's free-spot test for the objects of one scene (candidate spots memoised).

    Args:
        objects: the scene's objects.
        search: margins, sample count, grid step and the hits required.
        layout: table geometry.
        reach: whether the gripper can place at a point (x, y, z) [m]; tried on the best spots
            (the planner's own reach annulus already filters every spot).
    """

    def __init__(
        self,
        objects: Sequence[Footprinted],
        search: SpotSearch,
        layout: TableLayout,
        reach: Callable[[Sequence[float]], bool],
    ) -> None:
        self._overlap = rect_overlap
        self.objects = tuple(objects)
        self.search = search
        self.layout = layout
        self.reach = reach
        self.centre = np.array([o.footprint_centre for o in objects], float).reshape(-1, 2)
        self.origin = np.array([o.coords[:2] for o in objects], float).reshape(-1, 2)
        self.rot = yaw_rotation_2d(np.array([o.yaw for o in objects], float)).reshape(-1, 2, 2)
        self.half = np.array([o.footprint_half for o in objects], float).reshape(-1, 2)
        self.turns, self.turn_share = _yaw_weights()
        self._memo: dict[tuple[Any, ...], _Spots] = {}

    def room_in_part(self, moved: Sequence[int], part: str) -> bool:
        """Whether the moved objects all find a free spot in a table part, one after another.

        Objects are moved in index order, as the executor does. Each one already in the part
        stays; each arriving one frees its old spot and takes one of the spots the planner may pick
        (its best-scored free spots: room around, comfortable reach, least turn), namely the one
        that leaves the next object least room, so the answer holds whichever the planner picks.
        """
        arriving = [k for k in sorted(set(moved)) if part not in self.objects[k].table_part]
        present = np.ones(len(self.objects), bool)  # objects still where the scene has them
        placed: list[_Rect] = []
        for n, k in enumerate(arriving):
            spots = self._part_spots(k, part)
            free, neighbours = self._free(k, spots, present, placed)
            options = self._options(k, spots, free, neighbours)
            if not options:
                return False
            present[k] = False
            chosen = options[0]
            if n + 1 < len(arriving) and len(options) > 1:
                nxt = arriving[n + 1]
                nxt_spots = self._part_spots(nxt, part)
                nxt_free, _ = self._free(nxt, nxt_spots, present, placed)
                room_left = [self._hits(nxt_spots, nxt_free & ~self._blocks(nxt, nxt_spots, nxt_free,
                                                                          *self._rect(k, spots, j)))
                             for j in options]
                chosen = options[int(np.argmin(room_left))]
            placed.append(self._rect(k, spots, chosen))
        return True

    def room_beside(self, x: int, ref: int, direction: Sequence[float]) -> bool:
        """Whether object ``x`` finds a free spot past object ``ref`` along a direction (x, y)."""
        spots = self._beside_spots(x, ref, (float(direction[0]), float(direction[1])))
        free, neighbours = self._free(x, spots, np.ones(len(self.objects), bool), [])
        return bool(self._options(x, spots, free, neighbours))

    def _rect(self, k: int, spots: _Spots, j: int) -> _Rect:
        """Object k's footprint rectangle on spot j: centre, rotation, half sizes."""
        return spots.centre[j], spots.rots[spots.turn[j]], self.half[k]

    def _hits(self, spots: _Spots, free: np.ndarray) -> float:
        """How many of the planner's first-try samples are expected on the free spots."""
        return self.search.samples * float(spots.weight[free].sum())

    def _free(self, k: int, spots: _Spots, present: np.ndarray,
              placed: Sequence[_Rect]) -> tuple[np.ndarray, np.ndarray]:
        """Object k's free spots, given which objects are still where the scene has them and the
        rectangles of those already moved; and the footprint centres of all those others."""
        others = present.copy()
        others[k] = False
        free = ~spots.blocked[:, others].any(axis=1)
        centres = [self.centre[others]]
        for rect in placed:
            free &= ~self._blocks(k, spots, free, *rect)
            centres.append(rect[0][None])
        return free, np.concatenate(centres)

    def _options(self, k: int, spots: _Spots, free: np.ndarray, neighbours: np.ndarray) -> list[int]:
        """Free spots the planner may put object k on, spread over the ones it may pick; none where
        too few of its first-try samples would land on a free spot or the gripper reaches none.

        The planner keeps its best-scored free samples and tries a few of them: here, the best free
        spots holding that many of its expected samples, of which a few far apart are returned.
        """
        if self._hits(spots, free) < self.search.min_hits:
            return []
        idx = np.flatnonzero(free)
        if len(neighbours):
            gap = np.linalg.norm(spots.centre[idx, None, :] - neighbours[None], axis=-1).min(axis=1)
        else:
            gap = np.full(len(idx), np.inf)
        ranked = idx[np.argsort(-np.minimum(gap, placement.SPOT_ROOM_CAP) + spots.score[idx], kind="stable")]
        samples = np.cumsum(self.search.samples * spots.weight[ranked])
        best = ranked[: max(1, int(np.searchsorted(samples, placement.SPOT_SHORTLIST, side="right")))]
        # spread: farthest-point picks over position and turn (a long object's turn matters as much)
        where = np.column_stack([spots.centre[best], _TURN_SPREAD * spots.turns[spots.turn[best]]])
        picks = [0]
        dist = np.linalg.norm(where - where[0], axis=1)
        while len(picks) < placement.SPOT_OPTIONS and dist.max() > 0:
            picks.append(int(dist.argmax()))
            dist = np.minimum(dist, np.linalg.norm(where - where[picks[-1]], axis=1))
        z = self.objects[k].coords[2]  # the origin's height does not change on the table
        reached = [int(best[i]) for i in picks if self.reach((*spots.origin[best[i]], z))]
        if reached:
            return reached
        return next(([int(j)] for j in ranked[:placement.SPOT_SHORTLIST] if self.reach((*spots.origin[j], z))), [])

    def _blocks(self, k: int, spots: _Spots, among: np.ndarray, c: np.ndarray, r: np.ndarray,
                h: np.ndarray) -> np.ndarray:
        """Which of object k's spots (of those in ``among``) overlap the rectangle (centre c,
        rotation r, half sizes h); one vectorised test per turn, on the spots whose circles reach it."""
        out = np.zeros(len(spots.centre), bool)
        grow = self.search.spot_margin / 2
        reach = math.hypot(*(self.half[k] + grow)) + math.hypot(*(h + grow))
        if len(spots.centre) == 0 or np.any(np.abs(c - spots.middle) > spots.spread + reach):
            return out
        near = among & (np.einsum("ij,ij->i", spots.centre - c, spots.centre - c) <= reach * reach)
        for t, members in enumerate(spots.by_turn):
            idx = members[near[members]]
            if len(idx):
                out[idx] = self._overlap(spots.centre[idx], spots.rots[t], self.half[k], c, r, h,
                                         self.search.spot_margin)
        return out

    def _part_spots(self, k: int, part: str) -> _Spots:
        key = ("part", k, part)
        if key not in self._memo:
            lo, hi = self.layout.part_bounds(part)
            lo, hi = lo + self.search.part_margin, hi - self.search.part_margin
            step = self.search.step
            gx, gy = np.meshgrid(_cells(lo[0], hi[0], step), _cells(lo[1], hi[1], step), indexing="ij")
            grid = np.stack([gx.ravel(), gy.ravel()], -1)
            nt = len(self.turns)
            turn = np.repeat(np.arange(nt), len(grid))
            centre = np.tile(grid, (nt, 1))
            origin = self._origins(k, turn, centre)
            weight = np.repeat(self.turn_share / len(grid), len(grid))
            inside = np.all((origin >= lo) & (origin <= hi), axis=1)
            self._memo[key] = self._spots(k, centre, origin, turn, weight, np.zeros(len(turn)), inside)
        return self._memo[key]

    def _beside_spots(self, x: int, ref: int, direction: tuple[float, float]) -> _Spots:
        key = ("beside", x, ref, direction)
        if key not in self._memo:
            d = np.asarray(direction, float)
            d /= np.linalg.norm(d)
            lateral = np.array([-d[1], d[0]])
            ext_ref = np.abs(d @ self.rot[ref]) @ self.half[ref]
            (near_dist, near_lat), (far_dist, far_lat) = placement.BESIDE_NEAR, placement.BESIDE_FAR
            step = self.search.step
            dist, lat = np.meshgrid(_cells(0.0, far_dist, step), _cells(-far_lat, far_lat, step), indexing="ij")
            dist, lat = dist.ravel(), lat.ravel()
            near = (dist <= near_dist) & (np.abs(lat) <= near_lat)
            # half the planner's samples fall in the near box, half in the far one
            cell = 0.5 / len(dist) + np.where(near, 0.5 / max(1, int(near.sum())), 0.0)
            nt = len(self.turns)
            turn = np.repeat(np.arange(nt), len(dist))
            weight = np.repeat(self.turn_share, len(dist)) * np.tile(cell, nt)
            dist, lat = np.tile(dist, nt), np.tile(lat, nt)
            ext_x = (np.abs(d @ self._turned_rots(x)) @ self.half[x])[turn]
            centre = (self.centre[ref] + (ext_ref + ext_x + self.search.spot_margin + dist)[:, None] * d
                      + lat[:, None] * lateral)
            origin = self._origins(x, turn, centre)
            lo = np.asarray(self.layout.workspace_min) - placement.SPOT_WORKSPACE_SLACK
            hi = np.asarray(self.layout.workspace_max) + placement.SPOT_WORKSPACE_SLACK
            past = (origin - self.origin[ref]) @ d >= self.search.relation_gap + placement.BESIDE_NEED
            inside = past & np.all((origin >= lo) & (origin <= hi), axis=1)
            score = placement.SPOT_FAR_PENALTY * (np.maximum(0.0, dist - near_dist)
                                                  + np.maximum(0.0, np.abs(lat) - near_lat))
            self._memo[key] = self._spots(x, centre, origin, turn, weight, score, inside)
        return self._memo[key]

    def _turned_rots(self, k: int) -> np.ndarray:
        """Object k's rotation after each turn (t, 2, 2)."""
        return yaw_rotation_2d(self.turns) @ self.rot[k]

    def _origins(self, k: int, turn: np.ndarray, centre: np.ndarray) -> np.ndarray:
        """Frame origins of object k turned by ``turns[turn]`` with its footprint centred at
        ``centre``: the origin keeps its offset from the footprint centre, turned with it."""
        offsets = yaw_rotation_2d(self.turns) @ (self.centre[k] - self.origin[k])
        return centre - offsets[turn]

    def _spots(self, k: int, centre: np.ndarray, origin: np.ndarray, turn: np.ndarray, weight: np.ndarray,
               score: np.ndarray, keep: np.ndarray) -> _Spots:
        """Spots that pass the tests not involving other objects, with their overlaps with them."""
        rots = self._turned_rots(k)
        half = (np.abs(rots) @ self.half[k])[turn]  # world-axis half sizes of the turned rectangles
        on_table, reach = table_and_reach(centre, half, origin, self.layout)
        keep = keep & on_table
        centre, origin, turn = centre[keep], origin[keep], turn[keep]
        score = (score[keep] + placement.SPOT_REACH_WEIGHT * np.abs(reach[keep] - placement.SPOT_COMFORT_REACH)
                 + placement.SPOT_TURN_WEIGHT * np.abs(self.turns[turn]))
        lo, hi = (centre.min(axis=0), centre.max(axis=0)) if len(centre) else (np.zeros(2), np.zeros(2))
        spots = _Spots(centre, origin, turn, self.turns, rots, weight[keep], score,
                       np.zeros((len(centre), len(self.objects)), bool),
                       tuple(np.flatnonzero(turn == t) for t in range(len(self.turns))), (lo + hi) / 2, (hi - lo) / 2)
        every = np.ones(len(spots.centre), bool)
        for j in range(len(self.objects)):
            if j != k:
                spots.blocked[:, j] = self._blocks(k, spots, every, self.centre[j], self.rot[j], self.half[j])
        return spots


def table_and_reach(centre: np.ndarray, half: np.ndarray, origin: np.ndarray,
                    layout: TableLayout) -> tuple[np.ndarray, np.ndarray]:
    """The tests of spots that involve no other object, the planner's and the grid's alike.

    Args:
        centre: (m, 2) footprint centres [m].
        half: (m, 2) world-axis half sizes of the turned footprints [m].
        origin: (m, 2) the objects' frame origins there [m].
        layout: table geometry.

    Returns:
        Which spots keep the footprint ``SPOT_TABLE_EDGE`` inside the table's edges with the origin in
        the arm's reach annulus, and each origin's horizontal distance from the robot base [m].
    """
    table = np.asarray(layout.table_size) / 2 - placement.SPOT_TABLE_EDGE
    keep = np.all((centre - half >= -table) & (centre + half <= table), axis=1)
    base = np.asarray(layout.robot_base)
    reach = np.hypot(origin[:, 0] - base[0], origin[:, 1] - base[1])
    keep &= (reach >= layout.reach_min) & (reach <= layout.reach_max)
    return keep, reach


def rect_overlap(c1: np.ndarray, r1: np.ndarray, h1: np.ndarray, c2: np.ndarray, r2: np.ndarray,
                 h2: np.ndarray, margin: float) -> np.ndarray:
    """Separating-axis test of oriented rectangles (centres, 2×2 rotations, half sizes) grown by margin.

    Broadcasts over leading dimensions (centres and half sizes ``(..., 2)``, rotations ``(..., 2, 2)``),
    so one call tests many pairs; returns whether each pair overlaps (a boolean array of the leading
    shape).
    """
    r1, r2 = np.broadcast_arrays(np.asarray(r1, float), np.asarray(r2, float))
    axes = np.swapaxes(np.concatenate((r1, r2), axis=-1), -1, -2)  # the four candidate axes, as rows
    reach = (np.abs(axes @ r1) @ (np.asarray(h1) + margin / 2)[..., None]
             + np.abs(axes @ r2) @ (np.asarray(h2) + margin / 2)[..., None])
    apart = np.abs(axes @ (np.asarray(c2) - np.asarray(c1))[..., None])
    return np.all(apart <= reach, axis=(-2, -1))

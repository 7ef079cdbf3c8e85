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

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from samplehd.errors import ConfigError
from samplehd.fixedmath import matmul, norm
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
# rectangles of the objects already moved: footprint centres (n, 2), rotations (n, 2, 2), half sizes (n, 2)
_Placed = tuple[np.ndarray, np.ndarray, np.ndarray]
# the weights of the planner's score terms that do not depend on the neighbours (spot_kernels.spot_scores)
_SCORE_WEIGHTS = np.array([placement.SPOT_REACH_WEIGHT, placement.SPOT_COMFORT_REACH, placement.SPOT_TURN_WEIGHT])
_SCORE_WEIGHTS.setflags(write=False)
_NO_SCORE = np.zeros(1)  # a part's spots have no score of their own
_NO_SCORE.setflags(write=False)
_NONE_PLACED: _Placed = (np.zeros((0, 2)), np.zeros((0, 2, 2)), np.zeros((0, 2)))
for _a in _NONE_PLACED:
    _a.setflags(write=False)
# picks whose frame origins lie this far inside the reach annulus are surely reached: ``reach`` (the annulus,
# memoised on coordinates rounded to a micrometre) says yes on them and on any point rounding alike [m]
_SURE_REACH = 1e-5


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


@functools.cache
def _kernels() -> Any:
    """The compiled loops (:mod:`samplehd.world.spot_kernels`), loaded when a spot is first tested: importing
    numba and compiling cost seconds that a process which never tests a spot should not pay."""
    from samplehd.world import spot_kernels

    return spot_kernels


def _cells(lo: float, hi: float, step: float) -> np.ndarray:
    """Centres of equal cells about ``step`` wide covering [lo, hi] (one cell if it is narrower)."""
    n = max(1, math.ceil((hi - lo) / step - 1e-9))
    return lo + (np.arange(n) + 0.5) * (hi - lo) / n


@functools.cache
def _yaw_weights() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The distinct turns the planner samples, how often it samples each, and their rotations (read only)."""
    turns, counts = np.unique(np.array(placement.SPOT_TURNS), return_counts=True)
    out = (turns, counts / len(placement.SPOT_TURNS), yaw_rotation_2d(turns))
    for a in out:
        a.setflags(write=False)
    return out


@dataclass
class _Grid:
    """A grid of spots for one object: footprint centre ``base[t] + u[i] e1 + v[j] e2`` for the turn
    ``t`` about the vertical, row ``i`` and column ``j``, flattened in the order (turn, row, column)."""

    base: np.ndarray  # (t, 2) origin of each turn's grid [m]
    axes: np.ndarray  # (2, 2) directions of the rows and the columns, e1 and e2 (rows)
    u: np.ndarray  # (r,) row coordinates along e1 [m]
    v: np.ndarray  # (c,) column coordinates along e2 [m]: (j + 0.5) * width past lo
    lo: float
    width: float
    on_axes: bool  # e1, e2 are x, y and base is 0: centre (u[i], v[j]) exactly


@dataclass(eq=False)
class _Spots:
    """Candidate spots of one object: every spot of its grid, the ones that pass the tests not
    involving other objects marked in ``keep``, and which other objects (where the scene has them)
    each one overlaps."""

    grid: _Grid
    centre_of: Callable[[], np.ndarray]  # makes ``centre`` when first asked for
    offsets: np.ndarray  # (t, 2) frame origin of the spot minus its footprint centre, per turn [m]
    turn: np.ndarray  # (m,) index into turns
    turns: np.ndarray  # (t,) turns about the vertical [rad]
    rots: np.ndarray  # (t, 2, 2) the object's rotation after each turn
    weight: np.ndarray  # (m,) share of the planner's first-try samples landing on the spot
    score_terms: tuple[np.ndarray, np.ndarray, np.ndarray]  # score, rel_x, rel_y of spot_kernels.spot_scores
    keep: np.ndarray  # (m,) passes the tests not involving other objects
    blockers_of: Callable[[_Spots], tuple[np.ndarray, np.ndarray, np.ndarray]]  # makes near, first, last
    blocked_weight_of: Callable[[_Spots], tuple[float, bool]]  # :meth:`blocked_weight` without the runs

    @functools.cached_property
    def _blockers(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.blockers_of(self)

    def blocked_weight(self) -> tuple[float, bool]:
        """The weights of the spots in ``keep`` outside every near object's runs, summed left to right, and
        whether there is any such spot (``uncovered_weight`` of :attr:`first`, :attr:`last` with every near
        object counting); in one compiled call where the runs are not yet known, without keeping them."""
        if "_blockers" in self.__dict__:
            near = self.near
            return _kernels().uncovered_weight(self.keep, self.first, self.last, np.ones(len(near), bool),
                                               len(self.grid.v), self.weight)
        return self.blocked_weight_of(self)

    @property
    def near(self) -> np.ndarray:
        """(b,) the other objects that come close enough to block some spot."""
        return self._blockers[0]

    @property
    def first(self) -> np.ndarray:
        """(b, t, r) first column of the run of spots object near[i] overlaps, per turn and row."""
        return self._blockers[1]

    @property
    def last(self) -> np.ndarray:
        """(b, t, r) the run's last column (before the first: none)."""
        return self._blockers[2]

    @functools.cached_property
    def centre(self) -> np.ndarray:
        """(m, 2) footprint centres [m] (only the ranking of spots needs them)."""
        return self.centre_of()

    def shares(self, samples: int) -> np.ndarray:
        """(m,) how many of ``samples`` first-try samples are expected on each spot (memoised)."""
        memo = self.__dict__.setdefault("_shares", {})
        if samples not in memo:
            memo[samples] = samples * self.weight
        return memo[samples]

    @functools.cached_property
    def turn_weights(self) -> tuple[float, ...]:
        """The weight of each turn's first spot (a part's spots of one turn weigh alike)."""
        return tuple(self.weight[:: len(self.weight) // len(self.turns)].tolist())

    def score(self) -> np.ndarray:
        """(m,) the planner's score terms that do not depend on the neighbours (the ranking computes them on the
        free spots only)."""
        return _kernels().spot_scores(*self.score_terms, self.turns, self.turn, _SCORE_WEIGHTS, len(self.grid.u),
                                      len(self.grid.v))


class FreeSpots:
    """The planner's free-spot test for the objects of one scene (candidate spots memoised).

    The spots an object may take form a grid per turn, and the spots a rectangle blocks are, on
    each row of the grid, one run of columns (the separating-axis test is four slabs), so the test
    finds where each run starts and ends instead of testing every spot against every rectangle.

    Args:
        objects: the scene's objects.
        search: margins, sample count, grid step and the hits required.
        layout: table geometry.
        reach: whether the gripper can place at a point (x, y, z) [m]; tried on the best spots
            (the planner's own reach annulus already filters every spot).
        reach_is_annulus: ``reach`` is that annulus (``layout.in_reach``): every spot passes it,
            so the last object moved needs only enough free spots, not the planner's picks.
    """

    def __init__(
        self,
        objects: Sequence[Footprinted],
        search: SpotSearch,
        layout: TableLayout,
        reach: Callable[[Sequence[float]], bool],
        reach_is_annulus: bool = False,
    ) -> None:
        self.objects = tuple(objects)
        self.search = search
        self.layout = layout
        self.reach = reach
        self.reach_is_annulus = reach_is_annulus
        self.centre = np.array([o.footprint_centre for o in objects], float).reshape(-1, 2)
        self.origin = np.array([o.coords[:2] for o in objects], float).reshape(-1, 2)
        self.rot = yaw_rotation_2d(np.array([o.yaw for o in objects], float)).reshape(-1, 2, 2)
        self.half = np.array([o.footprint_half for o in objects], float).reshape(-1, 2)
        self.turns, self.turn_share, self._turn_rots = _yaw_weights()
        self._table = np.asarray(layout.table_size) / 2 - placement.SPOT_TABLE_EDGE
        self._base = np.asarray(layout.robot_base)
        self._workspace = (np.asarray(layout.workspace_min) - placement.SPOT_WORKSPACE_SLACK,
                           np.asarray(layout.workspace_max) + placement.SPOT_WORKSPACE_SLACK)
        # the half diagonal of each footprint grown by half the margin: how far it reaches [m]
        self._radius = np.hypot(*(self.half + search.spot_margin / 2).T)
        self._memo: dict[tuple[Any, ...], Any] = {}

    def release(self) -> None:
        """Forget the memoised spots (they refer back to this test: freed now, not at the collector's next
        full pass)."""
        self._memo.clear()

    def room_in_part(self, moved: Sequence[int], part: str) -> bool:
        """Whether the moved objects all find a free spot in a table part, one after another.

        Objects are moved in index order, as the executor does. Each one already in the part
        stays; each arriving one frees its old spot and takes one of the spots the planner may pick
        (its best-scored free spots: room around, comfortable reach, least turn), namely the one
        that leaves the next object least room, so the answer holds whichever the planner picks.
        """
        arriving = tuple(k for k in sorted(set(moved)) if part not in self.objects[k].table_part)
        key = ("room in part", arriving, part)
        answer = self._memo.get(key)
        if answer is None:
            answer = self._memo[key] = self._room_in_part(arriving, part)
        return answer

    def _first_options(self, k: int, part: str) -> list[int]:
        """The spots the planner may put object k on in a part when it is the first moved (memoised:
        they depend on nothing else)."""
        key = ("first options", k, part)
        options = self._memo.get(key)
        if options is None:
            if self._surely_crowded(k, part):
                options = []
            else:
                spots = self._part_spots(k, part)
                present = np.ones(len(self.objects), bool)
                free = self._free(k, spots, present, _NONE_PLACED)
                options = self._options(k, spots, free, self._neighbours(k, present, _NONE_PLACED))
            self._memo[key] = options
        return options

    def _surely_crowded(self, k: int, part: str) -> bool:
        """Whether object k, moved first, surely finds too few free spots in a part for the planner's samples
        (and so no options), from a bound that needs no spot of its own.

        Object k's footprint, grown by half the margin, holds the circle of its smaller half size plus that
        half margin about its centre, whatever the turn; on a free spot that circle meets no other footprint
        grown alike. So k's free spots, every turn together, lie on the grid points at least that radius (less
        1e-7 m, far above rounding) from every other footprint, and their weights sum to at most the share
        of those points (each point's turns weigh its share in all). Where even that, a bound far from
        rounding, leaves fewer than ``min_hits`` samples, the full test finds too few as well.
        """
        answer = self._memo.get(("crowded", k, part))
        if answer is None:
            clear = self._memo.get(("clearance", part))
            if clear is None:
                grid = _part_grid(self.layout, self.search.part_margin, self.search.step, part)[0]
                clear = self._memo["clearance", part] = _kernels().clearance(grid.u, grid.v, self.centre, self.rot,
                                                                              self.half, self.search.spot_margin / 2)
            radius = max(float(self.half[k].min()) + self.search.spot_margin / 2 - 1e-7, 0.0)
            share = _kernels().clear_points(*clear, k, radius * radius) / clear[0].size
            answer = self._memo["crowded", k, part] = self.search.samples * share < self.search.min_hits * (1 - 1e-9)
        return answer

    def _room_in_part(self, arriving: Sequence[int], part: str) -> bool:
        """:meth:`room_in_part` for the objects arriving in the part, in index order."""
        if arriving and self._surely_crowded(arriving[0], part):  # the first has too few free spots
            return False
        if len(arriving) > 1 or (arriving and not self.reach_is_annulus):
            if not self._first_options(arriving[0], part):  # the first one's options, as the loop takes them
                return False
        present = np.ones(len(self.objects), bool)  # objects still where the scene has them
        # the rectangles of the objects moved so far: the first ``moved`` rows
        size = len(arriving)
        centres, rots, halves = np.empty((size, 2)), np.empty((size, 2, 2)), np.empty((size, 2))
        moved = 0
        placed: _Placed = _NONE_PLACED
        free: np.ndarray | None = None  # the next object's free spots, where already known
        for n, k in enumerate(arriving):
            spots = self._part_spots(k, part)
            last = n + 1 == len(arriving)
            if n == 0 and not (last and self.reach_is_annulus):
                options = self._first_options(k, part)
            else:
                if free is None:
                    free = self._free(k, spots, present, placed)
                if last and self.reach_is_annulus:
                    return self._enough(spots, free)
                options = self._options(k, spots, free, self._neighbours(k, present, placed))
            if not options:
                return False
            present[k] = False
            chosen, free = options[0], None
            if n + 1 < len(arriving) and len(options) > 1:
                nxt = arriving[n + 1]
                nxt_spots = self._part_spots(nxt, part)
                nxt_free = self._free(nxt, nxt_spots, present, placed)
                # the next object's free spots each option leaves, counted per turn: the samples on them
                # are summed exactly as over the spots themselves (a part's spots weigh alike per turn)
                g = nxt_spots.grid
                first, lst, counts = _kernels().option_counts(
                    nxt_free, nxt_spots.rots, self.half[nxt], spots.centre, spots.rots, spots.turn, np.array(options),
                    self.half[k], self.search.spot_margin / 2, g.base, g.axes, g.u, float(g.lo), float(g.width),
                    len(g.v))
                room_left = [self._hits_counted(nxt_spots, c) for c in counts.tolist()]
                best = room_left.index(min(room_left))  # the first smallest, as np.argmin
                chosen = options[best]
                if n + 2 == len(arriving) and self.reach_is_annulus:  # the next is the last to arrive
                    return room_left[best] >= self.search.min_hits and sum(counts[best]) > 0
                free = _kernels().uncovered(nxt_free, first[best : best + 1], lst[best : best + 1], np.ones(1, bool),
                                            len(nxt_spots.grid.v))
            centres[moved], rots[moved], halves[moved] = self._rect(k, spots, chosen)
            moved += 1
            placed = (centres[:moved], rots[:moved], halves[:moved])
        return True

    def room_beside(self, x: int, ref: int, direction: Sequence[float]) -> bool:
        """Whether object ``x`` finds a free spot past object ``ref`` along a direction (x, y)."""
        spots = self._beside_spots(x, ref, (float(direction[0]), float(direction[1])))
        if spots is None or self._too_few(spots):
            return False
        present = np.ones(len(self.objects), bool)
        if self.reach_is_annulus:  # :meth:`_enough` of the free spots, their weights summed as they are found
            # the objects near and the runs they block, and the weights outside them, in one compiled call
            # (:func:`samplehd.world.spot_kernels.blocked_weight`): every object but x is where it is
            total, found = spots.blocked_weight()
            below = self._below(total, len(spots.weight), self.search.min_hits,
                                lambda: float(spots.weight[self._free(x, spots, present, _NONE_PLACED)].sum()))
            return not below and found
        free = self._free(x, spots, present, _NONE_PLACED)
        return bool(self._options(x, spots, free, self._neighbours(x, present, _NONE_PLACED)))

    def _rect(self, k: int, spots: _Spots, j: int) -> _Rect:
        """Object k's footprint rectangle on spot j: centre, rotation, half sizes."""
        return spots.centre[j], spots.rots[spots.turn[j]], self.half[k]

    def _hits(self, spots: _Spots, free: np.ndarray) -> float:
        """How many of the planner's first-try samples are expected on the free spots."""
        return self.search.samples * float(spots.weight[free].sum())

    def _hits_counted(self, spots: _Spots, counts: Sequence[int]) -> float:
        """:meth:`_hits` of a part's spots from how many are free per turn (the same sum: a part's spots of
        one turn weigh alike, so the free spots' weights are those counts of each turn's weight, in order)."""
        return self.search.samples * _repeated_sum(spots.turn_weights, tuple(counts))

    def _below(self, approx: float, terms: int, bound: float, exact: Callable[[], float]) -> bool:
        """Whether ``samples`` times a sum of weights is below a bound, from the sum ``approx`` taken in any
        order (of ``terms`` non-negative weights summing to at most 1) where that is far enough from the
        bound for the rounding of either sum not to matter, else from ``exact()``, the sum as numpy takes it."""
        samples = self.search.samples
        value = samples * approx
        if abs(value - bound) > 1e-15 * samples * terms + 1e-12:
            return value < bound
        return samples * exact() < bound

    def _hits_below(self, spots: _Spots, mask: np.ndarray, bound: float) -> tuple[bool, bool]:
        """Whether :meth:`_hits` of the spots in ``mask`` is below a bound (decided as :meth:`_below` does),
        and whether there is any such spot."""
        total, found = _kernels().weight_sum(mask, spots.weight)
        return self._below(total, len(mask), bound, lambda: float(spots.weight[mask].sum())), found

    def _too_few(self, spots: _Spots) -> bool:
        """Whether the tests not involving other objects already leave too few of the planner's samples
        (with room for rounding: the free spots' sum is then below ``min_hits`` whatever they are)."""
        return self._hits_below(spots, spots.keep, self.search.min_hits - 1e-9)[0]

    def _enough(self, spots: _Spots, free: np.ndarray) -> bool:
        """Whether enough of the planner's first-try samples land on free spots (and there is one)."""
        below, found = self._hits_below(spots, free, self.search.min_hits)
        return not below and found

    def _free(self, k: int, spots: _Spots, present: np.ndarray, placed: _Placed) -> np.ndarray:
        """Object k's free spots, given which objects are still where the scene has them and the
        rectangles of those already moved."""
        others = present.copy()
        others[k] = False
        g, (centres, rots, halves) = spots.grid, placed
        # one compiled call: outside the runs of the objects where they are, and of the placed rectangles
        # (:func:`samplehd.world.spot_kernels.free_spots`)
        return _kernels().free_spots(spots.keep, spots.first, spots.last, others[spots.near], spots.rots, self.half[k],
                                     rots, halves, centres, self.search.spot_margin / 2, g.base, g.axes, g.u,
                                     float(g.lo), float(g.width), len(g.v))

    def _neighbours(self, k: int, present: np.ndarray, placed: _Placed) -> np.ndarray:
        """Footprint centres of the objects other than k where they are: (N, 2)."""
        others = present.copy()
        others[k] = False
        return np.concatenate([self.centre[others], placed[0]])

    def _options(self, k: int, spots: _Spots, free: np.ndarray, neighbours: np.ndarray) -> list[int]:
        """Free spots the planner may put object k on, spread over the ones it may pick; none where
        too few of its first-try samples would land on a free spot or the gripper reaches none.

        The planner keeps its best-scored free samples and tries a few of them: here, the best free
        spots holding that many of its expected samples, of which a few far apart are returned.
        """
        g, search = spots.grid, self.search
        args = (g.on_axes, g.u, g.v, spots.centre, neighbours, *spots.score_terms, spots.turns, spots.turn,
                _SCORE_WEIGHTS, spots.shares(search.samples), placement.SPOT_ROOM_CAP, self._ranks_needed(spots),
                float(placement.SPOT_SHORTLIST), _TURN_SPREAD, placement.SPOT_OPTIONS, spots.offsets, self._base,
                self.layout.reach_min + _SURE_REACH, self.layout.reach_max - _SURE_REACH)
        # one compiled call: enough samples on free spots, the best ranked, the picks spread over them and
        # whether the reach annulus surely holds them all (:func:`samplehd.world.spot_kernels.spot_options`)
        status, ranked, count, picks, sure = _kernels().spot_options(free, spots.weight, float(search.samples),
                                                                     search.min_hits, False, *args)
        if status == 1:  # the sum of weights too near the bound to decide in any order: as numpy sums it
            if search.samples * float(spots.weight[free].sum()) < search.min_hits:
                return []
            status, ranked, count, picks, sure = _kernels().spot_options(free, spots.weight, float(search.samples),
                                                                         search.min_hits, True, *args)
        if status == 0:
            return []
        best = ranked[:count]
        if self.reach_is_annulus and sure:
            return best[picks].tolist()
        z = self.objects[k].coords[2]  # the origin's height does not change on the table
        reached = [int(best[i]) for i in picks if self.reach((*_origin(spots, best[i]), z))]
        if reached:
            return reached
        return next(([int(j)] for j in ranked[:placement.SPOT_SHORTLIST] if self.reach((*_origin(spots, j), z))),
                    [])

    def _ranks_needed(self, spots: _Spots) -> int:
        """How many best-scored spots surely hold the shortlist's samples and the shortlist itself
        (every spot holds at least the lightest spot's share of the samples; memoised on the spots)."""
        needed = spots.__dict__.get("_ranks_needed")
        if needed is None:
            least = self.search.samples * float(spots.weight.min()) if len(spots.weight) else 0.0
            needed = len(spots.weight) if least <= 0 else max(placement.SPOT_SHORTLIST,
                                                              int(1.01 * placement.SPOT_SHORTLIST / least) + 2)
            spots.__dict__["_ranks_needed"] = needed
        return needed

    def _part_spots(self, k: int, part: str) -> _Spots:
        key = ("part", k, part)
        if key not in self._memo:
            grid, centre, turn, weight, (lo, hi) = _part_grid(self.layout, self.search.part_margin, self.search.step,
                                                              part)
            _, offsets, half = self._turned(k)
            table, base = self._table, self._base
            # the tests of table_and_reach and the part's bounds, each on x or y alone or on the frame
            # origin's distance from the base: computed per turn and row, per turn and column
            keep, rel_x, rel_y = _kernels().part_keep(grid.u, grid.v, offsets, half, lo, hi, table, base)
            _in_annulus(keep, rel_x, rel_y, self.layout)
            self._memo[key] = self._spots(k, grid, lambda: centre, offsets, turn, weight, _NO_SCORE, keep.ravel(),
                                          rel_x, rel_y)
        return self._memo[key]

    def _beside_grid(self, direction: tuple[float, float]) -> tuple[Any, ...]:
        """What the spots past a reference along a direction share, whichever the objects (see
        :func:`_beside_cells`)."""
        return _beside_cells(direction, self.search.step)

    def _beside_spots(self, x: int, ref: int, direction: tuple[float, float]) -> _Spots | None:
        """Object x's spots past object ref along a direction; None where the tests on the table, the
        workspace and the distance past the reference already leave surely too few (:meth:`_too_few`
        with room for the rounding of either sum), before the reach annulus is tested."""
        key = ("beside", x, ref, direction)
        if key not in self._memo:
            d, lateral, grid_axes, dists, lats, dist, lat, turn, weight, far, v_lo, v_width = self._beside_grid(
                direction)
            ext_ref, ext_x = self._extent_along(ref, direction, False), self._extent_along(x, direction, True)
            _, offsets, half = self._turned(x)
            lo, hi = self._workspace
            # the tests per spot, each coordinate on the axes it depends on as the array expressions were
            # (:func:`samplehd.world.spot_kernels.beside_keep`); the sums of weights stay in numpy
            start = (ext_ref + ext_x) + self.search.spot_margin
            keep, cx, cy, rel_x, rel_y, kept = _kernels().beside_keep(
                d, lateral, dists, lats, start, self.centre[ref], self.origin[ref], offsets, half, lo, hi,
                self._table, self._base, self.search.relation_gap + placement.BESIDE_NEED, weight)
            centre = (cx, cy)
            if self._below(kept, len(weight), self.search.min_hits - 1e-6,
                           lambda: float(np.add.reduce(weight * keep.ravel()))):
                self._memo[key] = None
                return None
            _in_annulus(keep, rel_x, rel_y, self.layout)
            grid = _Grid(self.centre[ref] + start[:, None] * d,
                         grid_axes, dists, lats, v_lo, v_width, False)
            self._memo[key] = self._spots(x, grid, functools.partial(_flat_xy, centre, keep.shape), offsets, turn,
                                          weight, far, keep.ravel(), rel_x, rel_y)
        return self._memo[key]

    def _extent_along(self, k: int, direction: tuple[float, float], turned: bool) -> Any:
        """How far object k's footprint reaches from its centre along a direction [m], as it stands or
        after each turn ((t,)) (memoised)."""
        key = ("extent", k, direction, turned)
        if key not in self._memo:
            d = _beside_cells(direction, self.search.step)[0]
            self._memo[key] = matmul(np.abs(matmul(d, self._turned(k)[0] if turned else self.rot[k])), self.half[k])
        return self._memo[key]

    def _turned(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Object k after each turn: its rotations (t, 2, 2), frame origin less footprint centre (t, 2) and
        world-axis half sizes (t, 2) [m] (memoised)."""
        key = ("turned footprint", k)
        if key not in self._memo:
            rots = self._turned_rots(k)
            self._memo[key] = (rots, matmul(self._turn_rots, self.centre[k] - self.origin[k]),
                               matmul(np.abs(rots), self.half[k]))
        return self._memo[key]

    def _turned_rots(self, k: int) -> np.ndarray:
        """Object k's rotation after each turn (t, 2, 2) (memoised)."""
        key = ("turned", k)
        if key not in self._memo:
            self._memo[key] = matmul(self._turn_rots, self.rot[k])
        return self._memo[key]

    def _spots(self, k: int, grid: _Grid, centre: Callable[[], np.ndarray], offsets: np.ndarray, turn: np.ndarray,
               weight: np.ndarray, score: np.ndarray, keep: np.ndarray, rel_x: np.ndarray,
               rel_y: np.ndarray) -> _Spots:
        """The spots with their score terms (``score``, (m,) or (1,), and the frame origins' offsets from the
        base, (t, r or 1, c or 1)) and their overlaps with the other objects."""

        def blockers_of(spots: _Spots) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            # the objects whose rectangle, with both margins, comes within reach of the box around the
            # spots that pass the tests without other objects (the others' overlaps matter nowhere else), and
            # their runs on the rows holding such spots only: elsewhere no run is marked (no spot there can be
            # free); one compiled call (:func:`samplehd.world.spot_kernels.blockers`)
            return _kernels().blockers(spots.keep, grid.base, grid.axes, grid.u, grid.v, self.centre, self._radius, k,
                                       spots.rots, self.half[k], self.rot, self.half, self.search.spot_margin / 2,
                                       float(grid.lo), float(grid.width), len(grid.v))

        def blocked_weight_of(spots: _Spots) -> tuple[float, bool]:
            # the same objects and runs, and the weights of the spots outside them, in one compiled call
            # (:func:`samplehd.world.spot_kernels.blocked_weight`)
            return _kernels().blocked_weight(spots.keep, grid.base, grid.axes, grid.u, grid.v, self.centre,
                                             self._radius, k, spots.rots, self.half[k], self.rot, self.half,
                                             self.search.spot_margin / 2, float(grid.lo), float(grid.width),
                                             len(grid.v), spots.weight)

        # the other objects' overlaps are found when first asked for: a spot search whose tests without
        # them already leave too few spots needs none
        return _Spots(grid, centre, offsets, turn, self.turns, self._turned_rots(k), weight, (score, rel_x, rel_y),
                      keep, blockers_of, blocked_weight_of)

def _in_annulus(keep: np.ndarray, rel_x: np.ndarray, rel_y: np.ndarray, layout: TableLayout) -> None:
    """Keep (in place, keep (t, r, c)) only the spots with ``reach_min <= hypot(rel_x, rel_y) <= reach_max``
    (offsets of shapes that broadcast to keep's), with the hypotenuse taken only where the squared distance
    is too near either bound to decide it: the same answers."""
    lo, hi = layout.reach_min ** 2, layout.reach_max ** 2
    tol = 1e-9  # far above the rounding of the squares, far below any real distance
    _kernels().in_annulus(keep, rel_x, rel_y, layout.reach_min, layout.reach_max, lo, hi, lo * (1 + tol),
                          hi * (1 - tol), lo * 2 * tol, hi * 2 * tol)


def _flat_xy(coords: Sequence[Any], shape: tuple[int, ...]) -> np.ndarray:
    """Stack x and y coordinates given on axes of a (t, r, c) grid as (m, 2), in the spots' order."""
    return np.stack([np.broadcast_to(v, shape).ravel() for v in coords], -1)


@functools.lru_cache(maxsize=4096)
def _repeated_sum(values: tuple[float, ...], counts: tuple[int, ...]) -> float:
    """``sum`` of ``counts[i]`` copies of each ``values[i]``, in order, as numpy sums that array."""
    return float(np.repeat(np.array(values), counts).sum())


def _origin(spots: _Spots, j: int) -> np.ndarray:
    """Frame origin (x, y) of spot j: the footprint centre less the turned offset [m]."""
    return spots.centre[j] - spots.offsets[spots.turn[j]]


@functools.lru_cache(maxsize=32)
def _part_grid(layout: TableLayout, part_margin: float, step: float,
               part: str) -> tuple[_Grid, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A table part's grid of spots (the same for every object and scene, read only): the grid, its
    spots' centres, turns and weights, and the part's bounds shrunk by the part margin."""
    lo, hi = layout.part_bounds(part)
    lo, hi = lo + part_margin, hi - part_margin
    xs, ys = _cells(lo[0], hi[0], step), _cells(lo[1], hi[1], step)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    grid = np.stack([gx.ravel(), gy.ravel()], -1)
    turns, share, _ = _yaw_weights()
    nt = len(turns)
    turn = np.repeat(np.arange(nt), len(grid))
    centre = np.tile(grid, (nt, 1))
    weight = np.repeat(share / len(grid), len(grid))
    frame = _Grid(np.zeros((nt, 2)), np.eye(2), xs, ys, float(lo[1]), float(hi[1] - lo[1]) / len(ys), True)
    bounds = np.stack([lo, hi])
    for a in (centre, turn, weight, bounds, xs, ys, frame.base, frame.axes):
        a.setflags(write=False)
    return frame, centre, turn, weight, bounds


@functools.lru_cache(maxsize=64)
def _beside_cells(direction: tuple[float, float], step: float) -> tuple[Any, ...]:
    """What the spots past a reference along a direction share, whichever the objects and scene (read
    only): the direction and its lateral (and both as rows), the (distance, lateral offset) cells of every
    turn, flattened, their turns, weights and far penalty, and the columns' start and width."""
    d = np.asarray(direction, float)
    d /= norm(d)
    lateral = np.array([-d[1], d[0]])
    (near_dist, near_lat), (far_dist, far_lat) = placement.BESIDE_NEAR, placement.BESIDE_FAR
    dists, lats = _cells(0.0, far_dist, step), _cells(-far_lat, far_lat, step)
    dist, lat = np.meshgrid(dists, lats, indexing="ij")
    dist, lat = dist.ravel(), lat.ravel()
    near = (dist <= near_dist) & (np.abs(lat) <= near_lat)
    # half the planner's samples fall in the near box, half in the far one
    cell = 0.5 / len(dist) + np.where(near, 0.5 / max(1, int(near.sum())), 0.0)
    _, turn_share, _ = _yaw_weights()
    nt = len(turn_share)
    turn = np.repeat(np.arange(nt), len(dist))
    weight = np.repeat(turn_share, len(dist)) * np.tile(cell, nt)
    dist, lat = np.tile(dist, nt), np.tile(lat, nt)
    far = placement.SPOT_FAR_PENALTY * (np.maximum(0.0, dist - near_dist) + np.maximum(0.0, np.abs(lat) - near_lat))
    axes = np.stack([d, lateral])
    for a in (d, lateral, axes, dists, lats, dist, lat, turn, weight, far):
        a.setflags(write=False)
    return (d, lateral, axes, dists, lats, dist, lat, turn, weight, far, -far_lat, 2 * far_lat / len(lats))


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
    reach = (matmul(np.abs(matmul(axes, r1)), (np.asarray(h1) + margin / 2)[..., None])
             + matmul(np.abs(matmul(axes, r2)), (np.asarray(h2) + margin / 2)[..., None]))
    apart = np.abs(matmul(axes, (np.asarray(c2) - np.asarray(c1))[..., None]))
    return np.all(apart <= reach, axis=(-2, -1))

"""Which object to move, from the parser and the perception model (``evaluate --grounding DIR``).

The keypose network decides *how* to move (where to grasp, where the object goes) and, from its
auxiliary class map, also *which* object; on L1 pick_up it lifts the wrong one of two look-alikes
more often than it misses a grasp. Grounding keeps the two apart, as 3D-LOTUS++ and ProgramPort do:
the parser turns the instruction into a program, the perception model turns the scene camera's
RGB-D into objects with class, colour, material, size and position, and the program, run on them by
the project's executor (with the next likeliest labels where the top ones find nothing), names the
objects the instruction moves. The policy then seeks its grasp on those objects only: the cells of
its own map of the raised group (with the cells it encloses and its edge) that holds an object's
perceived position, within :data:`GROUND_RADIUS` of it.

The objects still to move are those of the task not standing where this episode let an object go
(within :data:`RELEASED_RADIUS`); the program, run again on each new view, no longer names what
``remove`` has carried off. The network chooses the order among them, as it learnt to, but for a tower
(:data:`ORDERED`), which is built from the bottom up: its first object still to move. Grounding stands
aside (the network chooses alone) when the program uses a value more often than the instruction says
it (:func:`unsaid_value`: a parse gone wrong on an unfamiliar phrasing), when the program finds no
object, when the instruction names classes and perception calls an object to move none of them, or when
no raised cell of the map lies at the objects.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage

from samplehd.envs.tokens import tokenize
from samplehd.language.lexicon import default_lexicon
from samplehd.learn.keypose.exclusion import classes_said, raised_groups
from samplehd.learn.neurosymbolic import SCENE_MODALITIES, perceived_task
from samplehd.learn.parser import InstructionParser
from samplehd.learn.perception import Perception
from samplehd.learn.topdown import TopDownGrid
from samplehd.render.renderer import SceneRenderer, camera_intrinsics, camera_pose
from samplehd.scene.annotate import SceneAnnotation

__all__ = ["GROUND_RADIUS", "ORDERED", "RELEASED_RADIUS", "Grounded", "ProgramGrounding", "grounded_cells",
           "next_to_move", "still_to_move", "unsaid_value"]

GROUND_RADIUS = 0.08  # the grasp is sought on map cells this close to the object's perceived position [m]
RELEASED_RADIUS = 0.04  # an object this close to where the episode let one go has been moved [m]
ORDERED = frozenset({"stack_three"})  # the program actions whose objects are moved in the task's order


class Grounded(dict):
    """What grounding found for one decision (copied into the diagnosis): ``program`` (the parser's),
    ``objects`` (the perceived objects the task moves: name and x, y), ``targets`` (x, y of those the
    grasp is sought on; empty when grounding stood aside) and ``why`` (why it stood aside, when it did)."""


_FILTERS = {"filter_name": "name", "filter_shape": "name", "filter_colour": "colour", "filter_color": "colour",
            "filter_material": "material", "filter_size": "size"}


def _times_said(tokens: Sequence[str], phrases: Sequence[str]) -> int:
    n = 0
    for phrase in set(phrases):
        words = tokenize(phrase)
        n += sum(list(tokens[i:i + len(words)]) == words for i in range(len(tokens) - len(words) + 1))
    return n


def unsaid_value(program: Sequence[str], instruction: str) -> str | None:
    """The first value of ``program`` (a flat program's tokens, action first) that it uses more often than
    ``instruction`` says it, or None. Each filter's value counts once, and the action's (a part, a
    relation) once where the instruction says it at all: ``remove``'s destination goes unsaid ("Empty
    the right part" is ``place[left] scene filter_table[right]``). A class is said by its noun, singular
    or plural; a colour, material or size by its word (``medium-sized``); anything else by itself."""
    tokens = tokenize(instruction)
    lexicon = default_lexicon()
    need: dict[tuple[str, str], int] = {}
    for k, token in enumerate(program):
        op, _, rest = token.partition("[")
        if not rest.endswith("]"):
            continue
        kind = _FILTERS.get(op, "" if op.startswith("filter_") or k > 0 else "action")
        need[(kind, rest[:-1])] = need.get((kind, rest[:-1]), 0) + 1
    said: dict[str, int] = {}
    for (kind, value), n in need.items():
        if kind == "name":
            phrases: Sequence[str] = lexicon.nouns.get(value, (value.replace("_", " "),))
        elif kind in ("colour", "material", "size"):
            phrases = (lexicon.adjectives.get(kind, {}).get(value, value),)
        else:
            phrases = (value.replace("_", " "),)
        times = _times_said(tokens, phrases)
        said[value] = said.get(value, 0) + (0 if kind == "action" and times == 0 else n)
        if said[value] > times:
            return value
    return None


def still_to_move(moved: Sequence[Sequence[float]], released: Sequence[Sequence[float]]) -> list[int]:
    """The indices of ``moved`` (x, y [m] of the task's objects) that stand farther than
    :data:`RELEASED_RADIUS` from every point of ``released`` (x, y), in order."""
    return [i for i, xy in enumerate(moved)
            if all(np.hypot(xy[0] - r[0], xy[1] - r[1]) > RELEASED_RADIUS for r in released)]


def next_to_move(moved: Sequence[Sequence[float]], released: Sequence[Sequence[float]]) -> int | None:
    """The first of :func:`still_to_move`, or None."""
    left = still_to_move(moved, released)
    return left[0] if left else None


def grounded_cells(grid: np.ndarray, xy: Sequence[float], coarse: TopDownGrid, factor: int) -> np.ndarray | None:
    """The cells of the network's map (``coarse``: rows × cols, bool) the grasp of the object perceived
    at ``xy`` is sought in: those of the raised group of cells (:func:`raised_groups` of the grid image
    ``grid``, with the cells it encloses and a cell around it) nearest to ``xy`` that lie within
    :data:`GROUND_RADIUS` of it; None when no such cell does."""
    _, raised = raised_groups(grid, coarse.rows, coarse.cols, factor)
    # a group's cells the camera does not see into (a mug's or a bowl's inside) and its rim's edge cells
    # belong to it: the grasp of a mug is often there
    groups = [ndimage.binary_fill_holes(ndimage.binary_dilation(g)) for g in raised]
    centres = coarse.world(*np.meshgrid(np.arange(coarse.rows), np.arange(coarse.cols), indexing="ij"))
    near = np.hypot(centres[..., 0] - xy[0], centres[..., 1] - xy[1])
    best: tuple[float, np.ndarray] | None = None
    for cells in groups:
        close = cells & (near <= GROUND_RADIUS)
        if close.any() and (best is None or near[close].min() < best[0]):
            best = (float(near[close].min()), close)
    return None if best is None else best[1]


class ProgramGrounding:
    """The parser and perception model of ``models`` (a folder with ``parser/`` and ``perception/`` from
    ``samplehd train``), grounding a keypose policy's decisions.

    Args:
        models: the folder.
        device: where the networks run (None: the CPU).
    """

    def __init__(self, models: str | Path, device: Any = None) -> None:
        self.models = Path(models)
        self.parser = InstructionParser.load(self.models / "parser", device)
        self.perception = Perception.load(self.models / "perception", device)
        self.classes = tuple(default_lexicon().nouns)
        self._renderer: Any = None
        self._renderer_model: Any = None
        self._programs: dict[str, list[str]] = {}

    def program(self, instruction: str) -> list[str]:
        """The parser's flat program of ``instruction`` (kept per text: an episode asks again after each
        release)."""
        if instruction not in self._programs:
            self._programs[instruction] = list(self.parser.parse([instruction])[0].flat)
        return self._programs[instruction]

    def perceive(self, env: Any) -> SceneAnnotation:
        """The perception model's scene annotation of the scene camera's current view of ``env``."""
        u = env.unwrapped
        image = self.perception.config.image
        w, h, cam = image.width, image.height, image.camera
        if self._renderer_model is not u.model:
            self.close()
            self._renderer = SceneRenderer(u.model, w, h, "fast")
            self._renderer_model = u.model
            self._renderer.render(u.data, cam, SCENE_MODALITIES)  # a context's first frame differs
        images = self._renderer.render(u.data, cam, SCENE_MODALITIES)
        camera = {"width": w, "height": h, "intrinsics": camera_intrinsics(u.model, cam, w, h).tolist(),
                  "extrinsics": camera_pose(u.model, u.data, cam).tolist()}
        directions = (getattr(u, "episode", None) and u.episode.annotation.get("directions")) or None
        return self.perception.perceive(images["rgb"], images["depth"], camera, directions)

    def target(self, instruction: str, env: Any, released: Sequence[Sequence[float]]) -> Grounded:
        """The object the instruction moves next in ``env``'s current scene (``released``: x, y [m] where
        this episode let objects go)."""
        program = self.program(instruction)
        found = Grounded(program=" ".join(program), objects=[], targets=[])
        unsaid = unsaid_value(program, instruction)
        if unsaid is not None:
            found["why"] = f"the program uses {unsaid!r} more often than the instruction says it"
            return found
        perceived = self.perceive(env)
        task = perceived_task(program, perceived)
        if task is None or not task["objects"]:
            found["why"] = "the program finds no object"
            return found
        objects: list[Mapping[str, Any]] = [perceived["objects"][i] for i in task["objects"]]
        moved = [tuple(float(v) for v in o["3d_coords"][:2]) for o in objects]
        found["objects"] = [[o["name"], round(x, 3), round(y, 3)] for o, (x, y) in zip(objects, moved, strict=True)]
        left = still_to_move(moved, released)
        if not left:
            found["why"] = "every object it moves stands where one was let go"
            return found
        if task["type"] in ORDERED:
            left = left[:1]
        named = classes_said(instruction, self.classes)
        wrong = sorted({objects[k]["name"] for k in left} - named) if named else []
        if wrong:
            found["why"] = f"the instruction names {sorted(named)}, not {wrong}"
            return found
        found["targets"] = [[round(moved[k][0], 4), round(moved[k][1], 4)] for k in left]
        return found

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
            self._renderer_model = None

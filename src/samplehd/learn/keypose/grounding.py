"""Which object to move, from the parser and the perception model (``evaluate --grounding DIR``).

The keypose network decides *how* to move (where to grasp, where the object goes) and, from its
auxiliary class map, also *which* object; on L1 pick_up it lifts the wrong one of two look-alikes
more often than it misses a grasp. Grounding keeps the two apart, as 3D-LOTUS++ and ProgramPort do:
the parser turns the instruction into a program, the perception model turns the scene camera's
RGB-D into objects with class, colour, material, size and position, and the program, run on them by
the project's executor (with the next likeliest labels where the top ones find nothing), names the
objects the instruction moves, in order. The policy then seeks its grasp on the object to move next
only: the raised cells of its own map that hold that object's perceived position, within
:data:`GROUND_RADIUS` of it.

The object to move next is the first of the task's objects not standing where this episode let an
object go (within :data:`RELEASED_RADIUS`): a tower's middle object once set down is not lifted
again, and the program, run again on the current view, no longer names what ``remove`` has carried
off. Grounding stands aside (the network chooses alone) when the program finds no object, when the
instruction names classes and the perception model calls the object none of them (a parse gone wrong
on an unfamiliar phrasing), or when the object's position holds no raised cell of the map.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.language.lexicon import default_lexicon
from samplehd.learn.keypose.exclusion import classes_said, raised_groups
from samplehd.learn.neurosymbolic import SCENE_MODALITIES, perceived_task
from samplehd.learn.parser import InstructionParser
from samplehd.learn.perception import Perception
from samplehd.learn.topdown import TopDownGrid
from samplehd.render.renderer import SceneRenderer, camera_intrinsics, camera_pose
from samplehd.scene.annotate import SceneAnnotation

__all__ = ["GROUND_RADIUS", "RELEASED_RADIUS", "Grounded", "ProgramGrounding", "grounded_cells", "next_to_move"]

GROUND_RADIUS = 0.08  # the grasp is sought on map cells this close to the object's perceived position [m]
RELEASED_RADIUS = 0.04  # an object this close to where the episode let one go has been moved [m]


class Grounded(dict):
    """What grounding found for one decision (copied into the diagnosis): ``program`` (the parser's),
    ``objects`` (the perceived objects the task moves: name and x, y), ``target`` (the one to move next,
    or None) and ``why`` (why grounding stood aside, when it did)."""


def next_to_move(moved: Sequence[Sequence[float]], released: Sequence[Sequence[float]]) -> int | None:
    """The index of the first of ``moved`` (x, y [m], in the order the task moves them) that stands
    farther than :data:`RELEASED_RADIUS` from every point of ``released`` (x, y), or None."""
    for i, xy in enumerate(moved):
        if all(np.hypot(xy[0] - r[0], xy[1] - r[1]) > RELEASED_RADIUS for r in released):
            return i
    return None


def grounded_cells(grid: np.ndarray, xy: Sequence[float], coarse: TopDownGrid, factor: int) -> np.ndarray | None:
    """The cells of the network's map (``coarse``: rows × cols, bool) the grasp of the object perceived
    at ``xy`` is sought in: those of the raised group of cells (:func:`raised_groups` of the grid image
    ``grid``) nearest to ``xy`` that lie within :data:`GROUND_RADIUS` of it; None when no raised cell
    does."""
    _, groups = raised_groups(grid, coarse.rows, coarse.cols, factor)
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
        perceived = self.perceive(env)
        found = Grounded(program=" ".join(program), objects=[], target=None)
        task = perceived_task(program, perceived)
        if task is None or not task["objects"]:
            found["why"] = "the program finds no object"
            return found
        objects: list[Mapping[str, Any]] = [perceived["objects"][i] for i in task["objects"]]
        moved = [tuple(float(v) for v in o["3d_coords"][:2]) for o in objects]
        found["objects"] = [[o["name"], round(x, 3), round(y, 3)] for o, (x, y) in zip(objects, moved, strict=True)]
        k = next_to_move(moved, released)
        if k is None:
            found["why"] = "every object it moves stands where one was let go"
            return found
        named = classes_said(instruction, self.classes)
        if named and objects[k]["name"] not in named:
            found["why"] = f"the instruction names {sorted(named)}, not {objects[k]['name']!r}"
            return found
        found["target"] = list(moved[k])
        return found

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
            self._renderer_model = None

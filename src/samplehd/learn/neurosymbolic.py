"""The neuro-symbolic closed-loop policy: parse the instruction, perceive the scene, run the program
with the project's executor on the perceived scene, then plan and act with the project's planner,
one action per ``env.step``.

Stages and where a failure is charged (``policy.diagnosis``, copied into evaluation records):

- ``parse``: the predicted program, run on the true scene annotation, gives another task;
- ``perception``: the true program, run on the perceived scene, gives another task;
- ``execution``: each alone was right but together they pick another task (or none);
- ``motion``: the task was right and the planner or the physics did not finish it.

The perceived objects that a task names are handed to the planner as the simulator's objects nearest
to their perceived positions (within ``match_radius``): the planner plans grasps on the simulator's
object models, and perception decides which objects and where to. With ``perception="gt"`` the
episode's own scene annotation is used; with ``programs="gt"`` the instruction's own program.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.envs.oracle import OraclePolicy
from samplehd.errors import ConfigError, SamplehdError
from samplehd.language.executor import ProgramError, execute
from samplehd.language.scene import parse_scene
from samplehd.learn.parser import InstructionParser
from samplehd.learn.perception import Perception
from samplehd.learn.training import set_seed
from samplehd.render.renderer import SceneRenderer, camera_intrinsics, camera_pose
from samplehd.scene.annotate import ObjectAnnotation, SceneAnnotation
from samplehd.tasks.task import ProgramTask, family_of_program, parse_task

__all__ = ["NeuroSymbolicPolicy", "policy_for_evaluation"]

_CHOICES = ("gt", "predicted")


def _describe(obj: ObjectAnnotation) -> str:
    """One object of a scene annotation in a few words, for the reports: ``small red metal mug @ (x, y)``."""
    x, y = obj["3d_coords"][:2]
    return f"{obj['size']} {obj['colour']} {obj['material']} {obj['name']} @ ({x:.3f}, {y:.3f})"


_FILTERS = {"filter_name": "name", "filter_shape": "name", "filter_color": "colour", "filter_colour": "colour",
            "filter_material": "material", "filter_size": "size"}
_MIN_SCORE = 0.05  # an alternative label below this probability is not tried
_MAX_TRIES = 8


def _relabel(scene: SceneAnnotation, changes: Sequence[tuple[int, str, str]]) -> SceneAnnotation:
    objects = [dict(o) for o in scene["objects"]]
    for i, attr, value in changes:
        objects[i][attr] = value
        if attr == "name":
            objects[i]["shape"] = value
        if attr == "colour":
            objects[i]["color"] = value
    return {**scene, "objects": objects}


def _relaxed(program: Sequence[str], perceived: SceneAnnotation,
             run: Callable[[list[str], Any], ProgramTask | None]) -> ProgramTask | None:
    """Run ``program`` on the perceived scene with the next most likely labels where its top labels fail.

    A filter of the program that finds no object (or too many) is retried with one or two objects
    relabelled: an object given the filter's value where the perception model found it likely, or an
    object that has it given its own next likeliest value, most probable changes first (the
    probabilistic execution of neuro-symbolic VQA, in its simplest form).
    """
    scores = perceived.get("attribute_scores") or []
    moves: list[tuple[float, int, str, str]] = []
    for token in program:
        name, _, rest = token.partition("[")
        attr = _FILTERS.get(name)
        if attr is None or not rest.endswith("]"):
            continue
        value = rest[:-1]
        for i, (obj, sc) in enumerate(zip(perceived["objects"], scores, strict=False)):
            probs = sc.get(attr, {})
            if obj[attr] != value and probs.get(value, 0.0) >= _MIN_SCORE:
                moves.append((probs[value], i, attr, value))
            elif obj[attr] == value:
                others = sorted(((q, v) for v, q in probs.items() if v != value), reverse=True)
                if others and others[0][0] >= _MIN_SCORE:
                    moves.append((others[0][0], i, attr, others[0][1]))
    moves = sorted(set(moves), reverse=True)[:_MAX_TRIES]
    tries = [[m] for m in moves] + [[a, b] for k, a in enumerate(moves) for b in moves[k + 1:] if a[1] != b[1]]
    for changes in tries:
        try:
            scene = parse_scene(_relabel(perceived, [(i, attr, v) for _, i, attr, v in changes]))
        except SamplehdError:
            continue
        task = run(list(program), scene)
        if task is not None:
            return task
    return None


def _same(a: ProgramTask | None, b: ProgramTask) -> bool:
    return a is not None and all(a.get(k) == b.get(k) for k in ("type", "objects", "subject", "relation"))


# The modalities of the dataset's scene images, which perception was trained on: asked for together, depth
# comes from the segmentation pass, where glass is opaque; depth from the RGB pass alone sees through
# transparent geoms (glasses, wine glasses), which perception then misses.
SCENE_MODALITIES = ("rgb", "depth", "segmentation")


class NeuroSymbolicPolicy(OraclePolicy):
    """Parser + perception + executor + planner, acting through the environment's step.

    Args:
        env: the environment.
        models: folder with ``parser/`` and ``perception/`` (from ``samplehd train``).
        programs: ``predicted`` (the parser) or ``gt`` (the instruction's program).
        perception: ``predicted`` (the perception model on the scene camera) or ``gt``.
        match_radius: largest distance [m] between a perceived object and the simulator object it stands for.
    """

    def __init__(self, env: Any, models: str | Path | None = None, programs: str = "predicted",
                 perception: str = "predicted", match_radius: float = 0.08, seed: int = 0) -> None:
        super().__init__(env, seed=seed)
        for name, value in (("programs", programs), ("perception", perception)):
            if value not in _CHOICES:
                raise ConfigError(f"{name}={value!r}: valid: {', '.join(_CHOICES)}", field=name)
        self.programs, self.perception_mode, self.match_radius = programs, perception, match_radius
        self.parser = self.perception = None
        if "predicted" in (programs, perception) and models is None:
            raise ConfigError("models: needed for predicted programs or perception (a folder with parser/ and "
                              "perception/ from `samplehd train`)", field="models")

        set_seed(seed)
        if programs == "predicted":

            self.parser = InstructionParser.load(Path(models) / "parser")
        if perception == "predicted":

            self.perception = Perception.load(Path(models) / "perception")
        self._renderer: Any = None
        self._renderer_model: Any = None
        self._decided: tuple[Any, Any] | None = None
        self.diagnosis: dict[str, Any] = {}

    # ------------------------------------------------------------------ stages
    def _scene_image(self) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
        env = self.env
        image = self.perception.config.image
        w, h, cam = image.width, image.height, image.camera
        if self._renderer_model is not env.model:
            if self._renderer is not None:
                self._renderer.close()
            self._renderer = SceneRenderer(env.model, w, h, "fast")
            self._renderer_model = env.model
            self._renderer.render(env.data, cam, SCENE_MODALITIES)  # first frame of a context differs
        images = self._renderer.render(env.data, cam, SCENE_MODALITIES)
        camera = {"width": w, "height": h, "intrinsics": camera_intrinsics(env.model, cam, w, h).tolist(),
                  "extrinsics": camera_pose(env.model, env.data, cam).tolist()}
        return images["rgb"], images["depth"], camera

    def _decide(self) -> tuple[Any, dict[str, Any]]:
        """(planner task or None, diagnosis) for the current episode."""
        ep = self.env.episode
        gt_task = dict(ep.instruction["task"])
        gt_program = str(ep.instruction["program_sequence"]).split()
        gt_scene = parse_scene(ep.annotation)
        diag: dict[str, Any] = {"programs": self.programs, "perception": self.perception_mode}

        program = gt_program
        if self.parser is not None:
            program = list(self.parser.parse([ep.text])[0].flat)
            diag["program"] = " ".join(program)

        def run(prog: list[str], scene: Any) -> ProgramTask | None:
            try:
                return execute(prog, scene).to_program_dict()
            except (ProgramError, ValueError):
                return None

        mapping: list[int] | None = None
        if self.perception is not None:
            rgb, depth, camera = self._scene_image()
            perceived = self.perception.perceive(rgb, depth, camera, ep.annotation.get("directions"))
            scene = parse_scene(perceived)
            model, data = self.env.model, self.env.data
            bodies = np.array([data.xpos[model.body(f"object_{i}").id][:2] for i in range(len(ep.scene.objects))])
            mapping = []
            for o in perceived["objects"]:
                d = np.linalg.norm(bodies - np.asarray(o["3d_coords"][:2]), axis=1)
                mapping.append(int(np.argmin(d)) if d.min() <= self.match_radius else -1)
            diag["perceived_objects"] = len(perceived["objects"])
            diag["perceived"] = [_describe(o) for o in perceived["objects"]]
            diag["true"] = [_describe(o) for o in ep.annotation["objects"]]
        else:
            scene = gt_scene

        def grounded(task: ProgramTask | None) -> ProgramTask | None:
            if task is None or mapping is None:
                return task
            objs = [mapping[i] for i in task["objects"]]
            subj = task["subject"]
            if isinstance(subj, int):
                subj = mapping[subj]
            if min(objs + ([subj] if isinstance(subj, int) else [])) < 0:
                return None
            return {**task, "objects": objs, "subject": subj}

        def decide(prog: list[str]) -> ProgramTask | None:
            task = grounded(run(prog, scene))
            if task is None and self.perception is not None:  # a filter found no object, or too many
                task = grounded(_relaxed(prog, perceived, run))
            return task

        chosen = decide(program)
        parse_ok = self.parser is None or _same(run(program, gt_scene), gt_task)
        perception_ok = self.perception is None or _same(decide(gt_program), gt_task)
        diag["task_correct"] = _same(chosen, gt_task)
        diag["parse_ok"], diag["perception_ok"] = parse_ok, perception_ok
        if not diag["task_correct"]:
            diag["stage"] = "parse" if not parse_ok else ("perception" if not perception_ok else "execution")
        if chosen is None:
            return None, diag
        try:
            return parse_task(chosen, family_of_program(chosen["type"], program)), diag
        except Exception as exc:  # noqa: BLE001 - a malformed predicted task is a failed decision
            diag["error"] = str(exc)
            return None, diag

    # ------------------------------------------------------------------ policy API
    def episode_task(self) -> Any:
        decided = self._decided
        if decided is None or decided[0] is not self.env.episode:
            raise ConfigError("the neuro-symbolic policy has not decided a task for this episode")
        return decided[1]

    def __call__(self, obs: Any = None) -> np.ndarray:
        env = self.env
        if self._decided is None or self._decided[0] is not env.episode:
            task, diag = self._decide()
            self._decided = (env.episode, task)
            self.diagnosis = diag
            if task is None:
                self.reset()
                self.failure = f"no task: {diag.get('stage', 'execution')}"
                self._finished = True
                self._episode = env.episode
        if self._decided[1] is None:
            return self._hold_action()
        return super().__call__(obs)

    def reset(self, seed: int | None = None) -> None:
        renderer, self._renderer = self._renderer, None  # the base reset closes the plan, not the camera
        super().reset(seed)
        self._renderer = renderer

    def close(self) -> None:
        super().close()
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def policy_for_evaluation(env: Any, config: Any) -> NeuroSymbolicPolicy:
    """The policy ``samplehd evaluate --policy neurosymbolic`` runs (``config``: its EvalConfig)."""
    return NeuroSymbolicPolicy(env, config.models, programs=config.programs, perception=config.perception)

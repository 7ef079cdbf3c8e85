"""Episode specifications: which scene, which instruction; drawn from a generator or given.

An :class:`EpisodeSpec` is everything an environment episode starts from. :func:`sample_episode`
draws one from an explicit generator (the environment's ``np_random``); :func:`episode_from_options`
rebuilds one from a scene and an instruction (dicts as written in scenes.json / instructions.json,
or the library's objects) so that a dataset episode can be reproduced exactly.

Scene sampling and compilation are the expensive part of a reset; :class:`SceneCache` memoises
both per scene (the sampler is a deterministic function of its seed and config).
"""

from __future__ import annotations

import copy
import json
import os
from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from samplehd.dataset.reader import DatasetReader
from samplehd.envs.scene_worker import sample_in_child
from samplehd.errors import ConfigError, SamplehdError, SceneError
from samplehd.language.executor import execute
from samplehd.language.generator import generate_instructions
from samplehd.language.instruction_file import InstructionEntry
from samplehd.motion.assist import compile_scene_with_assist
from samplehd.scene.annotate import SceneAnnotation, annotate_scene
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import sample_scene
from samplehd.scene.spec import SceneSpec, compile_scene
from samplehd.scene.world import OPERATOR_CAMERA, SCENE_CAMERA
from samplehd.tasks.task import parse_task
from samplehd.world.seeding import scene_seed as pool_seed

__all__ = ["EpisodeSpec", "SceneCache", "episode_from_options", "sample_episode"]

# Scenes tried before giving up on finding an instruction of the drawn family.
_SCENE_TRIES = 12
# Sampled scenes shared by every environment of the process: sampling is a deterministic function of
# (seed, index, config), and costs seconds (settling, occlusion renders).
_SAMPLED: OrderedDict[tuple[int, int, str], SceneSpec] = OrderedDict()
_SAMPLED_MAX = 256


@dataclass(frozen=True)
class EpisodeSpec:
    """What one episode starts from.

    Attributes:
        scene: the scene (objects, settled poses, camera).
        instruction: the instruction entry: ``instruction`` (text), ``family``, ``task``
            (executor dict), ``targets``, ``program`` (CLEVR nodes), ``program_sequence``.
        annotation: the CLEVR-layout scene dict the instruction refers to (directions, objects).
        initial_state: optional ``{qpos, qvel, act}`` arrays replacing the compiled initial state.
    """

    scene: SceneSpec
    instruction: InstructionEntry
    annotation: SceneAnnotation = field(default_factory=SceneAnnotation)
    initial_state: dict[str, np.ndarray] | None = None

    @property
    def family(self) -> str:
        return str(self.instruction["family"])

    @property
    def text(self) -> str:
        return str(self.instruction["instruction"])


class SceneCache:
    """Memoises sampled scenes (by seed, process-wide) and compiled models (by scene, per cache),
    least recently used first out.

    Args:
        config: scene sampler options.
        size: compiled scenes kept.
        timestep: physics timestep of compiled models [s].
        grasp_welds: compile with the (inactive) grasp-assist welds.
        gl_free: sample scenes in a child process (:mod:`samplehd.envs.scene_worker`), so that this
            process makes no GL context (the sampler's occlusion check renders); same scenes either way.
    """

    def __init__(self, config: SceneConfig, size: int = 8, timestep: float = 0.002, grasp_welds: bool = False,
                 gl_free: bool = False) -> None:
        self.config = config
        self.gl_free = gl_free
        self.grasp_welds = grasp_welds
        self.size = size
        self.timestep = timestep
        self._config_key = json.dumps(config.to_dict(), sort_keys=True)
        self._models: OrderedDict[str, tuple[mujoco.MjModel, mujoco.MjData]] = OrderedDict()
        self._annotations: dict[str, SceneAnnotation] = {}

    def scene(self, seed: int, index: int = 0) -> SceneSpec:
        """The scene sampled from ``seed`` (cached)."""
        key = (int(seed), int(index), self._config_key)
        if key in _SAMPLED:
            _SAMPLED.move_to_end(key)
            return _SAMPLED[key]
        if self.gl_free:
            scene = sample_in_child(index, seed, self.config)
        else:
            scene = sample_scene(index, seed, self.config).scene
        _SAMPLED[key] = scene
        while len(_SAMPLED) > _SAMPLED_MAX:
            _SAMPLED.popitem(last=False)
        return scene

    def compiled(self, scene: SceneSpec) -> tuple[mujoco.MjModel, mujoco.MjData, bool]:
        """(model, pristine initial data, whether the model is new) of a scene (cached).

        The pristine data must not be modified: copy it into a working MjData.
        """
        key = json.dumps(scene.to_dict(), sort_keys=True)
        if key in self._models:
            self._models.move_to_end(key)
            model, data = self._models[key]
            return model, data, False
        if self.grasp_welds:
            model, data = compile_scene_with_assist(scene, self.timestep)
        else:
            model, data = compile_scene(scene, self.timestep)
        mujoco.mj_forward(model, data)
        self._models[key] = (model, data)
        while len(self._models) > self.size:
            old, _ = self._models.popitem(last=False)
            self._annotations.pop(old, None)
        return model, data, True

    def annotation(self, scene: SceneSpec) -> SceneAnnotation:
        """The scene's CLEVR-layout annotation (cached with the compiled model; a private copy)."""
        model, data, _ = self.compiled(scene)
        key = json.dumps(scene.to_dict(), sort_keys=True)
        if key not in self._annotations:
            self._annotations[key] = _annotation(scene, model, data)
        return copy.deepcopy(self._annotations[key])


def _annotation(scene: SceneSpec, model: mujoco.MjModel, data: mujoco.MjData) -> SceneAnnotation:
    camera = SCENE_CAMERA if scene.camera.name == SCENE_CAMERA else OPERATOR_CAMERA.name
    return annotate_scene(scene, model, data, 640, 360, camera=camera)


def _instruction_entry(instruction: Any) -> InstructionEntry:
    d = dict(instruction.to_dict())
    d["task"] = dict(d["task"])
    return d


def sample_episode(
    rng: np.random.Generator,
    cache: SceneCache,
    families: tuple[str, ...],
    *,
    family: str | None = None,
    num_scenes: int = 0,
    scene_seed: int = 0,
) -> EpisodeSpec:
    """Draw a scene and an instruction of a uniformly drawn family.

    Args:
        rng: the only source of randomness.
        cache: scene cache (sampling config and compiled models).
        families: families to draw from.
        family: use this family instead of drawing one.
        num_scenes: 0 for a fresh scene seed per episode, else the size of the scene pool.
        scene_seed: base seed of the scene pool.

    Raises:
        SceneError: no scene in several tries allowed an instruction of the family.
    """
    drawn = family is None
    if family is None:
        family = families[int(rng.integers(len(families)))]
    elif family not in families:
        raise ConfigError(f"episode family {family!r} is not among the environment's families {list(families)}")
    last: tuple[SceneSpec, SceneAnnotation] | None = None
    for _ in range(_SCENE_TRIES):
        if num_scenes:
            index = int(rng.integers(num_scenes))
            seed = pool_seed(scene_seed, index)
        else:
            index, seed = 0, int(rng.integers(2**31 - 1))
        scene = cache.scene(seed, index)
        ann = cache.annotation(scene)
        sub = np.random.default_rng(int(rng.integers(2**63 - 1)))
        made = generate_instructions(ann, sub, per_scene=1, families=[family]).instructions
        if made:
            return EpisodeSpec(scene, _instruction_entry(made[0]), ann)
        last = (scene, ann)
    if drawn and last is not None:
        # Rare families (stack_three needs three stackable objects) fall back to another family
        # on the last scene, in a random order, rather than failing the reset.
        scene, ann = last
        for k in rng.permutation(len(families)):
            sub = np.random.default_rng(int(rng.integers(2**63 - 1)))
            made = generate_instructions(ann, sub, per_scene=1, families=[families[int(k)]]).instructions
            if made:
                return EpisodeSpec(scene, _instruction_entry(made[0]), ann)
    raise SceneError(f"no instruction of family {family!r} in {_SCENE_TRIES} sampled scenes; "
                     "allow more objects (scene.max_objects) or other families")


def _as_scene(value: Any) -> SceneSpec:
    if isinstance(value, SceneSpec):
        return value
    if isinstance(value, Mapping):
        # A scenes.json entry carries the exact spec under "spec"; a bare SceneSpec dict is the spec.
        return SceneSpec.from_dict(dict(value.get("spec", value)))
    raise SceneError(f"reset option 'scene' must be a SceneSpec or a scene dict, got {type(value).__name__}")


def _dataset_options(options: Mapping[str, Any]) -> dict[str, Any]:
    """Resolve ``dataset`` + ``episode_index`` into the scene, instruction and recorded episode."""
    if "dataset" not in options or "episode_index" not in options:
        given = "dataset" if "dataset" in options else "episode_index"
        raise ConfigError(f"reset: option {given!r}={options[given]!r:.80}: 'dataset' (a dataset folder) and "
                          f"'episode_index' (an integer) go together; give both")
    if {"scene", "instruction", "episode"} & set(options):
        raise ConfigError("reset: give either 'dataset' + 'episode_index' or 'scene' + 'instruction' (+ 'episode')")
    index = options["episode_index"]
    if not isinstance(index, (int, np.integer)) or isinstance(index, bool):
        raise ConfigError(f"reset: option 'episode_index' must be an integer, got {index!r}")
    folder = options["dataset"]
    if not isinstance(folder, (str, os.PathLike)) or not str(folder):
        raise ConfigError(f"reset: option 'dataset'={folder!r:.80}: must be a dataset folder (a path: str or "
                          f"pathlib.Path), got {type(folder).__name__}")
    reader = DatasetReader(folder)
    episode = reader.episode(int(index), images="none")
    entry = reader.episodes[int(index)]
    out = {"scene": reader.scene(entry.scene_index), "instruction": reader.instruction(int(index)),
           "episode": episode}
    if "family" in options:
        out["family"] = options["family"]
    return out


def _task_objects(task: Mapping[str, Any], family: Any, count: int) -> list[int]:
    """The objects a task names (moved ones and its reference), each checked to be one of the
    scene's ``count`` objects, given as distinct integers."""
    raw = task.get("objects")
    if isinstance(raw, (list, tuple)):
        if any(not isinstance(i, (int, np.integer)) or isinstance(i, bool) for i in raw):
            raise ConfigError(f"reset: instruction task objects {list(raw)!r}: must be object indices (integers "
                              f"0..{count - 1})")
        if len(set(raw)) != len(raw):
            raise ConfigError(f"reset: instruction task objects {list(raw)!r}: names an object twice; give each once")
    try:
        parsed = parse_task(dict(task), family if isinstance(family, str) else None)
    except (SamplehdError, KeyError, TypeError, ValueError) as exc:
        raise ConfigError(f"reset: instruction task {dict(task)!r}: {str(exc).splitlines()[0]}") from None
    named = [*parsed.objects] + ([parsed.reference] if parsed.reference != -1 else [])
    bad = [i for i in named if not 0 <= i < count]
    if bad:
        raise ConfigError(f"reset: instruction task names object(s) {bad}, but the scene has objects "
                          f"0..{count - 1}")
    return sorted(named)


def episode_from_options(options: Mapping[str, Any], cache: SceneCache) -> EpisodeSpec:
    """Rebuild an episode from reset options.

    Options:
        scene: a ``SceneSpec``, its dict, or a scenes.json entry (with ``spec``).
        instruction: an instructions.json entry or ``Instruction`` (needs ``instruction`` text and
            ``task`` or ``program``; ``family`` defaults to the task type).
        episode: optional recorded ``Episode`` (``samplehd.record.episode``) or a mapping with
            ``qpos``/``qvel``/``act`` arrays: the episode starts from its first frame's state.
        dataset, episode_index: instead of the three above, a dataset directory (``samplehd
            generate``) and an episode index in it: its scene, instruction and first state.

    Raises:
        ConfigError: a required option is missing or malformed.
    """
    unknown = sorted(set(options) - {"scene", "instruction", "episode", "family", "dataset", "episode_index"})
    if unknown:
        raise ConfigError(f"reset: unknown option(s) {unknown}; valid: dataset, episode, episode_index, family, "
                          "instruction, scene")
    if "dataset" in options or "episode_index" in options:
        options = _dataset_options(options)
    if "scene" not in options or "instruction" not in options:
        raise ConfigError("reset: options need both 'scene' and 'instruction' to reproduce an episode")
    scene = _as_scene(options["scene"])
    model, pristine, _ = cache.compiled(scene)
    ann = cache.annotation(scene)
    raw = options["instruction"]
    if not hasattr(raw, "to_dict") and not isinstance(raw, Mapping):
        raise ConfigError(f"reset: option 'instruction' must be an instructions.json entry (a dict), got "
                          f"{type(raw).__name__}")
    entry = _instruction_entry(raw) if hasattr(raw, "to_dict") else dict(raw)
    if not isinstance(entry.get("instruction"), str) or not entry["instruction"].strip():
        raise ConfigError("reset: option 'instruction' needs the instruction text under key 'instruction'")
    program = entry.get("program") or entry.get("program_sequence")
    executed = None
    if program:
        # The program must run on this scene: an instruction made for another scene is refused.
        try:
            executed = execute(program, ann).to_program_dict()
        except (KeyError, TypeError, ValueError, IndexError, SceneError, ConfigError) as exc:
            raise ConfigError(f"reset: the instruction {entry['instruction']!r} does not fit the scene: its program "
                              f"fails on it ({str(exc).splitlines()[0][:160]})") from None
    if "task" not in entry:
        if executed is None:
            raise ConfigError("reset: option 'instruction' needs a 'task' or a 'program'")
        entry["task"] = executed
    if not isinstance(entry["task"], Mapping):
        raise ConfigError(f"reset: instruction 'task' must be a dict (type, objects, subject), got "
                          f"{type(entry['task']).__name__}")
    task = dict(entry["task"])
    named = _task_objects(task, entry.get("family"), len(scene.objects))
    if executed is not None and _task_objects(executed, entry.get("family"), len(scene.objects)) != named:
        raise ConfigError(f"reset: the instruction's task names objects {named}, but its program picks other "
                          "objects in this scene; the instruction was made for another scene")
    entry["task"] = task
    entry.setdefault("family", str(task.get("type", "")).split("[")[0])
    entry.setdefault("targets", list(task.get("objects", [])) + (
        [task["subject"]] if isinstance(task.get("subject"), int) else []))
    entry.setdefault("program", [])
    entry.setdefault("program_sequence", "")
    state = None
    ep = options.get("episode")
    if ep is not None:
        frames = getattr(ep, "frames", ep)
        try:
            state = {k: np.array(frames[k][0] if np.ndim(frames[k]) == 2 else frames[k], dtype=float)
                     for k in ("qpos", "qvel", "act")}
        except (KeyError, TypeError, IndexError) as exc:
            raise ConfigError(f"reset: option 'episode' needs qpos, qvel and act frames ({exc})") from None
        sizes = {"qpos": model.nq, "qvel": model.nv, "act": model.na}
        if any(state[k].shape != (n,) for k, n in sizes.items()):
            raise ConfigError("reset: option 'episode' does not match the scene (qpos/qvel/act sizes differ)")
    check_start_state(model, pristine, state, len(scene.objects))
    return EpisodeSpec(scene, entry, ann, state)


# How deep two objects may interpenetrate at the start [m]: resting contacts of a sampled scene are
# a fraction of a millimetre deep.
_MAX_PENETRATION = 0.003


def check_start_state(model: mujoco.MjModel, pristine: mujoco.MjData, state: Mapping[str, np.ndarray] | None,
                      num_objects: int) -> None:
    """Refuse a start state (given, or the scene's own) that physics cannot start from: non-finite
    values, robot joints outside their limits, or two objects inside each other.

    Raises:
        ConfigError: one line naming the field (qpos, qvel, act) or the objects.
    """
    data = mujoco.MjData(model)
    mujoco.mj_copyData(data, model, pristine)
    if state is not None:
        for key, values in state.items():
            bad = np.flatnonzero(~np.isfinite(values))
            if bad.size:
                raise ConfigError(f"reset: option 'episode' {key}[{int(bad[0])}] is {values[bad[0]]}: the start "
                                  f"state must be finite")
        for j in np.flatnonzero(model.jnt_limited):
            if int(model.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
                value, (lo, hi) = state["qpos"][model.jnt_qposadr[j]], model.jnt_range[j]
                if not lo - 1e-3 <= value <= hi + 1e-3:
                    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
                    raise ConfigError(f"reset: option 'episode' qpos of joint {name} is {value:.4g}, outside its "
                                      f"range {lo:.4g}..{hi:.4g}")
        data.qpos[:], data.qvel[:], data.act[:] = state["qpos"], state["qvel"], state["act"]
    mujoco.mj_forward(model, data)
    owner = {int(model.body(f"object_{i}").id): i for i in range(num_objects)}
    for c in data.contact[:data.ncon]:
        a, b = (owner.get(int(model.body_rootid[model.geom_bodyid[g]])) for g in (c.geom1, c.geom2))
        if a is not None and b is not None and a != b and c.dist < -_MAX_PENETRATION:
            raise ConfigError(f"reset: objects {min(a, b)} and {max(a, b)} of the scene are {-c.dist * 1000:.0f} mm "
                              f"inside each other; give them poses apart (sample_scene finds free spots)")

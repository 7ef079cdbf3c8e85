"""Robustness axes: a suite episode changed along one axis, at strengths 1–5, beside its clean twin.

Strength 0 is the clean twin itself: the same scene seed, scene and instruction. A variant differs from
its twin only in what its axis names (:data:`AXIS_FIELDS`), by an amount set by the strength in the
physical units below, in a direction drawn from ``SeedSequence([seed, axis, twin, strength, attempt])``:

================  ===========================================================  ==================
axis              what changes                                                 per strength step
================  ===========================================================  ==================
``camera``        the scene camera turns about the vertical through its         6° (5: 30°; the
                  look-at point (``scene.camera.pos``)                          training cone is ±12°)
``object_shift``  every object moves by one horizontal offset before the        1.5 cm (5: 7.5 cm)
                  episode (``scene.objects[*].pos``); their layout is kept
``robot_start``   each arm joint starts off its home angle by the step, in a    0.05 rad (5:
                  drawn sign, within its limits (``start_state``)               0.25 rad, 14°)
``sensor``        RGB noise and blur, depth noise and holes on the images a        RGB σ 4 levels
                  policy sees (``sensor``; :mod:`samplehd.benchmark.sensor`)    (of 255), blur σ
                                                                                0.4 px, depth σ
                                                                                2 mm, 4 % holes
``paraphrase``    words of the instruction's synonym groups (``synonyms.json``:  20 % of those
                  put/place/set, move/shift/slide, pick up/lift/grab, ...)      words (5: every
                  become another member of their group (``instruction``)        one)
``shuffled``      words of the instruction trade places (``instruction``):      20 % of the words
                  a shortcut control (5: every word moved, the words kept)      (5: 100 %)
``blank``         words of the instruction are dropped (``instruction``): a     20 % of the words
                  shortcut control; at 5 none is left and the instruction is    (5: all; the text
                  :data:`BLANK_INSTRUCTION`, the full stop alone                is ``.``)
``lighting``      the scene lights (``scene.lighting``,                         intensity ×(1 ±
                  :class:`samplehd.scene.world.Lighting`): every light dimmer   0.12), key light
                  or brighter, the key light turned about the vertical          15°, tint ±0.06 on
                  through the table centre, every light warmer or cooler        red and blue (5:
                  (red up and blue down, or the reverse)                        ×0.4 or ×1.6, 75°,
                                                                                1.3 / 0.7)
``distractors``  objects added after the scene's own, in free spots as the      one object (5: five)
                  sampler places its own, settled (``scene.objects``): every
                  second one of a class already on the table; the scene's own
                  objects keep their poses. A variant whose instruction no
                  longer picks only its own objects (a same-class distractor
                  made a description ambiguous) is rejected
``textures``      the table's wood and the walls' plaster and tiles                hue 30°, saturation
                  (``scene.surfaces``, :class:`samplehd.scene.world.Surfaces`),  ×(1 + 0.4) or ÷,
                  each surface moved in HSV: hue turned, saturation raised or   brightness ×(1 ±
                  lowered, brightness raised or lowered, each in a drawn        0.1) (5: 150°, ×3
                  direction                                                     or ÷3, ×1.5 or 0.5)
``verbs``         as ``paraphrase``, the verb groups only (put/place/set,        20 % of those
                  move/shift/slide, stack, pick up/lift/grab; ``words.json``)   words (5: every one)
``nouns``         as ``paraphrase``, the noun groups only (side/part/half)      20 % of those words
``unseen_synonyms`` verbs and nouns the generator says become words it never     20 % of those
                  says (``words.json``: put → lay/deposit, mug → cup, chopping  words (5: every one)
                  board → breadboard, side → area, ...)
``unseen_objects`` objects of the scene, the task's first, become objects of the   one object (5: five)
                  held-out class (food_box) placed in free spots; the
                  instruction is drawn again keeping each object's role
                  (``scene.objects``, ``instruction``, ``task``, ``program``,
                  ``program_sequence``, ``targets``)
``imported_objects`` as ``unseen_objects``, but the new objects are of the       one object (5: five)
                  shipped pack's imported classes (bottle, bread, lemon; one
                  drawn per object), which no scene draws unless it names them
``task_swap``     another instruction of the same family and level on the same   the candidate at
                  scene, naming other objects (``instruction``, ``task``,       quantile (s − 1)/4
                  ``program``, ``program_sequence``, ``targets``): of up to     of word distance
                  16 drawn candidates, ordered by their word distance to the    (5: the least
                  twin's text (1 − Jaccard of the lower-case word sets)         alike; 1: the most)
================  ===========================================================  ==================

The environment's instruction is never empty (its ``Text`` space has ``min_length=1``, and a reset refuses
an empty text), so a blank instruction is the neutral token ``.``: no word, the full stop every
instruction ends with (tokens ``<START> . <END>``).

An axis whose change cannot alter physics (``camera``, ``lighting``, ``textures``, ``sensor``, ``paraphrase``,
``verbs``, ``nouns``, ``unseen_synonyms``, ``shuffled``, ``blank``: the
oracle acts on state and the task, never on images or text) keeps its twin's oracle proof: the same
rollout, bit for bit. A physical axis (``object_shift``, ``robot_start``, ``distractors``, ``task_swap``,
``unseen_objects``, ``imported_objects``) is proven again
by the oracle through the env; a variant it fails, or that cannot be made (:class:`~samplehd.errors.SceneError`
from :func:`perturb`), is replaced by the next attempt's. A variant that would
equal its twin (an instruction with no word of a synonym group) is left out.
"""

from __future__ import annotations

import copy
import functools
import math
import re
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any, TypedDict

import numpy as np

from samplehd.catalogue.loader import pack_classes
from samplehd.envs.episodes import SceneCache, episode_from_options
from samplehd.envs.suite_file import EpisodeRecord, SuiteEpisode
from samplehd.errors import AssetError, ConfigError, SceneError
from samplehd.fileio import read_json
from samplehd.language.generator import generate_instructions
from samplehd.language.levels import HELD_OUT_CLASSES, episode_level
from samplehd.language.templates import default_synonyms
from samplehd.motion.execute import initial_state
from samplehd.robot.constants import JOINT_NAMES
from samplehd.robot.controller import ControlConfig
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import add_objects
from samplehd.scene.spec import SceneSpec, compile_scene
from samplehd.scene.world import Lighting, Surfaces

__all__ = ["AXES", "AXIS_FIELDS", "BLANK_INSTRUCTION", "PHYSICAL_AXES", "STRENGTHS", "WORDS_FILE",
           "changed_fields", "check_instruction_fits", "language_words", "perturb"]

STRENGTHS = (1, 2, 3, 4, 5)
CAMERA_DEG_PER_STRENGTH = 6.0
SHIFT_M_PER_STRENGTH = 0.015
SHUFFLE_FRACTION_PER_STRENGTH = 0.2
JOINT_RAD_PER_STRENGTH = 0.05
TASK_SWAP_CANDIDATES = 16
UNSEEN_OBJECT_CANDIDATES = 48
LIGHT_INTENSITY_PER_STRENGTH = 0.12
LIGHT_TURN_DEG_PER_STRENGTH = 15.0
LIGHT_TINT_PER_STRENGTH = 0.06
TEXTURE_HUE_DEG_PER_STRENGTH = 30.0
TEXTURE_SATURATION_PER_STRENGTH = 0.4
TEXTURE_VALUE_PER_STRENGTH = 0.1
# The words of the language axes: synonym groups by part of speech, and words the generator never says.
WORDS_FILE = Path(__file__).resolve().parent / "words.json"
# A blanked instruction: the env admits no empty text, and "." carries no word (see the module docstring).
BLANK_INSTRUCTION = "."


def _camera(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    cam = ep["scene"]["camera"]
    pos, target = np.asarray(cam["pos"], float), np.asarray(cam["target"], float)
    angle = math.radians(CAMERA_DEG_PER_STRENGTH * strength) * (1.0 if rng.random() < 0.5 else -1.0)
    dx, dy = pos[0] - target[0], pos[1] - target[1]
    c, s = math.cos(angle), math.sin(angle)
    cam["pos"] = [float(target[0] + c * dx - s * dy), float(target[1] + s * dx + c * dy), float(pos[2])]


def _object_shift(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    heading = rng.uniform(0.0, 2.0 * math.pi)
    dx, dy = (SHIFT_M_PER_STRENGTH * strength * f(heading) for f in (math.cos, math.sin))
    for obj in ep["scene"]["objects"]:
        obj["pos"] = [float(obj["pos"][0] + dx), float(obj["pos"][1] + dy), float(obj["pos"][2])]


def _lighting(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    brighter, turn, warmer = (1.0 if v < 0.5 else -1.0 for v in rng.random(3))
    tint = LIGHT_TINT_PER_STRENGTH * strength * warmer
    ep["scene"]["lighting"] = Lighting(intensity=1.0 + brighter * LIGHT_INTENSITY_PER_STRENGTH * strength,
                                       turn=turn * LIGHT_TURN_DEG_PER_STRENGTH * strength,
                                       tint=(1.0 + tint, 1.0, 1.0 - tint)).to_dict()


def _textures(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    turn, more, brighter = (np.where(rng.random((3, 2)) < 0.5, 1.0, -1.0))
    hue = turn * TEXTURE_HUE_DEG_PER_STRENGTH * strength
    saturation = (1.0 + TEXTURE_SATURATION_PER_STRENGTH * strength) ** more
    value = 1.0 + brighter * TEXTURE_VALUE_PER_STRENGTH * strength
    ep["scene"]["surfaces"] = Surfaces(
        table_hue=float(hue[0]), table_saturation=float(saturation[0]), table_value=float(value[0]),
        wall_hue=float(hue[1]), wall_saturation=float(saturation[1]), wall_value=float(value[1])).to_dict()


def _distractors(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    scene = SceneSpec.from_dict(ep["scene"])
    config = SceneConfig(catalogue=ep["catalogue"])
    present = sorted({o.instance.class_name for o in scene.objects})
    crowded = add_objects(scene, [present if k % 2 else None for k in range(strength)], rng, config)
    ep["scene"] = crowded.to_dict()
    check_instruction_fits(ep)


def check_instruction_fits(ep: EpisodeRecord) -> None:
    """Raise a SceneError unless the episode's program, run on its scene, picks the task's objects (the
    env's own check on a ``scene`` + ``instruction`` reset): an added object may make a description
    ambiguous ("the scissors" beside a second pair) or make it pick another object."""
    try:
        episode_from_options(SuiteEpisode.from_dict({"id": 0, **ep}).reset_options(),
                             SceneCache(SceneConfig(catalogue=ep["catalogue"])))
    except ConfigError:
        raise SceneError("the instruction no longer picks only its own objects") from None


def _words(text: str) -> set[str]:
    return set(re.findall(r"[a-z]+", text.lower()))


def _task_swap(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    scene = SceneSpec.from_dict(ep["scene"])
    annotation = SceneCache(SceneConfig(catalogue=ep["catalogue"])).annotation(scene)
    made = generate_instructions(annotation, rng, per_scene=TASK_SWAP_CANDIDATES, families=[ep["family"]])
    own = _words(ep["instruction"])
    found = []
    for ins in (i.to_dict() for i in made.instructions):
        if sorted(ins["targets"]) != sorted(ep["targets"]) and episode_level(ins, annotation) == ep["level"]:
            words = _words(ins["instruction"])
            found.append((1.0 - len(own & words) / len(own | words), len(found), ins))
    if not found:
        raise SceneError("no other instruction of the family and level on this scene")
    found.sort(key=lambda c: c[:2])
    ins = found[round((strength - 1) / (len(STRENGTHS) - 1) * (len(found) - 1))][2]
    ep.update(instruction=ins["instruction"], task=dict(ins["task"]), program=list(ins["program"]),
              program_sequence=str(ins["program_sequence"]), targets=[int(t) for t in ins["targets"]])


def _unseen_objects(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    _replace_objects(ep, strength, rng, lambda count: [sorted(HELD_OUT_CLASSES)] * count)


def _imported_objects(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    pack = pack_classes()
    _replace_objects(ep, strength, rng, lambda count: [[pack[int(k)]] for k in rng.integers(len(pack), size=count)],
                     pack)


def _replace_objects(ep: EpisodeRecord, strength: int, rng: np.random.Generator,
                     draw: Callable[[int], list[list[str]]], named: tuple[str, ...] = ()) -> None:
    """Take ``strength`` objects of the scene away (the task's first, in their order in ``targets``),
    place as many objects of the classes ``draw(count)`` gives (one list of classes per object) in free
    spots, and draw the instruction again so that each object keeps its role. ``named``: imported
    classes the replacements are drawn from (they join the catalogue by name)."""
    scene = SceneSpec.from_dict(ep["scene"])
    config = SceneConfig(catalogue=ep["catalogue"], classes=named)
    targets = [int(t) for t in ep["targets"]]
    order = list(dict.fromkeys([*targets, *range(len(scene.objects))]))  # the task's objects first
    gone = order[:min(strength, len(order))]
    kept = [i for i in range(len(scene.objects)) if i not in gone]
    rest = replace(scene, objects=tuple(scene.objects[i] for i in kept))
    new = add_objects(rest, draw(len(gone)), rng, config)
    index = {old: k for k, old in enumerate(kept)} | {old: len(kept) + k for k, old in enumerate(gone)}
    want = [index[t] for t in targets]  # in the twin's order: each object keeps its role
    annotation = SceneCache(config).annotation(new)
    made = generate_instructions(annotation, rng, per_scene=UNSEEN_OBJECT_CANDIDATES, families=[ep["family"]])
    own = _words(ep["instruction"])
    found = []
    for ins in (i.to_dict() for i in made.instructions):
        if [int(t) for t in ins["targets"]] == want:
            words = _words(ins["instruction"])
            found.append((1.0 - len(own & words) / len(own | words), len(found), ins))
    if not found:
        raise SceneError("no instruction of the family gives the objects the twin's roles")
    ins = min(found, key=lambda c: c[:2])[2]
    ep.update(scene=new.to_dict(), instruction=ins["instruction"], task=dict(ins["task"]),
              program=list(ins["program"]), program_sequence=str(ins["program_sequence"]), targets=want)


def _robot_start(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    # The state the twin starts from (the arm at home, the gripper open), only the arm's joints moved.
    model, data = compile_scene(SceneSpec.from_dict(ep["scene"]))
    initial_state(model, data, ControlConfig())
    qpos = data.qpos.copy()
    for name, sign in zip(JOINT_NAMES, rng.choice([-1.0, 1.0], size=len(JOINT_NAMES)), strict=True):
        joint = model.joint(name)
        lo, hi = model.jnt_range[joint.id]
        adr = int(model.jnt_qposadr[joint.id])
        qpos[adr] = float(np.clip(qpos[adr] + sign * JOINT_RAD_PER_STRENGTH * strength, lo, hi))
    ep["start_state"] = {"qpos": [float(v) for v in qpos], "qvel": [float(v) for v in data.qvel],
                         "act": [float(v) for v in data.act]}


def _sensor(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    ep["sensor"] = {"rgb_noise": 4.0 * strength, "rgb_blur": 0.4 * strength, "depth_noise": 0.002 * strength,
                    "depth_holes": 0.04 * strength}


class LanguageWords(TypedDict):
    """The language axes' words (:data:`WORDS_FILE`): per part of speech (``verbs``, ``nouns``) the seen
    synonym group names, and each unseen word's replacements."""

    seen_groups: dict[str, tuple[str, ...]]
    unseen: dict[str, dict[str, tuple[str, ...]]]


@functools.cache
def language_words() -> LanguageWords:
    """The language axes' words (:data:`WORDS_FILE`): ``seen_groups`` (``verbs``, ``nouns``: synonym group
    names of ``synonyms.json``) and ``unseen`` (``verbs``, ``nouns``: word -> words the generator never
    says).

    Raises:
        AssetError: the file is unreadable or lacks those keys.
    """
    words = read_json(WORDS_FILE, AssetError)
    try:
        groups = {pos: tuple(words["seen_groups"][pos]) for pos in ("verbs", "nouns")}
        unseen = {pos: {str(k): tuple(v) for k, v in words["unseen"][pos].items()} for pos in ("verbs", "nouns")}
    except (KeyError, TypeError, AttributeError) as exc:
        raise AssetError(f"{WORDS_FILE}: missing or malformed key {exc}; it needs seen_groups.verbs/nouns "
                         "and unseen.verbs/nouns") from None
    return {"seen_groups": groups, "unseen": unseen}


def _alternatives(groups: tuple[str, ...] | None = None) -> dict[str, tuple[str, ...]]:
    """Each synonym-group member -> the other members of the first group holding it (``put`` is also a
    ``stack`` synonym, but ``stack`` is not a ``put`` synonym); only the groups named in ``groups``
    (default: all)."""
    out: dict[str, tuple[str, ...]] = {}
    for name, members in default_synonyms().items():
        if groups is None or name in groups:
            for word in members:
                out.setdefault(word, tuple(m for m in members if m != word))
    return out


def _swap_words(ep: EpisodeRecord, alternatives: Mapping[str, tuple[str, ...]], strength: int,
                rng: np.random.Generator) -> None:
    """Replace a share of the instruction's words (or phrases) that have alternatives, longest first,
    each by one alternative drawn uniformly; the share is 20 % per strength step (5: every one)."""
    pattern = re.compile(r"\b(" + "|".join(sorted(map(re.escape, alternatives), key=len, reverse=True)) + r")\b",
                         re.IGNORECASE)
    text = ep["instruction"]
    found = list(pattern.finditer(text))
    if not found:
        return
    count = min(len(found), max(1, round(SHUFFLE_FRACTION_PER_STRENGTH * strength * len(found))))
    chosen = set(rng.choice(len(found), size=count, replace=False).tolist())
    out, last = [], 0
    for i, m in enumerate(found):
        word = m.group(0)
        out.append(text[last:m.start()])
        if i in chosen:
            options = alternatives[word.lower()]
            new = options[int(rng.integers(len(options)))]
            word = new[0].upper() + new[1:] if word[0].isupper() else new
        out.append(word)
        last = m.end()
    ep["instruction"] = "".join(out) + text[last:]


def _paraphrase(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    _swap_words(ep, _alternatives(), strength, rng)


def _verbs(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    _swap_words(ep, _alternatives(language_words()["seen_groups"]["verbs"]), strength, rng)


def _nouns(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    _swap_words(ep, _alternatives(language_words()["seen_groups"]["nouns"]), strength, rng)


def _unseen_synonyms(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    unseen = language_words()["unseen"]
    _swap_words(ep, {**unseen["verbs"], **unseen["nouns"]}, strength, rng)


def _shuffled(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    text = ep["instruction"].rstrip(".")
    words = text.split()
    moved = min(len(words), max(2, round(SHUFFLE_FRACTION_PER_STRENGTH * strength * len(words))))
    picks = sorted(rng.choice(len(words), size=moved, replace=False).tolist())
    perm = rng.permutation(moved)
    while np.any(perm == np.arange(moved)):  # a derangement: every picked word leaves its place
        perm = rng.permutation(moved)
    order = [picks[int(i)] for i in perm]
    out = list(words)
    for src, dst in zip(picks, order, strict=True):
        out[dst] = words[src]
    ep["instruction"] = " ".join(out) + ("." if ep["instruction"].endswith(".") else "")


def _blank(ep: EpisodeRecord, strength: int, rng: np.random.Generator) -> None:
    words = ep["instruction"].rstrip(".").split()
    dropped = min(len(words), max(1, round(SHUFFLE_FRACTION_PER_STRENGTH * strength * len(words))))
    gone = set(rng.choice(len(words), size=dropped, replace=False).tolist())
    kept = [w for i, w in enumerate(words) if i not in gone]
    ep["instruction"] = " ".join(kept) + "." if kept else BLANK_INSTRUCTION


AXES: dict[str, Callable[[EpisodeRecord, int, np.random.Generator], None]] = {
    "camera": _camera, "lighting": _lighting, "object_shift": _object_shift, "robot_start": _robot_start,
    "sensor": _sensor, "paraphrase": _paraphrase, "shuffled": _shuffled, "blank": _blank,
    "distractors": _distractors, "task_swap": _task_swap, "textures": _textures, "verbs": _verbs,
    "nouns": _nouns, "unseen_synonyms": _unseen_synonyms, "unseen_objects": _unseen_objects,
    "imported_objects": _imported_objects}
# The episode fields (dotted paths) each axis may change; a variant equals its twin elsewhere.
AXIS_FIELDS = {"camera": ("scene.camera",), "lighting": ("scene.lighting",), "object_shift": ("scene.objects",),
               "robot_start": ("start_state",), "sensor": ("sensor",), "paraphrase": ("instruction",),
               "shuffled": ("instruction",), "blank": ("instruction",), "distractors": ("scene.objects",),
               "task_swap": ("instruction", "task", "program", "program_sequence", "targets"),
               "textures": ("scene.surfaces",), "verbs": ("instruction",), "nouns": ("instruction",),
               "unseen_synonyms": ("instruction",),
               "unseen_objects": ("scene.objects", "instruction", "task", "program", "program_sequence", "targets"),
               "imported_objects": ("scene.objects", "instruction", "task", "program", "program_sequence",
                                    "targets")}
PHYSICAL_AXES = ("object_shift", "robot_start", "distractors", "task_swap", "unseen_objects", "imported_objects")
# An axis's index in the seed of its directions: the first six sorted, then the others as they were added,
# so an axis draws the same directions when another is added.
_SEED_ORDER = ("camera", "object_shift", "paraphrase", "robot_start", "sensor", "shuffled", "blank", "lighting",
               "distractors", "task_swap", "textures", "verbs", "nouns", "unseen_synonyms", "unseen_objects",
               "imported_objects")


def changed_fields(twin: Mapping[str, Any], variant: Mapping[str, Any]) -> set[str]:
    """The fields in which two episode dicts differ, a scene's one level down (``scene.objects``): a
    variant's, less ``id``, ``axis``, ``strength``, ``twin`` and ``oracle_steps``, are within its axis'
    :data:`AXIS_FIELDS`."""
    out = set()
    for key in set(twin) | set(variant):
        if key == "scene":
            a, b = twin.get(key) or {}, variant.get(key) or {}
            out |= {f"scene.{k}" for k in set(a) | set(b) if a.get(k) != b.get(k)}
        elif twin.get(key) != variant.get(key):
            out.add(key)
    return out


def perturb(twin: EpisodeRecord, axis: str, strength: int, seed: int, attempt: int = 0) -> EpisodeRecord:
    """The variant of a clean episode dict (a suite episode without ``id``) on ``axis`` at ``strength``.

    The variant's ``axis``, ``strength`` and ``twin`` are set; ``twin`` must carry its ``id``.

    Raises:
        SceneError: this attempt's variant cannot be made (``distractors``: no free spot, an object of
            the scene hidden, or the instruction made ambiguous; ``task_swap``: no other instruction of the
            family and level on the scene); another ``attempt`` may succeed.
    """
    ep = copy.deepcopy(twin)
    axis_index = _SEED_ORDER.index(axis)
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), axis_index, int(twin["id"]), int(strength),
                                                        int(attempt)]))
    AXES[axis](ep, strength, rng)
    ep.update(axis=axis, strength=int(strength), twin=int(twin["id"]))
    ep.pop("id", None)
    return ep

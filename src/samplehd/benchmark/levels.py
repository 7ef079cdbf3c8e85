"""VIMA-style generalisation levels: which episodes a level evaluates and which data training leaves out.

=====  ===============================================  =============================================
level  episodes evaluated                               left out of training (learned models)
=====  ===============================================  =============================================
L1     seen templates and objects, new placements       nothing beyond the dataset's test scenes
L2     a target object has a held-out colour–class      instances of those combinations (perception
       combination                                      attributes; episodes moving them)
L3     the instruction is a held-out text variant       instructions realised from those variants
       (paraphrase) of its template                     (parser, policy)
L4     a target object is of a held-out class           instances of those classes (perception
                                                        attributes; episodes moving them)
=====  ===============================================  =============================================

L1 keeps every other held-out item out as well, so it measures in-distribution skill. Episodes of a
level are drawn by rejection from the same seeded split as plain evaluation: reset seeds
``SeedSequence([seed, k, attempt])`` until the episode is in the level (:func:`reset_at_level`). A
suite build draws differently (:func:`instruction_at_level`): it keeps a scene whose first
instruction is of another level and draws more instructions of the family on it, so an episode of a
level costs a scene sampling only when the scene has none.
Training code calls :func:`held_out_instruction` and :func:`held_out_object` to drop the items a
level holds out, so every model's L2–L4 numbers are on things it never saw. The classification itself
lives in :mod:`samplehd.language.levels` (the LeRobot export uses it too); this module draws episodes.
"""

from __future__ import annotations

import zlib
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from samplehd.catalogue import catalogue_for, object_facts
from samplehd.envs.episodes import SceneCache
from samplehd.errors import ConfigError
from samplehd.language.generator import generate_instructions, may_have_family
from samplehd.language.levels import (
    HELD_OUT_CLASSES,
    HELD_OUT_COMBINATIONS,
    HELD_OUT_VARIANT,
    LEVELS,
    episode_level,
    held_out_for,
    held_out_instruction,
    held_out_object,
    text_variants,
)
from samplehd.language.scene import SceneObject

__all__ = [
    "HELD_OUT_CLASSES",
    "HELD_OUT_COMBINATIONS",
    "HELD_OUT_VARIANT",
    "LEVELS",
    "episode_level",
    "held_out_for",
    "held_out_instruction",
    "held_out_object",
    "in_level",
    "instruction_at_level",
    "pose_free_objects",
    "reset_at_level",
    "text_variants",
]


def in_level(instruction: Mapping[str, Any], annotation: Mapping[str, Any], level: str) -> bool:
    """Whether an episode is one of ``level``'s."""
    if level not in LEVELS:
        raise ConfigError(f"level={level!r}: valid: {', '.join(LEVELS)}", field="level")
    return episode_level(instruction, annotation) == level


def reset_at_level(env: Any, seed: int, family: str, level: str | None, max_attempts: int = 400
                   ) -> tuple[Any, dict[str, Any], int]:
    """Reset ``env`` to the first episode of ``family`` in ``level`` among seeds derived from ``seed``.

    Returns:
        (observation, info, reset seed used). With ``level`` None the plain ``seed`` is used.

    Raises:
        ConfigError: no episode of the level among ``max_attempts`` seeds (e.g. a family whose
            targets never have a held-out class).
    """
    if level is None:
        obs, info = env.reset(seed=seed, options={"family": family})
        return obs, info, seed
    if level not in LEVELS:
        raise ConfigError(f"level={level!r}: valid: {', '.join(LEVELS)}", field="level")
    for attempt in range(max_attempts):
        s = int(np.random.SeedSequence([int(seed), 7, attempt]).generate_state(1, np.uint32)[0])
        obs, info = env.reset(seed=s, options={"family": family})
        ep = env.unwrapped.episode
        if in_level(ep.instruction, ep.annotation, level):
            return obs, info, s
    raise ConfigError(f"level={level!r}: no {family} episode of this level in {max_attempts} seeds", field="level")


def _may_have_level(scene: Any, level: str) -> bool:
    """Whether a scene has an object that a target of an L2 or L4 episode must be (always for L1, L3)."""
    objects = [{"name": o.instance.class_name, "colour": o.instance.colour} for o in scene.objects]
    if level == "L4":
        return any(o["name"] in HELD_OUT_CLASSES for o in objects)
    if level == "L2":
        return any(held_out_object(o) and o["name"] not in HELD_OUT_CLASSES for o in objects)
    return True


def pose_free_objects(scene: Any, cache: SceneCache) -> list[SceneObject]:
    """The scene's objects as instructions see them, with what their classes and sizes fix (affordances,
    extents, flat top, opening) as the scene's annotation gives it, and dummy poses."""
    catalogue = catalogue_for(cache.config.named_classes, cache.config.catalogue)
    out = []
    for i, o in enumerate(scene.objects):
        inst = o.instance
        facts = object_facts(inst, catalogue)
        aff = facts.affordances
        out.append(SceneObject(
            index=i, name=inst.class_name, colour=inst.colour, material=inst.material, size=inst.size,
            table_part=(), coords=(0.0, 0.0, 0.0), extents=tuple(float(v) for v in facts.extents),
            graspable=aff.graspable, handle_pickable=aff.handle_pickable, container=aff.container,
            stackable_on=aff.stackable_on, stackable=aff.stackable,
            opening_radius=facts.opening_radius, top_extent=facts.top_extent))
    return out


def instruction_at_level(cache: SceneCache, scene_seeds: Iterable[int], family: str, level: str,
                         per_scene: int = 8, rounds: int = 1) -> tuple[Any, dict[str, Any], int]:
    """The first episode of ``family`` in ``level`` among the scenes sampled from ``scene_seeds``.

    On each scene up to ``per_scene`` distinct instructions of the family are drawn, as a reset draws
    one (:func:`samplehd.language.generator.generate_instructions`, from a generator seeded by the
    scene seed and the family), and the first of the level is taken; when none is, up to ``rounds - 1``
    more rounds are drawn, round ``r`` from a generator seeded by the scene seed, the family and ``r``
    (a scene with only a task or two of a rare family then also says them in their other text
    variants: an L3 episode needs the held-out one); a scene with none gives way to the next seed.
    Scenes and their annotations come from ``cache``, so cells that share scene seeds sample each
    scene once.

    Args:
        cache: the environment's scene cache (its sampler options make the scenes).
        scene_seeds: scene seeds, tried in order.
        family: the task family.
        level: L1–L4.
        per_scene: instructions drawn per round.
        rounds: rounds of drawing per scene (1: the first round only).

    Returns:
        (scene, instruction entry, scene seed): reset the environment with
        ``options={"scene": scene, "instruction": entry}`` and the scene seed as its seed.

    Raises:
        ConfigError: an unknown level, or no episode of the level on any of the scenes.
    """
    if level not in LEVELS:
        raise ConfigError(f"level={level!r}: valid: {', '.join(LEVELS)}", field="level")
    tried = 0
    for seed in scene_seeds:
        tried += 1
        scene = cache.scene(int(seed))
        if not _may_have_level(scene, level):
            continue  # no object a target of the level could be: skip the scene's annotation and compilation
        if not may_have_family(pose_free_objects(scene, cache), family):
            continue  # e.g. no three objects that stack: no task of the family, wherever the objects stand
        annotation = cache.annotation(scene)
        for r in range(rounds):
            rng = np.random.default_rng([int(seed), zlib.crc32(family.encode()), *([r] if r else [])])
            made = generate_instructions(annotation, rng, per_scene=per_scene, families=[family]).instructions
            for instruction in made:
                entry = instruction.to_dict()
                if episode_level(entry, annotation) == level:
                    return scene, entry, int(seed)
            if not made:
                break  # no task of the family on the scene: another round draws none either
    raise ConfigError(f"level={level!r}: no {family} episode of this level on {tried} scenes", field="level")

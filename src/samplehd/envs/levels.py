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
``SeedSequence([seed, k, attempt])`` until the episode is in the level (:func:`reset_at_level`).
Training code calls :func:`held_out_instruction` and :func:`held_out_object` to drop the items a
level holds out, so every model's L2–L4 numbers are on things it never saw.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from functools import cache
from typing import Any

import numpy as np

from samplehd.errors import ConfigError
from samplehd.language.templates import default_synonyms, default_templates

__all__ = [
    "HELD_OUT_CLASSES",
    "HELD_OUT_COMBINATIONS",
    "HELD_OUT_VARIANT",
    "LEVELS",
    "episode_level",
    "held_out_instruction",
    "held_out_object",
    "in_level",
    "reset_at_level",
    "text_variants",
]

LEVELS = ("L1", "L2", "L3", "L4")
# Combinations of classes and colours that have many colours each, so both stay well represented.
HELD_OUT_COMBINATIONS: frozenset[tuple[str, str]] = frozenset(
    {("red", "mug"), ("blue", "plate"), ("green", "bowl"), ("yellow", "soda_can"), ("purple", "thermos")})
HELD_OUT_CLASSES: frozenset[str] = frozenset({"food_box"})
# The last text variant of every template is the held-out paraphrase.
HELD_OUT_VARIANT = -1

_OPTIONAL = re.compile(r"\[([^\[\]]*)\]")
_SYNONYM = re.compile(r"\{([A-Za-z0-9_]+)\}")
_PLACEHOLDER = re.compile(r"<([A-Za-z0-9_]+)(?::([a-z]+))?>")


def _variant_regex(text: str, synonyms: Mapping[str, Sequence[str]]) -> re.Pattern[str]:
    out, pos = [], 0
    token = re.compile(r"\[([^\[\]]*)\]|\{([A-Za-z0-9_]+)\}|<([A-Za-z0-9_]+)(?::([a-z]+))?>")
    for m in token.finditer(text):
        out.append(re.escape(text[pos:m.start()]))
        if m.group(1) is not None:
            inner = _SYNONYM.sub(lambda s: "(?:" + "|".join(map(re.escape, synonyms.get(s.group(1), ()))) + ")",
                                 re.escape(m.group(1)).replace(r"\{", "{").replace(r"\}", "}"))
            out.append(f"(?:{inner})?")
        elif m.group(2) is not None:
            out.append("(?:" + "|".join(re.escape(s) for s in synonyms.get(m.group(2), ())) + ")")
        else:
            out.append(".+?")
        pos = m.end()
    out.append(re.escape(text[pos:]))
    pattern = "".join(out)
    pattern = re.sub(r"(\\ )+", r"\\s*", pattern)  # optional parts leave doubled or missing spaces
    return re.compile(r"^\s*" + pattern + r"\s*[.?!]?\s*$", re.IGNORECASE)


@cache
def _templates() -> dict[tuple[str, int], list[re.Pattern[str]]]:

    base = default_synonyms()
    out = {}
    for t in default_templates():
        syn = {**base, **t.synonyms}
        out[(t.filename, t.index)] = [_variant_regex(text, syn) for text in t.text]
    return out


def text_variants(instruction: Mapping[str, Any]) -> list[int]:
    """Indices of the template text variants an instruction's text matches (empty: unknown template)."""
    key = (str(instruction.get("template_filename", "")), int(instruction.get("template_index", -1)))
    patterns = _templates().get(key)
    if not patterns:
        return []
    text = str(instruction.get("instruction", ""))
    return [k for k, p in enumerate(patterns) if p.match(text)]


def _held_out_variant_index(instruction: Mapping[str, Any]) -> int | None:
    key = (str(instruction.get("template_filename", "")), int(instruction.get("template_index", -1)))
    patterns = _templates().get(key)
    if not patterns or len(patterns) < 2:
        return None  # a template with one text has no paraphrase to hold out
    return len(patterns) + HELD_OUT_VARIANT if HELD_OUT_VARIANT < 0 else HELD_OUT_VARIANT


def held_out_instruction(instruction: Mapping[str, Any]) -> bool:
    """Whether an instruction's text comes only from a held-out variant (training leaves it out).

    A text that a seen variant can also produce (synonyms make some texts fit two variants) is seen
    language, and stays in.
    """
    k = _held_out_variant_index(instruction)
    return k is not None and text_variants(instruction) == [k]


def held_out_object(obj: Mapping[str, Any]) -> bool:
    """Whether a scene-annotation object is of a held-out class or colour–class combination."""
    name = str(obj.get("name", obj.get("shape", "")))
    colour = str(obj.get("colour", obj.get("color", "")))
    return name in HELD_OUT_CLASSES or (colour, name) in HELD_OUT_COMBINATIONS


def _targets(instruction: Mapping[str, Any], annotation: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    objs = annotation.get("objects", [])
    return [objs[i] for i in instruction.get("targets", []) if 0 <= i < len(objs)]


def episode_level(instruction: Mapping[str, Any], annotation: Mapping[str, Any]) -> str:
    """The level an episode belongs to: L4 before L2 before L3 before L1 (the first novelty in this order wins)."""
    targets = _targets(instruction, annotation)
    if any(str(o.get("name", o.get("shape"))) in HELD_OUT_CLASSES for o in targets):
        return "L4"
    if any(held_out_object(o) for o in targets):
        return "L2"
    if held_out_instruction(instruction):
        return "L3"
    return "L1"


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

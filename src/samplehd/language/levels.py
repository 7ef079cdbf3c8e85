"""Generalisation levels L1–L4: which episodes each level evaluates and which data training leaves out.

The classification of an (instruction, scene annotation) pair, shared by evaluation
(:mod:`samplehd.benchmark.levels` draws episodes of a level), training (:mod:`samplehd.learn` leaves out
what a level holds out) and the LeRobot export (its per-level train lists). The table and the
rejection sampling of evaluation episodes are described in :mod:`samplehd.benchmark.levels`.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from functools import cache
from typing import Any

from samplehd.errors import ConfigError
from samplehd.language.templates import default_synonyms, default_templates

__all__ = [
    "HELD_OUT_CLASSES",
    "HELD_OUT_COMBINATIONS",
    "HELD_OUT_VARIANT",
    "LEVELS",
    "episode_level",
    "held_out_for",
    "held_out_instruction",
    "held_out_object",
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
# A template's space: whitespace, or none where a word does not go on across it.
_SPACE = r"(?:\s+|(?<!\w)|(?!\w))"


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
    # Optional parts leave doubled or missing spaces, but a missing space may not join two words: the
    # "in" of "put X in Y" must not match the start of "inside", nor "on" that of "onto".
    pattern = re.sub(r"(\\ )+", lambda _: _SPACE, pattern)
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


def held_out_for(level: str, instruction: Mapping[str, Any], annotation: Mapping[str, Any]) -> bool:
    """Whether training for ``level`` leaves this episode out: it moves a held-out class (L4), a held-out
    colour–class combination (L2) or says a held-out paraphrase (L3); L1 leaves out all three, so only
    L1 episodes train a model measured at L1.

    Raises:
        ConfigError: ``level`` is not one of ``LEVELS``.
    """
    targets = _targets(instruction, annotation)
    names = [str(o.get("name", o.get("shape"))) for o in targets]
    novel = {
        "L2": any(held_out_object(o) and n not in HELD_OUT_CLASSES for o, n in zip(targets, names, strict=True)),
        "L3": held_out_instruction(instruction),
        "L4": any(n in HELD_OUT_CLASSES for n in names),
    }
    if level == "L1":
        return any(novel.values())
    if level not in novel:
        raise ConfigError(f"level={level!r}: valid: {', '.join(LEVELS)}")
    return novel[level]

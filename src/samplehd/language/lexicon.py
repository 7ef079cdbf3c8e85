"""Words for rendering referring expressions, loaded from ``lexicon.json``.

The lexicon knows how to say a class name ("wine glass", plural "wine glasses"), an attribute value
("medium-sized"), a table part inside a noun phrase ("on the left") and a relation ("left of"). It
also holds the two rules that keep descriptions from sounding silly: a material the noun already
says is never used ("glass glass"), and some attribute pairs are never said together ("metallic
metal").
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from functools import cache, cached_property
from pathlib import Path
from typing import Any

__all__ = ["LEXICON_PATH", "Lexicon", "default_lexicon"]

LEXICON_PATH = Path(__file__).with_name("lexicon.json")


def _regular_plural(noun: str) -> str:
    if noun.endswith(("s", "x", "z", "ch", "sh")):
        return noun + "es"
    if noun.endswith("y") and noun[-2:-1] not in "aeiou":
        return noun[:-1] + "ies"
    return noun + "s"


@dataclass(frozen=True)
class Lexicon:
    """Words used to render descriptions.

    Attributes:
        nouns: class name -> (singular, plural).
        generic_noun: (singular, plural) used when a set description names no class.
        adjectives: attribute kind -> value -> word; missing values are said as they are.
        redundant_material: material -> classes whose noun already says it.
        exclusive_modifiers: pairs of (kind, value) never said together.
        table_part_phrase: table part -> post-modifier ("on the left").
        relation_phrase: relation -> words before the anchor ("left of").
        set_determiners: determiners drawn for set descriptions ("all the").
        relation_destination_phrase: relation as a destination ("to the left of").
        plural_only: classes whose singular form is grammatically plural ("scissors").
        agreement: "singular"/"plural" -> form name (they, them, be) -> word ("it", "are").
        relative_pronoun: word that starts a relative clause ("that").
    """

    nouns: dict[str, tuple[str, str]] = field(default_factory=dict)
    generic_noun: tuple[str, str] = ("object", "objects")
    adjectives: dict[str, dict[str, str]] = field(default_factory=dict)
    redundant_material: dict[str, tuple[str, ...]] = field(default_factory=dict)
    exclusive_modifiers: tuple[tuple[tuple[str, str], tuple[str, str]], ...] = ()
    table_part_phrase: dict[str, str] = field(default_factory=dict)
    relation_phrase: dict[str, str] = field(default_factory=dict)
    set_determiners: tuple[str, ...] = ("all the",)
    relation_destination_phrase: dict[str, str] = field(default_factory=dict)
    plural_only: frozenset[str] = frozenset()
    agreement: dict[str, dict[str, str]] = field(
        default_factory=lambda: {
            "singular": {"they": "it", "them": "it", "be": "is"},
            "plural": {"they": "they", "them": "them", "be": "are"},
        }
    )
    relative_pronoun: str = "that"

    def noun(self, name: str | None, plural: bool = False) -> str:
        """Return the noun for a class (``None``: the generic noun), singular or plural."""
        if name is None:
            return self.generic_noun[1 if plural else 0]
        if name in self.nouns:
            return self.nouns[name][1 if plural else 0]
        singular = name.replace("_", " ")
        return _regular_plural(singular) if plural else singular

    def adjective(self, kind: str, value: str) -> str:
        """Return the word for an attribute value ("medium" -> "medium-sized")."""
        return self.adjectives.get(kind, {}).get(value, value.replace("_", " "))

    def agree(self, form: str, plural: bool) -> str:
        """Return a pronoun or verb form agreeing in number: ``agree("be", True) == "are"``."""
        return self.agreement["plural" if plural else "singular"][form]

    def is_plural_form(self, name: str) -> bool:
        """Whether a single object of this class takes plural agreement ("the scissors are")."""
        return name in self.plural_only

    def material_is_redundant(self, name: str, material: str) -> bool:
        """Whether saying ``material`` before this class's noun repeats it ("glass glass")."""
        return name in self.redundant_material.get(material, ())

    def are_exclusive(self, a: tuple[str, str], b: tuple[str, str]) -> bool:
        """Whether two (kind, value) modifiers must not be said together."""
        return frozenset((a, b)) in self._exclusive_pairs

    @cached_property
    def _exclusive_pairs(self) -> frozenset[frozenset[tuple[str, str]]]:
        """``exclusive_modifiers`` as unordered pairs, for look-ups."""
        return frozenset(frozenset(pair) for pair in self.exclusive_modifiers)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Lexicon:
        """Build a lexicon from the JSON layout of ``lexicon.json``."""
        return cls(
            nouns={k: (v[0], v[1]) for k, v in data.get("nouns", {}).items()},
            generic_noun=tuple(data.get("generic_noun", ("object", "objects"))),  # type: ignore[arg-type]
            adjectives={k: dict(v) for k, v in data.get("adjectives", {}).items()},
            redundant_material={k: tuple(v) for k, v in data.get("redundant_material", {}).items()},
            exclusive_modifiers=tuple(((a[0], a[1]), (b[0], b[1])) for a, b in data.get("exclusive_modifiers", [])),
            table_part_phrase=dict(data.get("table_part_phrase", {})),
            relation_phrase=dict(data.get("relation_phrase", {})),
            set_determiners=tuple(data.get("set_determiners", ("all the",))),
            relation_destination_phrase=dict(data.get("relation_destination_phrase", {})),
            plural_only=frozenset(data.get("plural_only", ())),
            **({"agreement": {k: dict(v) for k, v in data["agreement"].items()}} if "agreement" in data else {}),
            relative_pronoun=str(data.get("relative_pronoun", "that")),
        )

    def to_dict(self) -> dict[str, object]:
        """Return the JSON layout of ``lexicon.json``."""
        return {
            "nouns": {k: list(v) for k, v in self.nouns.items()},
            "generic_noun": list(self.generic_noun),
            "adjectives": self.adjectives,
            "redundant_material": {k: list(v) for k, v in self.redundant_material.items()},
            "exclusive_modifiers": [[list(a), list(b)] for a, b in self.exclusive_modifiers],
            "table_part_phrase": self.table_part_phrase,
            "relation_phrase": self.relation_phrase,
            "set_determiners": list(self.set_determiners),
            "relation_destination_phrase": self.relation_destination_phrase,
            "plural_only": sorted(self.plural_only),
            "agreement": self.agreement,
            "relative_pronoun": self.relative_pronoun,
        }


@cache
def default_lexicon() -> Lexicon:
    """Return the lexicon shipped with samplehd (loaded once)."""
    with LEXICON_PATH.open(encoding="utf-8") as f:
        return Lexicon.from_dict(json.load(f))

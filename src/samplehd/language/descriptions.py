"""Referring expressions: shortest unique descriptions of objects and descriptions of object sets.

A :class:`Description` is a set of attribute filters (class name, colour, material, size, table
part), optionally followed by a relation to another, uniquely described anchor object ("the mug
left of the blue bowl"). A description of a single object always names its class (the head noun);
its length is the number of *modifiers* — the attributes other than the class name. Shortest
unique means no description of that object with fewer modifiers picks it out alone (among the
descriptions the lexicon allows: no "glass glass", no "metallic metal"). Adding the
class name never lengthens a description in this measure, so naming the class costs nothing, and
"the red mug" is as short as "the red object".

Search is polynomial: filters are bitmasks over the scene's objects, and for each object the
modifier subsets are enumerated in increasing size over the at most four modifier kinds, stopping
at the first size with a unique match. There is no search over attribute-value combinations across
objects (SAMPLE-HD's depth-first search was exponential in the number of adjectives). Results are
cached per scene in a :class:`SceneDescriber`.

Example:
    >>> from samplehd.language.scene import parse_scene
    >>> def obj(name, colour, y):
    ...     return {"name": name, "colour": colour, "material": "ceramic", "size": "small",
    ...             "table_part": [], "3d_coords": [0.0, y, 0.8], "bbox": {"extents": [0.1, 0.1, 0.1]}}
    >>> scene = parse_scene({"objects": [obj("mug", "red", -0.2), obj("mug", "blue", 0.0),
    ...                                  obj("wine_glass", "blue", 0.2)]})
    >>> [render_description(shortest_unique_description(scene, i)) for i in range(3)]
    ['the red mug', 'the blue mug', 'the wine glass']
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from itertools import combinations, product
from typing import Any

from samplehd.language.lexicon import Lexicon, default_lexicon
from samplehd.language.scene import Scene
from samplehd.world.relations import RELATIONS

__all__ = [
    "ATTRIBUTE_KINDS",
    "Description",
    "MODIFIER_KINDS",
    "SceneDescriber",
    "render_description",
    "shortest_unique_description",
]

# Order of filters in programs (CLEVR's order: size, colour, material, then the class).
ATTRIBUTE_KINDS = ("table_part", "size", "colour", "material", "name")
# Modifier kinds in order of preference when several shortest descriptions exist.
MODIFIER_KINDS = ("colour", "size", "material", "table_part")
# Order of adjectives in English noun phrases: size before colour before material.
_ADJECTIVE_ORDER = ("size", "colour", "material")
_KIND_RANK = {k: i for i, k in enumerate(ATTRIBUTE_KINDS)}
_PREFERENCE = {k: i for i, k in enumerate(MODIFIER_KINDS)}


@dataclass(frozen=True)
class Description:
    """A referring expression as filters (and optionally a relation to an anchor object).

    Attributes:
        filters: ``(kind, value)`` pairs in program order (table_part, size, colour, material, name).
        relation: relation from the anchor to the described object ("left": left of the anchor).
        anchor: unique description of the anchor object, when ``relation`` is set.
    """

    filters: tuple[tuple[str, str], ...]
    relation: str | None = None
    anchor: Description | None = None

    @staticmethod
    def of(filters: Any, relation: str | None = None, anchor: Description | None = None) -> Description:
        """Build a description from ``(kind, value)`` pairs in any order."""
        ordered = tuple(sorted(((str(k), str(v)) for k, v in filters), key=lambda f: _KIND_RANK[f[0]]))
        return Description(ordered, relation, anchor)

    def value(self, kind: str) -> str | None:
        """Return the value of a filter kind, or None."""
        for k, v in self.filters:
            if k == kind:
                return v
        return None

    @property
    def modifier_count(self) -> int:
        """Number of attributes other than the class name (relations count as one, plus the anchor's)."""
        own = sum(1 for k, _ in self.filters if k != "name")
        if self.anchor is not None:
            own += 1 + self.anchor.modifier_count
        return own

    def to_dict(self) -> dict[str, object]:
        """Return ``{filters: {kind: value}, relation, anchor}``."""
        return {
            "filters": dict(self.filters),
            "relation": self.relation,
            "anchor": None if self.anchor is None else self.anchor.to_dict(),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Description:
        """Inverse of :meth:`to_dict`."""
        anchor = data.get("anchor")
        return cls.of(
            data["filters"].items(),
            data.get("relation"),
            None if anchor is None else cls.from_dict(anchor),
        )


def _bits(mask: int) -> Iterator[int]:
    i = 0
    while mask:
        if mask & 1:
            yield i
        mask >>= 1
        i += 1


class SceneDescriber:
    """Describes the objects of one scene; caches every result.

    Args:
        scene: the scene.
        lexicon: words and the rules that forbid some modifier combinations.
        max_set_filters: largest number of filters in a set description ("all red mugs" has 2).
        modifier_kinds: attribute kinds that may modify the class name (default: all four).
    """

    def __init__(
        self,
        scene: Scene,
        lexicon: Lexicon | None = None,
        max_set_filters: int = 2,
        modifier_kinds: tuple[str, ...] = MODIFIER_KINDS,
    ) -> None:
        unknown = [k for k in modifier_kinds if k not in MODIFIER_KINDS]
        if unknown:
            raise ValueError(f"unknown modifier kind {unknown[0]!r}; valid: {', '.join(MODIFIER_KINDS)}")
        self.modifier_kinds = tuple(k for k in MODIFIER_KINDS if k in modifier_kinds)
        self.scene = scene
        self.lexicon = lexicon or default_lexicon()
        self.max_set_filters = max_set_filters
        self.full = (1 << len(scene.objects)) - 1
        self.masks: dict[tuple[str, str], int] = {}
        for obj in scene.objects:
            bit = 1 << obj.index
            for kind in ("name", "colour", "material", "size"):
                key = (kind, str(obj.attribute(kind)))
                self.masks[key] = self.masks.get(key, 0) | bit
            for part in obj.table_part:
                self.masks[("table_part", part)] = self.masks.get(("table_part", part), 0) | bit
        self.relation_masks: dict[str, list[int]] = {
            rel: [sum(1 << j for j in row) for row in scene.relationships[rel]] for rel in RELATIONS
        }
        self._attribute_cache: dict[int, tuple[Description, ...]] = {}
        self._unique_cache: dict[int, tuple[Description, ...]] = {}
        self._modifier_cache: dict[int, list[list[tuple[tuple[str, str], ...]]]] = {}
        self._allowed_cache: dict[tuple[tuple[str, str], ...], bool] = {}
        self._sets: tuple[Description, ...] | None = None

    # -- matching --------------------------------------------------------------------------------

    def mask(self, description: Description) -> int:
        """Bitmask of the objects a description matches."""
        m = self.full
        if description.anchor is not None:
            anchor = self.mask(description.anchor)
            if anchor.bit_count() != 1 or description.relation is None:
                return 0
            m = self.relation_masks[description.relation][anchor.bit_length() - 1]
        for f in description.filters:
            m &= self.masks.get(f, 0)
        return m

    def matches(self, description: Description) -> tuple[int, ...]:
        """Indices of the objects a description matches, ascending."""
        return tuple(_bits(self.mask(description)))

    # -- single objects ----------------------------------------------------------------------------

    def modifier_options(self, index: int) -> dict[str, tuple[str, ...]]:
        """Modifier values that may describe an object, per kind (empty kinds left out)."""
        obj = self.scene.objects[index]
        options: dict[str, tuple[str, ...]] = {
            "colour": (obj.colour,),
            "size": (obj.size,),
            "material": () if self.lexicon.material_is_redundant(obj.name, obj.material) else (obj.material,),
            "table_part": obj.table_part,
        }
        return {k: options[k] for k in self.modifier_kinds if options[k]}

    def _allowed(self, filters: tuple[tuple[str, str], ...]) -> bool:
        if not self.lexicon.exclusive_modifiers or len(filters) < 2:
            return True
        return not any(self.lexicon.are_exclusive(a, b) for a, b in combinations(filters, 2))

    def _minimal_subsets(self, index: int, within: int) -> tuple[tuple[tuple[str, str], ...], ...]:
        """Smallest modifier sets that, with the class name, single out ``index`` inside ``within``."""
        obj = self.scene.objects[index]
        bit = 1 << index
        base = self.masks[("name", obj.name)] & within
        if not base & bit:
            return ()
        if base == bit:
            return ((),)
        for candidates in self._modifier_sets(index):
            found = []
            for filters in candidates:
                m = base
                for f in filters:
                    m &= self.masks[f]
                if m == bit and self._allowed_memo(filters):
                    found.append(filters)
            if found:
                return tuple(found)
        return ()

    def _modifier_sets(self, index: int) -> list[list[tuple[tuple[str, str], ...]]]:
        """The modifier sets that may describe an object, by size, each size in the order of the kinds'
        combinations and their values (memoised: an object is singled out inside many sets of objects)."""
        if index not in self._modifier_cache:
            options = self.modifier_options(index)
            kinds = list(options)
            self._modifier_cache[index] = [
                [tuple(zip(combo, values, strict=True)) for combo in combinations(kinds, size)
                 for values in product(*(options[k] for k in combo))]
                for size in range(1, len(kinds) + 1)
            ]
        return self._modifier_cache[index]

    def _allowed_memo(self, filters: tuple[tuple[str, str], ...]) -> bool:
        """:meth:`_allowed`, memoised."""
        ok = self._allowed_cache.get(filters)
        if ok is None:
            ok = self._allowed_cache[filters] = self._allowed(filters)
        return ok

    def attribute_descriptions(self, index: int) -> tuple[Description, ...]:
        """All shortest unique descriptions of an object from its attributes alone (maybe none).

        Ordered by preference: colour first, then size, material, table part.
        """
        if index not in self._attribute_cache:
            name = self.scene.objects[index].name
            subsets = sorted(self._minimal_subsets(index, self.full), key=lambda fs: [_PREFERENCE[k] for k, _ in fs])
            self._attribute_cache[index] = tuple(Description.of((*fs, ("name", name))) for fs in subsets)
        return self._attribute_cache[index]

    def relational_descriptions(self, index: int) -> tuple[Description, ...]:
        """Shortest descriptions of an object through a relation to a uniquely described anchor."""
        name = self.scene.objects[index].name
        bit = 1 << index
        best: list[tuple[int, Description]] = []
        for j in range(len(self.scene.objects)):
            if j == index:
                continue
            anchors = self.attribute_descriptions(j)
            if not anchors:
                continue
            anchor = anchors[0]
            for rel in RELATIONS:
                within = self.relation_masks[rel][j]
                if not within & bit:
                    continue
                for fs in self._minimal_subsets(index, within):
                    d = Description.of((*fs, ("name", name)), rel, anchor)
                    best.append((d.modifier_count, d))
        if not best:
            return ()
        shortest = min(score for score, _ in best)
        found = [d for score, d in best if score == shortest]
        # an anchor of another class reads better ("the mug left of the bowl")
        other = [d for d in found if d.anchor is not None and d.anchor.value("name") != name]
        return tuple(other or found)

    def unique_descriptions(self, index: int) -> tuple[Description, ...]:
        """All shortest unique descriptions of an object: from attributes, else through a relation.

        Returns an empty tuple when no description singles the object out.
        """
        if index not in self._unique_cache:
            self._unique_cache[index] = self.attribute_descriptions(index) or self.relational_descriptions(index)
        return self._unique_cache[index]

    # -- sets ---------------------------------------------------------------------------------------

    def set_descriptions(self) -> tuple[Description, ...]:
        """Descriptions that match two or more objects ("all red mugs"), one per distinct set.

        Each has 1 to ``max_set_filters`` filters; for each set the shortest description is kept
        (a description naming the class preferred). Ordered by the set's bitmask.
        """
        if self._sets is None:
            kinds = {*self.modifier_kinds, "name"}
            keys = sorted((k for k in self.masks if k[0] in kinds), key=lambda k: (_KIND_RANK[k[0]], k[1]))
            best: dict[int, tuple[tuple[int, int, list[int]], Description]] = {}
            masks = [self.masks[k] for k in keys]
            for size in range(1, self.max_set_filters + 1):
                for combo, m in _matching_combinations(keys, masks, size, self.full):
                    if len({k for k, _ in combo}) < size or not self._allowed(combo):
                        continue
                    name = dict(combo).get("name")
                    material = dict(combo).get("material")
                    if name and material and self.lexicon.material_is_redundant(name, material):
                        continue
                    rank = (size, 0 if name else 1, [_KIND_RANK[k] for k, _ in combo])
                    if m not in best or rank < best[m][0]:
                        best[m] = (rank, Description.of(combo))
            self._sets = tuple(best[m][1] for m in sorted(best))
        return self._sets


def _matching_combinations(
    keys: Sequence[tuple[str, str]], masks: Sequence[int], size: int, full: int
) -> Iterator[tuple[tuple[tuple[str, str], ...], int]]:
    """The combinations of ``size`` keys (in ``itertools.combinations`` order) whose masks share two or
    more objects, with that shared mask. A prefix sharing fewer than two objects is not extended: no
    combination that starts with it shares more (most combinations match fewer than two objects)."""

    def extend(
        start: int, prefix: tuple[tuple[str, str], ...], m: int
    ) -> Iterator[tuple[tuple[tuple[str, str], ...], int]]:
        last = len(prefix) + 1 == size
        for i in range(start, len(keys) - (size - len(prefix) - 1)):
            shared = m & masks[i]
            if shared.bit_count() < 2:
                continue
            combo = (*prefix, keys[i])
            if last:
                yield combo, shared
            else:
                yield from extend(i + 1, combo, shared)

    return extend(0, (), full)


def shortest_unique_description(scene: Scene, index: int, lexicon: Lexicon | None = None) -> Description | None:
    """Return the preferred shortest unique description of object ``index`` (None if there is none)."""
    found = SceneDescriber(scene, lexicon).unique_descriptions(index)
    return found[0] if found else None


def render_description(
    description: Description,
    lexicon: Lexicon | None = None,
    *,
    plural: bool = False,
    determiner: str = "the",
) -> str:
    """Say a description in English: "the small red ceramic mug on the left".

    Args:
        description: the description.
        lexicon: words to use (default: the shipped lexicon).
        plural: say the noun in the plural (set descriptions).
        determiner: the words before the noun phrase ("the", "all the").
    """
    lex = lexicon or default_lexicon()
    words = [determiner] if determiner else []
    words += [lex.adjective(k, v) for k in _ADJECTIVE_ORDER if (v := description.value(k)) is not None]
    words.append(lex.noun(description.value("name"), plural=plural))
    part = description.value("table_part")
    if part is not None:
        if plural:
            # "put all objects that are on the right on the front side", not "on the right on the front"
            words += [lex.relative_pronoun, lex.agree("be", True)]
        words.append(lex.table_part_phrase.get(part, f"on the {part}"))
    if description.anchor is not None and description.relation is not None:
        # a relative clause keeps a relation apart from the verb's destination phrase
        name = description.value("name")
        plural_verb = plural or (name is not None and lex.is_plural_form(name))
        words += [lex.relative_pronoun, lex.agree("be", plural_verb)]
        words.append(lex.relation_phrase.get(description.relation, description.relation))
        words.append(render_description(description.anchor, lex))
    return " ".join(words)

"""Rejection-based instruction generation (SAMPLE-HD's method).

For each instruction slot of a scene: order the templates so the least used template (or family,
then template) comes first, ties broken at random; for that template draw its parameters one by
one (objects uniformly among those with a unique description, sets among the scene's set
descriptions, table parts and relations uniformly), checking each constraint as soon as its
parameters are drawn and rejecting the candidates that fail it (counted by reason), backing up on a
dead end. A template without any valid binding, or whose ``tries_per_template`` draws all repeat
instructions already made, is dropped for the scene and the next one is tried. A draw
that passes gets descriptions drawn among the shortest unique ones, text, and programs in both
formats; both programs are executed and must give the same task, and a task already asked for in
the scene is rejected as a duplicate. Nothing enumerates all attribute combinations: the cost per
instruction is polynomial in the number of objects.
"""

from __future__ import annotations

import itertools
import operator
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from samplehd.errors import ConfigError
from samplehd.language.constraints import CONSTRAINTS, Check, ConstraintContext, Reachable, default_reachable
from samplehd.language.descriptions import Description, SceneDescriber, render_description
from samplehd.language.executor import ProgramError, execute_nodes, execute_sequence
from samplehd.language.lexicon import Lexicon, default_lexicon
from samplehd.language.programs import ProgramNode, node, reference_nodes, reference_tokens
from samplehd.language.realise import realise_text
from samplehd.language.scene import Scene, SceneObject, parse_scene
from samplehd.language.templates import Template, TemplateConstraint, default_templates
from samplehd.tasks.task import Task, parse_task
from samplehd.world.layout import OPPOSITE_PART, TABLE_PARTS
from samplehd.world.relations import RELATIONS

__all__ = [
    "BALANCE_MODES",
    "POSE_FREE_CONSTRAINTS",
    "GenerationResult",
    "Instruction",
    "TemplateBalancer",
    "generate_instructions",
    "may_have_family",
]

BALANCE_MODES = ("templates", "families")
_META = ("object", "object_set")
# Constraints that read only what objects are (their classes' affordances and their sizes), never where they
# stand or what surrounds them.
POSE_FREE_CONSTRAINTS = frozenset({"stackable_on", "fits_in"})


@dataclass(frozen=True)
class Instruction:
    """One generated instruction for one scene.

    Attributes:
        text: the instruction.
        family: task family of its template.
        template_name: the template's name.
        template_filename: the file the template came from.
        template_index: the template's position in that file.
        task: what the programs evaluate to.
        program: CLEVR node list.
        program_sequence: SAMPLE-HD flat program tokens.
        params: bound parameters (object index, list of indices, table part or relation).
        references: descriptions used for object and set parameters.
    """

    text: str
    family: str
    template_name: str
    template_filename: str
    template_index: int
    task: Task
    program: tuple[ProgramNode, ...]
    program_sequence: tuple[str, ...]
    params: dict[str, Any] = field(default_factory=dict)
    references: dict[str, Description] = field(default_factory=dict)

    @property
    def targets(self) -> tuple[int, ...]:
        """Every object index the task involves (moved objects, then the subject object)."""
        return self.task.involved

    def to_dict(self) -> dict[str, object]:
        """Return the instruction-file entry fields this instruction owns."""
        return {
            "instruction": self.text,
            "family": self.family,
            "template_name": self.template_name,
            "template_filename": self.template_filename,
            "template_index": self.template_index,
            "task": self.task.to_program_dict(),
            "targets": list(self.targets),
            "program": [dict(n) for n in self.program],
            "program_sequence": " ".join(self.program_sequence),
            "params": {k: list(v) if isinstance(v, tuple) else v for k, v in self.params.items()},
            "references": {k: d.to_dict() for k, d in self.references.items()},
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Instruction:
        """Inverse of :meth:`to_dict` (extra entry fields are ignored)."""
        seq = data["program_sequence"]
        return cls(
            text=str(data["instruction"]),
            family=str(data["family"]),
            template_name=str(data.get("template_name", "")),
            template_filename=str(data["template_filename"]),
            template_index=int(data["template_index"]),
            task=parse_task(data["task"]),
            program=tuple(dict(n) for n in data["program"]),
            program_sequence=tuple(seq.split() if isinstance(seq, str) else seq),
            params={k: tuple(v) if isinstance(v, list) else v for k, v in data.get("params", {}).items()},
            references={k: Description.from_dict(d) for k, d in data.get("references", {}).items()},
        )


@dataclass(frozen=True)
class GenerationResult:
    """Instructions for one scene and how many draws were rejected, by reason."""

    instructions: tuple[Instruction, ...]
    rejections: dict[str, int]
    attempts: int

    def to_dict(self) -> dict[str, object]:
        """Return ``{instructions: [...], rejections, attempts}``."""
        return {
            "instructions": [i.to_dict() for i in self.instructions],
            "rejections": dict(self.rejections),
            "attempts": self.attempts,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> GenerationResult:
        """Inverse of :meth:`to_dict`."""
        return cls(
            tuple(Instruction.from_dict(i) for i in data["instructions"]),
            {str(k): int(v) for k, v in data["rejections"].items()},
            int(data["attempts"]),
        )


class TemplateBalancer:
    """Keeps use counts so that templates (or families) come out near uniformly.

    Share one balancer across the scenes of a dataset; the next slot tries the least used template
    (``"templates"``) or the least used family and within it the least used template
    (``"families"``) first, ties broken at random.

    Args:
        balance: ``"templates"`` or ``"families"``.
    """

    def __init__(self, balance: str = "templates") -> None:
        if balance not in BALANCE_MODES:
            raise ConfigError(f"balance {balance!r} is unknown; valid: {', '.join(BALANCE_MODES)}")
        self.balance = balance
        self.template_counts: Counter[str] = Counter()
        self.family_counts: Counter[str] = Counter()

    def order(self, templates: Sequence[Template], rng: np.random.Generator) -> list[Template]:
        """Return the templates in the order to try them."""
        keys = rng.random(len(templates))
        if self.balance == "templates":
            order = sorted(range(len(templates)), key=lambda i: (self.template_counts[templates[i].name], keys[i]))
            return [templates[i] for i in order]
        families = sorted({t.family for t in templates})
        fkeys = dict(zip(families, rng.random(len(families)), strict=True))
        order = sorted(
            range(len(templates)),
            key=lambda i: (
                self.family_counts[templates[i].family],
                fkeys[templates[i].family],
                self.template_counts[templates[i].name],
                keys[i],
            ),
        )
        return [templates[i] for i in order]

    def record(self, template: Template) -> None:
        """Count one instruction made from ``template``."""
        self.template_counts[template.name] += 1
        self.family_counts[template.family] += 1


def binding_key(template: Template, values: Mapping[str, Any]) -> tuple[Any, ...]:
    """Hashable identity of a template binding (same key: same instruction up to wording)."""
    return (template.name, tuple(sorted(values.items())))


def _schedule(template: Template) -> list[list[TemplateConstraint]]:
    """Constraints to check after each parameter is drawn (when their last parameter is bound)."""
    position = {p.name: k for k, p in enumerate(template.params)}
    out: list[list[TemplateConstraint]] = [[] for _ in template.params]
    for c in template.constraints:
        out[max(position[p] for p in c.params)].append(c)
    return out


# A scheduled constraint as the search reads it: its name, and what reads its arguments (a tuple of the
# bound values of its parameters) from the values bound so far.
_Check = tuple[str, Callable[[Mapping[str, Any]], tuple[Any, ...]]]
# ... and as one scene's search runs it: with that constraint's memo (results by arguments) and its test
_SceneCheck = tuple[str, Callable[[Mapping[str, Any]], tuple[Any, ...]], dict[tuple[Any, ...], bool], Check]


def _compiled_schedule(template: Template) -> list[tuple[_Check, ...]]:
    """:func:`_schedule` with each constraint's arguments read by one ``itemgetter`` call."""
    out = []
    for checks in _schedule(template):
        level = []
        for c in checks:
            level.append((c.type, operator.itemgetter(*c.params) if len(c.params) > 1 else _single(c.params[0])))
        out.append(tuple(level))
    return out


def _single(name: str) -> Callable[[Mapping[str, Any]], tuple[Any, ...]]:
    return lambda values: (values[name],)


# compiled schedules of the templates seen, by identity (each entry holds its template, so the id stays its own)
_SCHEDULES: dict[int, tuple[Template, list[tuple[_Check, ...]]]] = {}


def _cached_schedule(template: Template) -> list[tuple[_Check, ...]]:
    """:func:`_compiled_schedule`, made once per template object (the shipped templates are loaded once)."""
    entry = _SCHEDULES.get(id(template))
    if entry is None or entry[0] is not template:
        if len(_SCHEDULES) > 4096:  # templates made afresh again and again: start over
            _SCHEDULES.clear()
        entry = _SCHEDULES[id(template)] = (template, _compiled_schedule(template))
    return entry[1]


class _SceneGenerator:
    """Per-scene state: descriptions, constraint context, counts."""

    def __init__(
        self,
        scene: Scene,
        reachable: Reachable,
        lexicon: Lexicon,
        rng: np.random.Generator,
        search_budget: int = 4000,
    ) -> None:
        self.scene = scene
        self.lexicon = lexicon
        self.rng = rng
        self.describer = SceneDescriber(scene, lexicon)
        self.ctx = ConstraintContext(scene, reachable)
        self.describable = [i for i in range(len(scene.objects)) if self.describer.unique_descriptions(i)]
        self.sets = self.describer.set_descriptions()
        self.set_members = [self.describer.matches(d) for d in self.sets]
        self.rejections: Counter[str] = Counter()
        self.attempts = 0
        self._schedules: dict[str, list[tuple[_SceneCheck, ...]]] = {}
        self._memo: dict[str, dict[tuple[Any, ...], bool]] = {}  # per constraint: its results by arguments
        # candidate checks one draw may make before giving up (bounds the search for any scene)
        self.search_budget = search_budget
        self.budget = self.search_budget

    def draw(
        self, template: Template, exclude: set[tuple[Any, ...]] | None = None
    ) -> tuple[dict[str, Any], dict[str, Description]] | None:
        """Draw parameters for a template; None when no new binding satisfies its constraints.

        Parameters are drawn in template order. Each parameter's candidates are tried in random
        order against the constraints that become checkable with it (failures are counted by
        constraint); the first that passes is taken (a uniform draw among the valid ones), and on a
        dead end the search backs up to the previous parameter and tries its next candidate.
        Templates have at most three object parameters, so the work is at most cubic in the number
        of objects; it is also capped at ``search_budget`` candidate checks per draw, and
        constraint results are memoised per scene.
        """
        self.attempts += 1
        checks_of = self._schedules.get(template.name)
        if checks_of is None:
            # each level's checks with the memo of their constraint and its test, read once per template
            checks_of = self._schedules[template.name] = [
                tuple((ctype, args_of, self._memo.setdefault(ctype, {}), CONSTRAINTS[ctype].check)
                      for ctype, args_of in level)
                for level in _cached_schedule(template)
            ]
        params = template.params
        last = len(params) - 1
        values: dict[str, Any] = {}
        refs: dict[str, Description] = {}
        used: set[int] = set()
        rng = self.rng

        def assign(k: int) -> bool:
            nonlocal budget
            p = params[k]
            kind, name, checks = p.type, p.name, checks_of[k]
            domain: list[Any]
            if kind == "object":
                domain = [i for i in self.describable if i not in used]
            elif kind == "object_set":
                domain = [s for s in range(len(self.sets)) if not used.intersection(self.set_members[s])]
            elif kind == "table_part":
                domain = list(TABLE_PARTS)
            else:
                domain = list(RELATIONS)
            # candidates in random order, each checked only when reached: the first valid one is a
            # uniform draw among the valid ones, and most draws stop long before the whole domain
            # (``shuffle`` of a list draws as ``permutation`` does: the same order from the same state)
            order = list(range(len(domain)))
            rng.shuffle(order)
            any_valid = False
            for j in order:
                candidate = domain[j]
                members: tuple[int, ...] = ()
                if kind == "object_set":
                    members = self.set_members[candidate]
                    values[name] = members
                elif kind == "object":
                    members = (candidate,)
                    values[name] = candidate
                else:
                    values[name] = candidate
                if budget <= 0:
                    break
                budget -= 1
                # the constraints that become checkable here, in order, memoised per scene; a rejection is
                # counted once per distinct rejected candidate, not per draw (inline: runs for every candidate)
                failed = False
                for ctype, args_of, memo, check in checks:
                    args = args_of(values)
                    ok = memo.get(args)
                    if ok is None:
                        ok = memo[args] = bool(check(ctx, args))
                        if not ok:
                            rejections[ctype] += 1
                    if not ok:
                        failed = True
                        break
                if failed:
                    continue
                any_valid = True
                # a whole binding is new unless drawn before
                if k == last and exclude is not None and binding_key(template, values) in exclude:
                    rejections["duplicate"] += 1
                    continue
                if kind == "object_set":
                    refs[name] = self.sets[candidate]
                used.update(members)
                if k == last or assign(k + 1):
                    return True
                used.difference_update(members)
            if not any_valid:
                rejections[f"no_candidate_{kind}"] += 1
            values.pop(name, None)
            refs.pop(name, None)
            return False

        budget = self.search_budget
        rejections, ctx = self.rejections, self.ctx
        if params:
            found = assign(0)
        else:  # nothing to draw: the one binding, unless drawn before
            found = exclude is None or binding_key(template, values) not in exclude
            if not found:
                rejections["duplicate"] += 1
        assign = None  # type: ignore[assignment]  # (it calls itself: unbound, its closure frees this scene's state)
        self.budget = budget
        if not found:
            if budget <= 0:
                self.rejections["search_budget"] += 1
            return None
        for p in params:
            if p.type == "object":
                options = self.describer.unique_descriptions(values[p.name])
                # "put the knife in the pan that is behind the knife" reads badly: avoid anchoring a
                # reference on another object of the same instruction when there is a choice
                apart = [
                    d for d in options if d.anchor is None or not used.intersection(self.describer.matches(d.anchor))
                ]
                options = apart or options
                refs[p.name] = options[int(rng.integers(len(options)))]
        return values, refs

    def build(self, template: Template, values: dict[str, Any], refs: dict[str, Description]) -> Instruction | None:
        """Render text and programs for a successful draw; None if the programs disagree."""
        rng = self.rng
        lex = self.lexicon
        types = {p.name: p.type for p in template.params}
        rendered: dict[str, str] = {}

        def phrase(name: str, modifier: str | None) -> str:
            kind, value = types[name], values[name]
            if kind == "object":
                obj_name = self.scene.objects[value].name
                plural = lex.is_plural_form(obj_name)
                if modifier is not None:  # they / them / be, agreeing with the noun
                    return lex.agree(modifier, plural)
                if name not in rendered:
                    rendered[name] = render_description(refs[name], lex)
                return rendered[name]
            if kind == "object_set":
                if name not in rendered:
                    dets = lex.set_determiners
                    det = dets[int(rng.integers(len(dets)))]
                    rendered[name] = render_description(refs[name], lex, plural=True, determiner=det)
                return rendered[name]
            if kind == "table_part":
                return OPPOSITE_PART[value] if modifier == "opposite" else value
            return lex.relation_destination_phrase.get(value, value)

        variant = template.text[int(rng.integers(len(template.text)))]
        text = realise_text(variant, phrase, template.synonyms, rng)

        nodes: list[ProgramNode] = []
        where: dict[int, int] = {}
        for k, nd in enumerate(template.nodes):
            if nd["type"] in _META:
                nodes += reference_nodes(refs[nd["side_inputs"][0]], len(nodes), unique=nd["type"] == "object")
            else:
                vals = list(nd["value_inputs"]) + [str(values[s]) for s in nd["side_inputs"]]
                nodes.append(node(nd["type"], [where[i] for i in nd["inputs"]], vals))
            where[k] = len(nodes) - 1

        def substitute(token: str) -> str:
            for p in template.params:
                if p.type == "table_part":
                    token = token.replace(f"<{p.name}:opposite>", OPPOSITE_PART[values[p.name]])
                if p.type not in _META:
                    token = token.replace(f"<{p.name}>", str(values[p.name]))
            return token

        sequence: list[str] = []
        for token in template.sequence:
            name = token[1:-1] if token.startswith("<") and token.endswith(">") else None
            if name in types and types[name] in _META:
                sequence += reference_tokens(refs[name])
            else:  # (a token without a placeholder stays as it is)
                sequence.append(substitute(token) if "<" in token else token)
        try:
            task = execute_nodes(nodes, self.scene)
            if execute_sequence(sequence, self.scene) != task:
                raise ProgramError("formats disagree")
        except ProgramError:
            self.rejections["program_mismatch"] += 1
            return None
        return Instruction(
            text=text,
            family=template.family,
            template_name=template.name,
            template_filename=template.filename,
            template_index=template.index,
            task=task,
            program=tuple(nodes),
            program_sequence=tuple(sequence),
            params=dict(values),
            references=dict(refs),
        )


def generate_instructions(
    scene: Scene | Mapping[str, Any],
    rng: np.random.Generator,
    templates: Sequence[Template] | None = None,
    *,
    per_scene: int = 5,
    balance: str = "templates",
    families: Sequence[str] | None = None,
    reachable: Reachable = default_reachable,
    balancer: TemplateBalancer | None = None,
    tries_per_template: int = 8,
    search_budget: int = 4000,
    lexicon: Lexicon | None = None,
) -> GenerationResult:
    """Generate up to ``per_scene`` distinct instructions for one scene by rejection sampling.

    Args:
        scene: a parsed scene or a scene dict (CLEVR layout).
        rng: the only source of randomness.
        templates: templates to draw from (default: the shipped ones).
        per_scene: how many instructions to make; fewer when the scene does not allow more.
        balance: ``"templates"`` or ``"families"``: what should come out uniform.
        families: only use templates of these families.
        reachable: whether the arm can pick or place at a point (x, y, z) [m].
        balancer: shared use counts across scenes (default: a fresh one for this scene).
        tries_per_template: draws of one template before giving up on it for this scene.
        search_budget: candidate checks one draw may make (bounds the work on crowded scenes).
        lexicon: words for the text (default: the shipped lexicon).

    Returns:
        The instructions, rejection counts by reason, and the number of draws.

    Raises:
        SceneError: ``scene`` is a malformed scene dict.
        ConfigError: an unknown balance mode or family, or no templates left.
    """
    if not isinstance(scene, Scene):
        scene = parse_scene(scene)
    pool = list(templates if templates is not None else default_templates())
    if families is not None:
        known = sorted({t.family for t in pool})
        unknown = [f for f in families if f not in known]
        if unknown:
            raise ConfigError(f"family {unknown[0]!r} has no templates; valid: {', '.join(known)}")
        pool = [t for t in pool if t.family in families]
    if not pool:
        raise ConfigError("no templates to generate from")
    if balancer is None:
        balancer = TemplateBalancer(balance)
    elif balancer.balance != balance:
        raise ConfigError(f"balancer balances {balancer.balance}, but balance={balance!r} was asked for")
    if per_scene < 0 or tries_per_template < 1 or search_budget < 1:
        raise ConfigError("per_scene must be >= 0, tries_per_template and search_budget >= 1")
    gen = _SceneGenerator(scene, reachable, lexicon or default_lexicon(), rng, search_budget)
    try:
        return _draw_instructions(gen, pool, balancer, per_scene, tries_per_template)
    finally:
        # the memo refers back to its context: freed now, not when a full collection walks every object in the
        # process (on 20-object scenes, such passes took about a fifth of the time)
        gen.ctx.release()


def _draw_instructions(
    gen: _SceneGenerator, pool: Sequence[Template], balancer: TemplateBalancer, per_scene: int,
    tries_per_template: int,
) -> GenerationResult:
    """:func:`generate_instructions` once its arguments are checked: draw and build until ``per_scene`` are made
    or every template is used up for the scene."""
    rng, scene = gen.rng, gen.scene
    gen.rejections["no_unique_description"] = len(scene.objects) - len(gen.describable)
    out: list[Instruction] = []
    seen: set[tuple[Any, ...]] = set()
    seen_bindings: set[tuple[Any, ...]] = set()
    exhausted: set[str] = set()
    while len(out) < per_scene:
        made: Instruction | None = None
        chosen: Template | None = None
        for template in balancer.order(pool, rng):
            if template.name in exhausted:
                continue
            for _ in range(tries_per_template):
                drawn = gen.draw(template, seen_bindings)
                if drawn is None:  # no new binding: the template is used up for this scene
                    break
                seen_bindings.add(binding_key(template, drawn[0]))
                inst = gen.build(template, *drawn)
                if inst is None:
                    continue
                key = (inst.task.type, inst.task.objects, inst.task.subject, inst.task.relation)
                if key in seen:
                    gen.rejections["duplicate"] += 1
                    continue
                seen.add(key)
                made, chosen = inst, template
                break
            if made is not None:
                break
            exhausted.add(template.name)
        if made is None or chosen is None:
            break
        balancer.record(chosen)
        out.append(made)
    rejections = {k: v for k, v in sorted(gen.rejections.items()) if v}
    return GenerationResult(tuple(out), rejections, gen.attempts)


def may_have_family(objects: Sequence[SceneObject], family: str, templates: Sequence[Template] | None = None) -> bool:
    """Whether some template of ``family`` can bind its object parameters to distinct ``objects`` that pass
    its pose-free constraints (:data:`POSE_FREE_CONSTRAINTS`; the objects' poses are not read).

    False means that :func:`generate_instructions` draws no instruction of the family on any scene of these
    objects, wherever they stand: every binding it tries is one of these. True says nothing more (a
    template with a parameter that is not an object, or with no pose-free constraint, always may).
    """
    pool = [t for t in (templates if templates is not None else default_templates()) if t.family == family]
    ctx = ConstraintContext(Scene(0, "", "", tuple(objects)))
    try:
        for template in pool:
            checks = [(CONSTRAINTS[c.type].check, c.params) for c in template.constraints
                      if c.type in POSE_FREE_CONSTRAINTS]
            if not checks or any(p.type != "object" for p in template.params):
                return True
            names = [p.name for p in template.params]
            for binding in itertools.permutations(range(len(objects)), len(names)):
                values = dict(zip(names, binding, strict=True))
                if all(check(ctx, [values[p] for p in params]) for check, params in checks):
                    return True
        return False
    finally:
        ctx.release()

"""Instruction templates: JSON data files, loaded and validated.

A template file (see ``templates/*.json``) is::

    {
      "family": "place",
      "synonyms": {"move": ["move", "shift"]},          # optional, adds to synonyms.json
      "templates": [
        {
          "name": "place_one",
          "text": ["{move} <R1> to the <P> {side} of the table.", ...],
          "params": [{"name": "R1", "type": "object"}, {"name": "P", "type": "table_part"}],
          "constraints": [{"type": "graspable", "params": ["R1"]}, ...],
          "nodes": [{"type": "object", "side_inputs": ["R1"]},
                    {"type": "place", "inputs": [0], "side_inputs": ["P"]}],
          "sequence": ["place[<P>]", "<R1>"]
        }
      ]
    }

Text: ``<NAME>`` is a parameter (``<P:opposite>`` the opposite table part; ``<R1:they>`` "it" or
"they", ``<R1:them>`` "it" or "them", ``<R1:be>`` "is" or "are", agreeing with the noun: "the
scissors ... them"), ``[words]`` an optional phrase, ``{group}`` a synonym drawn from the group.
Parameter types: ``object`` (a unique reference), ``object_set`` (a set reference),
``table_part``, ``relation``. Nodes: CLEVR functions (see :mod:`samplehd.language.programs`) with
parameters as ``side_inputs``, plus the meta-nodes ``object``/``object_set`` that expand into the
reference's nodes. Sequence: the flat program, where ``<R1>`` expands into the reference's tokens.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cache
from pathlib import Path
from typing import Any, TypedDict

from samplehd.errors import TemplateError
from samplehd.fileio import read_json
from samplehd.language.constraints import CONSTRAINTS
from samplehd.language.programs import ACTION_FUNCTIONS, FLAT_TASK_TOKENS, NODE_FUNCTIONS

__all__ = [
    "DEFAULT_TEMPLATE_DIR",
    "PARAM_TYPES",
    "SYNONYMS_PATH",
    "Template",
    "TemplateConstraint",
    "TemplateNode",
    "TemplateParam",
    "default_synonyms",
    "default_templates",
    "load_templates",
    "parse_template_file",
]

DEFAULT_TEMPLATE_DIR = Path(__file__).with_name("templates")
SYNONYMS_PATH = Path(__file__).with_name("synonyms.json")
PARAM_TYPES = ("object", "object_set", "table_part", "relation")
# Placeholder modifiers allowed per parameter type.
_MODIFIERS = {"opposite": ("table_part",), "they": ("object",), "them": ("object",), "be": ("object",)}
_PLACEHOLDER = re.compile(r"<([A-Za-z0-9_]+)(?::([a-z]+))?>")
_SYNONYM = re.compile(r"\{([A-Za-z0-9_]+)\}")
_META_NODES = ("object", "object_set")


@dataclass(frozen=True)
class TemplateParam:
    """A template parameter: its name (``R1``) and type (object, object_set, table_part, relation)."""

    name: str
    type: str

    def to_dict(self) -> dict[str, str]:
        """Return ``{name, type}``."""
        return {"name": self.name, "type": self.type}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> TemplateParam:
        """Inverse of :meth:`to_dict`."""
        return cls(str(data["name"]), str(data["type"]))


@dataclass(frozen=True)
class TemplateConstraint:
    """A constraint on template parameters: a registered check name and the parameters it reads."""

    type: str
    params: tuple[str, ...]

    def to_dict(self) -> dict[str, object]:
        """Return ``{type, params}``."""
        return {"type": self.type, "params": list(self.params)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> TemplateConstraint:
        """Inverse of :meth:`to_dict`."""
        return cls(str(data["type"]), tuple(str(p) for p in data["params"]))


class TemplateNode(TypedDict):
    """One node of a template's program: a CLEVR node whose arguments may also be the template's
    parameters (``side_inputs``, filled in when an instruction is made).

    Attributes:
        type: the function, or ``object``/``objects`` (a parameter's referring expression).
        inputs: indices of the earlier nodes whose outputs it takes.
        side_inputs: names of the template parameters it takes.
        value_inputs: its literal arguments.
    """

    type: str
    inputs: list[int]
    side_inputs: list[str]
    value_inputs: list[str]


@dataclass(frozen=True)
class Template:
    """One validated instruction template.

    Attributes:
        family: task family ("place", "stack", ...).
        name: template name, unique among loaded templates.
        text: text variants.
        params: parameters, in the order they are drawn.
        constraints: constraints on the parameters.
        nodes: CLEVR program nodes with ``side_inputs`` naming parameters.
        sequence: flat program tokens with placeholders.
        filename: file the template came from (its name, for the instruction file).
        index: position of the template in its file.
        synonyms: synonym groups the text may use.
    """

    family: str
    name: str
    text: tuple[str, ...]
    params: tuple[TemplateParam, ...]
    constraints: tuple[TemplateConstraint, ...]
    nodes: tuple[TemplateNode, ...]
    sequence: tuple[str, ...]
    filename: str = ""
    index: int = 0
    synonyms: dict[str, tuple[str, ...]] = field(default_factory=dict, compare=False)

    def param(self, name: str) -> TemplateParam:
        """Return the parameter with this name."""
        for p in self.params:
            if p.name == name:
                return p
        raise KeyError(name)

    def to_dict(self) -> dict[str, object]:
        """Return the template in the template-file layout (plus family, filename, index)."""
        return {
            "family": self.family,
            "name": self.name,
            "text": list(self.text),
            "params": [p.to_dict() for p in self.params],
            "constraints": [c.to_dict() for c in self.constraints],
            "nodes": [dict(n) for n in self.nodes],
            "sequence": list(self.sequence),
            "filename": self.filename,
            "index": self.index,
            "synonyms": {k: list(v) for k, v in self.synonyms.items()},
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Template:
        """Inverse of :meth:`to_dict` (validated)."""
        synonyms = {k: list(v) for k, v in data.get("synonyms", {}).items()}
        return _parse_template(
            data,
            str(data.get("family", "")),
            str(data.get("filename", "<dict>")),
            int(data.get("index", 0)),
            synonyms,
        )


def _err(filename: str, template: str, field_name: str, message: str) -> TemplateError:
    return TemplateError(f"{filename}: template {template!r}: {field_name}: {message}")


def _check_brackets(text: str, fail: Any) -> None:
    depth = 0
    for ch in text:
        if ch == "[":
            depth += 1
            if depth > 1:
                fail("nested [optional] phrases are not supported")
        elif ch == "]":
            depth -= 1
            if depth < 0:
                fail("']' without '['")
    if depth:
        fail("'[' without ']'")


def _parse_template(
    data: Any, family: str, filename: str, index: int, synonyms: Mapping[str, Sequence[str]]
) -> Template:
    if not isinstance(data, Mapping):
        raise TemplateError(f"{filename}: templates[{index}]: expected an object, got {type(data).__name__}")
    name = data.get("name", f"{family}_{index}")
    if not isinstance(name, str) or not name:
        raise TemplateError(f"{filename}: templates[{index}]: name: expected a non-empty string")

    def fail(field_name: str, message: str) -> TemplateError:
        return _err(filename, name, field_name, message)

    if not family:
        raise fail("family", "missing; expected a family name such as 'place'")
    known = {"name", "text", "params", "constraints", "nodes", "sequence", "family", "filename", "index", "synonyms"}
    unknown = sorted(set(data) - known)
    if unknown:
        raise fail(
            unknown[0],
            f"unknown field; valid: {', '.join(sorted(known - {'family', 'filename', 'index', 'synonyms'}))}",
        )

    # params
    raw_params = data.get("params")
    if not isinstance(raw_params, list):
        raise fail("params", "expected a list of {name, type}")
    params: list[TemplateParam] = []
    for k, p in enumerate(raw_params):
        if not isinstance(p, Mapping) or not isinstance(p.get("name"), str) or not p.get("name"):
            raise fail(f"params[{k}]", "expected {name, type} with a non-empty name")
        if p.get("type") not in PARAM_TYPES:
            raise fail(
                f"params[{k}].type", f"{p.get('type')!r} is not a parameter type; valid: {', '.join(PARAM_TYPES)}"
            )
        if any(q.name == p["name"] for q in params):
            raise fail(f"params[{k}].name", f"duplicate parameter {p['name']!r}")
        params.append(TemplateParam(p["name"], p["type"]))
    types = {p.name: p.type for p in params}

    # text
    raw_text = data.get("text")
    if isinstance(raw_text, str):
        raw_text = [raw_text]
    if not isinstance(raw_text, list) or not raw_text:
        raise fail("text", "expected a non-empty list of text variants")
    for k, text in enumerate(raw_text):
        where = f"text[{k}]"
        if not isinstance(text, str) or not text.strip():
            raise fail(where, "expected a non-empty string")

        def text_fail(message: str, where: str = where) -> None:
            raise fail(where, message)

        _check_brackets(text, text_fail)
        for m in _PLACEHOLDER.finditer(text):
            pname, mod = m.group(1), m.group(2)
            if pname not in types:
                raise fail(where, f"placeholder <{pname}> is not a parameter; parameters: {', '.join(types) or 'none'}")
            if mod is not None and types[pname] not in _MODIFIERS.get(mod, ()):
                valid = [f"<{pname}:{md}>" for md, ts in _MODIFIERS.items() if types[pname] in ts]
                raise fail(where, f"<{pname}:{mod}> is not valid; valid: {', '.join(valid) or 'none'}")
        for m in _SYNONYM.finditer(text):
            if m.group(1) not in synonyms:
                raise fail(where, f"unknown synonym group {{{m.group(1)}}}; known: {', '.join(sorted(synonyms))}")
        stripped = _SYNONYM.sub("", _PLACEHOLDER.sub("", text))
        if "<" in stripped or ">" in stripped or "{" in stripped or "}" in stripped:
            raise fail(where, "malformed placeholder; use <NAME>, <NAME:modifier> or {synonym}")
    for p in params:
        if not any(re.search(rf"<{re.escape(p.name)}(:[a-z]+)?>", t) for t in raw_text):
            raise fail("text", f"parameter {p.name!r} appears in no text variant")

    # constraints
    raw_constraints = data.get("constraints", [])
    if not isinstance(raw_constraints, list):
        raise fail("constraints", "expected a list of {type, params}")
    constraints: list[TemplateConstraint] = []
    for k, c in enumerate(raw_constraints):
        where = f"constraints[{k}]"
        if not isinstance(c, Mapping) or not isinstance(c.get("params"), list):
            raise fail(where, "expected {type, params: [...]}")
        ctype = c.get("type")
        if ctype not in CONSTRAINTS:
            raise fail(f"{where}.type", f"unknown constraint {ctype!r}; valid: {', '.join(sorted(CONSTRAINTS))}")
        cparams = [str(x) for x in c["params"]]
        for x in cparams:
            if x not in types:
                raise fail(f"{where}.params", f"{x!r} is not a parameter; parameters: {', '.join(types)}")
        if not CONSTRAINTS[ctype].accepts([types[x] for x in cparams]):
            raise fail(f"{where}.params", f"{ctype} takes ({', '.join(CONSTRAINTS[ctype].param_types)}), got {cparams}")
        constraints.append(TemplateConstraint(ctype, tuple(cparams)))

    # nodes
    raw_nodes = data.get("nodes")
    if not isinstance(raw_nodes, list) or not raw_nodes:
        raise fail("nodes", "expected a non-empty list of program nodes")
    nodes: list[TemplateNode] = []
    for k, nd in enumerate(raw_nodes):
        where = f"nodes[{k}]"
        if not isinstance(nd, Mapping):
            raise fail(where, "expected {type, inputs, side_inputs}")
        ntype = nd.get("type")
        if ntype not in NODE_FUNCTIONS and ntype not in _META_NODES:
            valid = ", ".join(sorted([*NODE_FUNCTIONS, *_META_NODES]))
            raise fail(f"{where}.type", f"unknown function {ntype!r}; valid: {valid}")
        inputs = nd.get("inputs", [])
        if not isinstance(inputs, list) or any(not isinstance(i, int) or not 0 <= i < k for i in inputs):
            raise fail(f"{where}.inputs", f"expected indices of earlier nodes, got {inputs!r}")
        side = nd.get("side_inputs", [])
        if not isinstance(side, list) or any(s not in types for s in side):
            raise fail(f"{where}.side_inputs", f"expected parameter names ({', '.join(types)}), got {side!r}")
        if ntype in _META_NODES:
            if len(side) != 1 or types[side[0]] != ntype or inputs:
                raise fail(where, f"a {ntype} node takes one {ntype} parameter as side_inputs and no inputs")
        elif len(side) + len(nd.get("value_inputs", [])) != NODE_FUNCTIONS[ntype]:
            raise fail(where, f"{ntype} takes {NODE_FUNCTIONS[ntype]} side/value inputs")
        nodes.append(
            {
                "type": ntype,
                "inputs": list(inputs),
                "side_inputs": list(side),
                "value_inputs": list(nd.get("value_inputs", [])),
            }
        )
    if nodes[-1]["type"] not in ACTION_FUNCTIONS:
        raise fail(f"nodes[{len(nodes) - 1}]", f"the last node must be an action; valid: {', '.join(ACTION_FUNCTIONS)}")

    # sequence
    raw_seq = data.get("sequence")
    if not isinstance(raw_seq, list) or not raw_seq or not all(isinstance(t, str) for t in raw_seq):
        raise fail("sequence", "expected a non-empty list of flat program tokens")
    head = re.match(r"^([a-z_]+)(\[.*\])?$", raw_seq[0])
    if not head or head.group(1) not in FLAT_TASK_TOKENS:
        raise fail("sequence[0]", f"{raw_seq[0]!r} is not a task token; valid: {', '.join(FLAT_TASK_TOKENS)}")
    for k, token in enumerate(raw_seq):
        for m in _PLACEHOLDER.finditer(token):
            if m.group(1) not in types:
                raise fail(f"sequence[{k}]", f"placeholder <{m.group(1)}> is not a parameter")
            if token == m.group(0) and types[m.group(1)] not in _META_NODES:
                raise fail(f"sequence[{k}]", f"only object parameters stand alone; use e.g. 'place[<{m.group(1)}>]'")
    for p in params:
        if p.type in _META_NODES and f"<{p.name}>" not in raw_seq:
            raise fail("sequence", f"object parameter {p.name!r} is missing from the sequence")

    return Template(
        family=family,
        name=name,
        text=tuple(raw_text),
        params=tuple(params),
        constraints=tuple(constraints),
        nodes=tuple(nodes),
        sequence=tuple(raw_seq),
        filename=filename,
        index=index,
        synonyms={k: tuple(v) for k, v in synonyms.items()},
    )


@cache
def default_synonyms() -> dict[str, tuple[str, ...]]:
    """Return the synonym groups shipped in ``synonyms.json``."""
    with SYNONYMS_PATH.open(encoding="utf-8") as f:
        data = json.load(f)
    return {k: tuple(v) for k, v in data.items() if not k.startswith("_")}


def parse_template_file(data: Any, filename: str) -> tuple[Template, ...]:
    """Validate the contents of one template file.

    Raises:
        TemplateError: one line naming the file, the template and the field at fault.
    """
    if not isinstance(data, Mapping):
        raise TemplateError(f"{filename}: expected an object {{family, templates: [...]}}")
    family = data.get("family")
    if not isinstance(family, str) or not family:
        raise TemplateError(f"{filename}: family: expected a non-empty string such as 'place'")
    raw_synonyms = data.get("synonyms", {})
    if not isinstance(raw_synonyms, Mapping) or any(
        not isinstance(v, list) or not v or not all(isinstance(w, str) for w in v) for v in raw_synonyms.values()
    ):
        raise TemplateError(f"{filename}: synonyms: expected {{group: [word, ...]}}")
    synonyms = {**default_synonyms(), **{k: tuple(v) for k, v in raw_synonyms.items()}}
    templates = data.get("templates")
    if not isinstance(templates, list) or not templates:
        raise TemplateError(f"{filename}: templates: expected a non-empty list")
    return tuple(_parse_template(t, family, filename, i, synonyms) for i, t in enumerate(templates))


def _template_files(path: Path) -> list[Path]:
    if path.is_dir():
        files = sorted(path.glob("*.json"))
        if not files:
            raise TemplateError(f"{path}: no *.json template files in this folder")
        return files
    if path.is_file():
        return [path]
    raise TemplateError(f"{path}: no such template file or folder")


def load_templates(
    paths: str | Path | Iterable[str | Path] | None = None, *, include_default: bool = True
) -> tuple[Template, ...]:
    """Load and validate templates.

    Args:
        paths: extra template files or folders of ``*.json`` files (user templates).
        include_default: also load the templates shipped with samplehd (first).

    Returns:
        The templates, shipped ones first, each file's in file order.

    Raises:
        TemplateError: a file is missing, not JSON or malformed; or two templates share a name.
    """
    if paths is None:
        paths = []
    elif isinstance(paths, str | Path):
        paths = [paths]
    files = (_template_files(DEFAULT_TEMPLATE_DIR) if include_default else []) + [
        f for p in paths for f in _template_files(Path(p))
    ]
    out: list[Template] = []
    seen: dict[str, str] = {}
    for file in files:
        data = read_json(file, TemplateError)
        for parsed in parse_template_file(data, str(file)):
            t = replace(parsed, filename=file.name)
            if t.name in seen:
                raise TemplateError(f"{file}: template {t.name!r}: name: already defined in {seen[t.name]}")
            seen[t.name] = file.name
            out.append(t)
    if not out:
        raise TemplateError("no templates loaded")
    return tuple(out)


@cache
def default_templates() -> tuple[Template, ...]:
    """Return the templates shipped with samplehd (loaded once)."""
    return load_templates()

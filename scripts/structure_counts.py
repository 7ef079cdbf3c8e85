"""Count what issue 32 measures in a source tree (read as text and syntax trees, nothing is imported).

Usage::

    python scripts/structure_counts.py [SRC_PACKAGE_DIR]     # default: src/samplehd

Prints:

- ``dict[str, Any]``: occurrences of the annotation anywhere in the text;
- ``dict[str, Any] in signatures``: its occurrences in function parameter and return annotations
  (``dict[str, Any] | None`` and ``list[dict[str, Any]]`` count once each);
- ``to_dict/from_dict defs``: methods of those names written out (a base class's count once);
- ``signatures with Any``: functions whose parameter or return annotations mention ``Any``, of all functions;
- ``config __post_init__ lines``: lines of ``__post_init__`` of every ``*Config`` class (hand-written validation);
- ``image clump functions``: functions taking ``width`` and ``height`` with ``preset``, ``cameras``,
  ``modalities`` or ``camera`` (the image request spelled out);
- ``flag-naming library messages``: calls of ``*Error(...)`` (and ``require_extra``, ``read_json``) whose
  strings hold a ``--flag``, outside ``commands/`` and ``cli.py``, per file;
- ``private names imported across modules``: names with a leading underscore (not dunder) in
  ``from samplehd... import`` statements;
- ``functions over 80 lines in learn/``: their count (a function's lines from ``def`` to its last line).

To compare with an earlier commit: ``git archive REV src | tar -x -C /tmp/base`` and run this on
``/tmp/base/src/samplehd``.
"""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

FLAG = re.compile(r"(?<![\w-])--[a-z][a-z-]*")


def _annotations(node: ast.FunctionDef | ast.AsyncFunctionDef) -> list[ast.expr]:
    a = node.args
    args = [*a.posonlyargs, *a.args, *a.kwonlyargs, a.vararg, a.kwarg]
    out = [x.annotation for x in args if x is not None and x.annotation is not None]
    return out + ([node.returns] if node.returns is not None else [])


def _call_name(node: ast.Call) -> str:
    f = node.func
    return f.id if isinstance(f, ast.Name) else getattr(f, "attr", "")


def _private_imports(tree: ast.AST) -> int:
    return sum(1 for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and (node.module or "").startswith(
        "samplehd") for a in node.names if a.name.startswith("_") and not a.name.startswith("__"))


def counts(root: Path) -> dict[str, object]:
    files = sorted(root.rglob("*.py"))
    dict_any = dict_any_sig = to_dict = sigs = with_any = post_init = private = long_learn = 0
    clump: list[str] = []
    flags: dict[str, int] = {}
    for p in files:
        text = p.read_text(encoding="utf-8")
        rel = p.relative_to(root).as_posix()
        dict_any += len(re.findall(r"dict\[str, Any\]", text))
        to_dict += len(re.findall(r"^\s*def (to_dict|from_dict)\(", text, re.M))
        tree = ast.parse(text)
        private += _private_imports(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                sigs += 1
                long_learn += rel.startswith("learn/") and node.end_lineno - node.lineno + 1 > 80
                annotations = [ast.unparse(t) for t in _annotations(node)]
                with_any += any(re.search(r"\bAny\b", t) for t in annotations)
                dict_any_sig += sum(len(re.findall(r"dict\[str, Any\]", t)) for t in annotations)
                names = {x.arg for x in [*node.args.args, *node.args.kwonlyargs]}
                if {"width", "height"} <= names and names & {"preset", "cameras", "modalities", "camera"}:
                    clump.append(f"{rel}:{node.name}")
            elif isinstance(node, ast.ClassDef) and node.name.endswith("Config"):
                post_init += sum(f.end_lineno - f.lineno for f in node.body
                                 if isinstance(f, ast.FunctionDef) and f.name == "__post_init__")
            elif isinstance(node, ast.Call) and not (rel.startswith("commands/") or rel == "cli.py"):
                if _call_name(node).endswith("Error") or _call_name(node) in ("require_extra", "read_json"):
                    strings = " ".join(c.value for a in [*node.args, *(k.value for k in node.keywords)]
                                       for c in ast.walk(a) if isinstance(c, ast.Constant) and isinstance(c.value, str))
                    if FLAG.search(strings):
                        flags[rel] = flags.get(rel, 0) + 1
    return {"dict[str, Any]": dict_any, "dict[str, Any] in signatures": dict_any_sig, "to_dict/from_dict defs": to_dict,
            "signatures with Any": f"{with_any}/{sigs} = {100 * with_any / sigs:.1f} %",
            "config __post_init__ lines": post_init, "image clump functions": len(clump),
            "flag-naming library messages": sum(flags.values()), "  per file": dict(sorted(flags.items())),
            "private names imported across modules": private, "functions over 80 lines in learn/": long_learn}


def main() -> None:
    root = Path(sys.argv[1] if len(sys.argv) > 1 else "src/samplehd")
    for name, value in counts(root).items():
        print(f"{name}: {value}")


if __name__ == "__main__":
    main()

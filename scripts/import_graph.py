"""Count package cycles, file cycles and imports inside functions in src/samplehd.

Reads every ``import`` statement with ``ast`` (module level and inside functions), so it needs nothing
but the standard library::

    python scripts/import_graph.py            # summary
    python scripts/import_graph.py --verbose  # also list every cycle and every local import

A package here is the first name below ``samplehd`` (``samplehd.motion.planner`` -> ``motion``); top-level
modules (``samplehd.cli``) are their own package. A file cycle is a strongly connected group of modules.
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent / "src"
TOP = "samplehd"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def is_package(path: Path) -> bool:
    return path.name == "__init__.py"


def resolve(mod: str, pkg: bool, node: ast.ImportFrom) -> str:
    if node.level == 0:
        return node.module or ""
    base = mod.split(".") if pkg else mod.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def collect(modules: dict[str, Path]) -> tuple[dict[str, set[str]], list[tuple[str, int, str]]]:
    """Edges module -> module (within the package) and the list of imports inside functions."""
    edges: dict[str, set[str]] = defaultdict(set)
    local: list[tuple[str, int, str]] = []
    for mod, path in modules.items():
        tree = ast.parse(path.read_text(), str(path))
        parents: dict[ast.AST, ast.AST] = {}
        for parent in ast.walk(tree):
            for child in ast.iter_child_nodes(parent):
                parents[child] = parent
        for node in ast.walk(tree):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = resolve(mod, is_package(path), node)
                targets = [base]
                for alias in node.names:
                    if f"{base}.{alias.name}" in modules:
                        targets.append(f"{base}.{alias.name}")
            else:
                continue
            if _type_checking_only(node, parents):
                continue
            if _inside_function(node, parents):
                local.append((mod, node.lineno, targets[0]))
            for target in targets:
                if target == TOP or target.startswith(TOP + "."):
                    owner = target
                    while owner not in modules and "." in owner:
                        owner = owner.rsplit(".", 1)[0]
                    if owner in modules and owner != mod:
                        edges[mod].add(owner)
    return edges, local


def _inside_function(node: ast.AST, parents: dict[ast.AST, ast.AST]) -> bool:
    cur = parents.get(node)
    while cur is not None:
        if isinstance(cur, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            return True
        cur = parents.get(cur)
    return False


def _type_checking_only(node: ast.AST, parents: dict[ast.AST, ast.AST]) -> bool:
    cur = parents.get(node)
    while cur is not None:
        if isinstance(cur, ast.If) and "TYPE_CHECKING" in ast.unparse(cur.test):
            return True
        cur = parents.get(cur)
    return False


def package_of(mod: str) -> str:
    parts = mod.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's algorithm (iterative); groups of more than one node, or a node with a self edge."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    groups: list[list[str]] = []
    counter = 0
    nodes = set(graph) | {t for targets in graph.values() for t in targets}
    for start in sorted(nodes):
        if start in index:
            continue
        work = [(start, iter(sorted(graph.get(start, ()))))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            advanced = False
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                    advanced = True
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                group = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    group.append(member)
                    if member == node:
                        break
                if len(group) > 1 or node in graph.get(node, ()):
                    groups.append(sorted(group))
    return groups


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--verbose", action="store_true", help="list every cycle and every local import")
    args = parser.parse_args(argv)
    modules = {module_name(p): p for p in sorted((ROOT / TOP).rglob("*.py"))}
    edges, local = collect(modules)
    # A package imports its own __init__ when a submodule imports a sibling through it; that is no cycle.
    file_graph = {m: {t for t in ts if not (modules[t].name == "__init__.py" and m.startswith(t + "."))}
                  for m, ts in edges.items()}
    pkg_graph: dict[str, set[str]] = defaultdict(set)
    for mod, targets in edges.items():
        for target in targets:
            a, b = package_of(mod), package_of(target)
            if a != b:
                pkg_graph[a].add(b)
    pkg_cycles = strongly_connected(pkg_graph)
    file_cycles = strongly_connected(file_graph)
    own_local = [entry for entry in local if entry[2] == TOP or entry[2].startswith(TOP + ".")]
    print(f"modules: {len(modules)}")
    print(f"package cycles (strongly connected groups of packages): {len(pkg_cycles)}"
          f" {[' '.join(g) for g in pkg_cycles]}")
    print(f"file cycles (strongly connected groups of modules): {len(file_cycles)}")
    print(f"import statements inside functions: {len(local)} (of samplehd modules: {len(own_local)})")
    if args.verbose:
        for group in file_cycles:
            print("file cycle:", " ".join(group))
        for mod, line, target in local:
            print(f"local import: {modules[mod].relative_to(ROOT.parent)}:{line} {target}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

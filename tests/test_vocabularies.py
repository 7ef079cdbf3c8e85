"""Each shared vocabulary has one home in src/: the LeRobot contract's names, the world's cameras, the
built-in catalogues' names, and family behaviour (the family registry in samplehd.tasks). The source is
read as syntax trees; a string spelt again outside its home fails here with the place that spells it."""

from __future__ import annotations

import ast
from pathlib import Path

from samplehd.catalogue.loader import CATALOGUES
from samplehd.dataset.lerobot_contract import EXPORT_RECORD, IMAGE_PREFIX, VECTOR_FEATURES
from samplehd.envs.config import CAMERAS
from samplehd.scene.world import CAMERA_NAMES, OPERATOR_CAMERA, SCENE_CAMERA

ROOT = Path(__file__).resolve().parent.parent
SRC = ROOT / "src" / "samplehd"


def _modules() -> list[tuple[str, ast.Module]]:
    out = []
    for path in sorted([*SRC.rglob("*.py"), *(ROOT / "plugins").rglob("*.py")]):
        rel = path.relative_to(SRC).as_posix() if path.is_relative_to(SRC) else path.relative_to(ROOT).as_posix()
        out.append((rel, ast.parse(path.read_text(encoding="utf-8"))))
    return out


def _docstrings(tree: ast.Module) -> set[int]:
    nodes = [tree, *(n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.ClassDef))]
    return {id(n.body[0].value) for n in nodes if n.body and isinstance(n.body[0], ast.Expr)}


def _spelt(values: set[str]) -> dict[str, list[str]]:
    """Where each of ``values`` is written as a string literal (docstrings, help texts and f-string parts
    are prose, not names)."""
    found: dict[str, list[str]] = {}
    for rel, tree in _modules():
        prose = _docstrings(tree)
        prose |= {id(v) for n in ast.walk(tree) if isinstance(n, ast.JoinedStr) for v in n.values}
        prose |= {id(k.value) for n in ast.walk(tree) if isinstance(n, ast.Call) for k in n.keywords
                  if k.arg == "help"}
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and node.value in values and id(node) not in prose:
                found.setdefault(node.value, []).append(f"{rel}:{node.lineno}")
    return found


def test_the_lerobot_contract_is_declared_once():
    spelt = _spelt({EXPORT_RECORD, IMAGE_PREFIX, *VECTOR_FEATURES} - {"action"})  # "action" is a common word
    assert {k: v for k, v in spelt.items() if any(not p.startswith("dataset/lerobot_contract.py") for p in v)} == {}


def test_the_cameras_are_the_worlds():
    assert CAMERAS == CAMERA_NAMES == (SCENE_CAMERA, OPERATOR_CAMERA.name, "wrist")
    homes = ("scene/world.py", "robot/constants.py")
    spelt = _spelt(set(CAMERA_NAMES) - {SCENE_CAMERA})  # "scene" is also a config section and a record key
    assert {k: v for k, v in spelt.items() if any(not p.startswith(homes) for p in v)} == {}


def test_the_catalogue_names_come_from_the_catalogue_registry():
    spelt = _spelt(set(CATALOGUES))
    # The loader declares them; a dataset written before catalogues had names was built from "procedural";
    # the sample-hd preset draws from SHOP-VRB.
    homes = ("catalogue/loader.py", "catalogue/model.py", "dataset/generate.py", "dataset/config.py")
    assert {k: v for k, v in spelt.items() if any(not p.startswith(homes) for p in v)} == {}


def _names_a_family(node: ast.expr) -> bool:
    """A string literal, or a tuple/list/set of them (``family == "place"``, ``family in ("stack", "put")``)."""
    items = node.elts if isinstance(node, ast.Tuple | ast.List | ast.Set) else [node]
    return any(isinstance(i, ast.Constant) and isinstance(i.value, str) for i in items)


def test_no_family_branches_outside_the_family_registry():
    branches = []
    for rel, tree in _modules():
        if rel.startswith("tasks/"):
            continue
        for node in ast.walk(tree):
            if not isinstance(node, ast.If | ast.IfExp):
                continue
            for test in (n for n in ast.walk(node.test) if isinstance(n, ast.Compare)):
                sides = [test.left, *test.comparators]
                names = [n.id if isinstance(n, ast.Name) else getattr(n, "attr", "") for n in sides]
                if "family" in names and any(_names_a_family(n) for n in sides):
                    branches.append(f"{rel}:{node.lineno}")
    assert branches == []

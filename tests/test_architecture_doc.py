"""docs/ARCHITECTURE.md names the code as it is: every ``samplehd...`` module it names imports (and the
names after it resolve), every ``path/file.py`` exists, and every ``module.name`` written in backticks
(``render.renderer.MODALITIES``, ``dataset/work.run_episode_unit``) resolves to a module and its
attribute. A rename that leaves the page behind fails here with the places it names."""

from __future__ import annotations

import dataclasses
import importlib
import re
import tomllib
from pathlib import Path

import pytest

from samplehd.schema import Config

ROOT = Path(__file__).resolve().parent.parent
SRC = ROOT / "src" / "samplehd"
DOC = ROOT / "docs" / "ARCHITECTURE.md"
# The pages ARCHITECTURE.md hands its details to, checked with it.
PAGES = (DOC, ROOT / "docs" / "CATALOGUES.md", ROOT / "docs" / "CONTRACTS.md")
PACKAGES = {p.name for p in SRC.iterdir() if p.is_dir() and (p / "__init__.py").exists()} | {
    p.stem for p in SRC.glob("*.py")}


def _resolve(dotted: str) -> str:
    """"" when ``dotted`` (``samplehd.a.b.Name.attr``) is a module followed by attributes; else why not."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        for i, name in enumerate(parts[cut:]):
            if not hasattr(obj, name):
                return f"{'.'.join(parts[:cut + i])} has no {name!r}"
            obj = getattr(obj, name)
        return ""
    return "no such module"


def _config_fields() -> set[str]:
    """``section.field`` of every config (``scene.catalogue``): a config key the page names, not a module."""
    importlib.import_module("samplehd.cli")  # every config's module, through the commands
    out, todo = set(), [Config]
    while todo:
        cls = todo.pop()
        todo.extend(cls.__subclasses__())
        out |= {f"{cls._section}.{f.name}" for f in dataclasses.fields(cls)} if dataclasses.is_dataclass(cls) else set()
    return out


def _named() -> tuple[set[str], set[str], set[str]]:
    text = "\n".join(p.read_text(encoding="utf-8") for p in PAGES)
    modules = set(re.findall(r"\bsamplehd(?:\.[A-Za-z_]\w*)+", text)) - {"samplehd.json"}
    files = set(re.findall(r"(?<![\w/.-])((?:[\w-]+/)*[\w-]+\.py)\b", text))
    dotted = set()
    for code in re.findall(r"`([^`\s]+)`", text):
        code = code.split("(")[0]
        m = re.fullmatch(r"([a-z_]+)([./][a-z_]\w*)*\.[A-Za-z_]\w*", code)
        if m and m.group(1) in PACKAGES and not code.endswith((".py", ".json", ".md", ".npz", ".pt", ".h5")):
            dotted.add(code)
    return modules, files, dotted


def _file_exists(name: str) -> bool:
    if "/" in name:
        return (ROOT / name).exists() or (SRC / name).exists()
    return any(True for _ in ROOT.glob(f"src/**/{name}")) or any(True for _ in ROOT.glob(f"*/{name}"))


def test_the_page_names_modules_and_files():
    modules, files, dotted = _named()
    assert len(modules) >= 5 and len(files) >= 30 and len(dotted) >= 10  # the page still names the code
    wrong = {m: why for m in sorted(modules) if (why := _resolve(m))}
    wrong.update({f: "no such file" for f in sorted(files) if not _file_exists(f)})
    for code in sorted(dotted):
        path = code.split(".")[0].replace("/", ".")
        # `dataset/work.run_episode_unit` names a module by its path; `render.renderer.MODALITIES` by dots.
        target = f"samplehd.{path}.{code.split('.', 1)[1]}" if "/" in code else f"samplehd.{code}"
        if (why := _resolve(target)) and code not in _config_fields():
            wrong[code] = why
    assert wrong == {}


@pytest.mark.parametrize("name", ["samplehd.no_such_module", "samplehd.render.renderer.NO_SUCH_NAME"])
def test_a_wrong_name_is_found(name: str):
    assert _resolve(name)


def test_the_floors_are_the_import_contracts():
    text = DOC.read_text(encoding="utf-8")
    block = text.split("## Floors", 1)[1].split("```", 2)[1]
    floors = [re.sub(r"\s*\|\s*", " | ", m.group(1)) for line in block.splitlines()
              if (m := re.match(r"  ([a-z_]+(?: \| [a-z_]+)*)(?:\s{2,}|$)", line))]
    contract = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["importlinter"]
    layers = contract["contracts"][0]["layers"]
    assert floors == [layer.replace("samplehd.", "") for layer in layers]


def test_the_names_after_a_module_are_in_it():
    """``render/states.py`: `set_state`, `pose_state``: each name listed after a module is defined there."""
    text = "\n".join(p.read_text(encoding="utf-8") for p in PAGES)
    missing, checked = [], 0
    for m in re.finditer(r"`((?:[a-z_]+/)*[a-z_]+)\.py`: (`\w+`(?:(?:, | and )`\w+`)*)", text):
        if not (SRC / f"{m.group(1)}.py").exists():
            continue
        module = importlib.import_module("samplehd." + m.group(1).replace("/", "."))
        for name in re.findall(r"`([A-Za-z_]\w*)`", m.group(2)):
            checked += 1
            if not hasattr(module, name):
                missing.append(f"{m.group(1)}.py: {name}")
    assert checked >= 20 and missing == []

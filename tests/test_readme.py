"""The front door works as written: README.md stays short, its links and those of docs/*.md resolve, the
`samplehd` commands of README.md and docs/CLI.md parse and their flags are in docs/CLI.md's command table,
and the README's short commands run.

Which commands run: in a fenced ```bash block, every line that starts with ``samplehd`` is a command
(``a && b`` are two); a line whose comment starts with ``long:`` (``samplehd view DIR  # long: ...``) is
parsed but not run, so that a command that takes hours or serves until Ctrl-C may stand in the README.
Commands run one after another in a temporary folder, as ``python -m samplehd`` of the package under
test; the README's ```python blocks run too.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

import samplehd
from samplehd.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = sorted((ROOT / "docs").rglob("*.md"))  # the dated notes of docs/experiments/ too
MAX_README_BYTES = 20_000
MAX_README_LINE = 200

_BLOCK = re.compile(r"^```(\w*)[ \t]*\n(.*?)^```", re.MULTILINE | re.DOTALL)
_LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


def fenced_blocks(text: str, language: str) -> list[str]:
    """The bodies of the fenced code blocks tagged ``language``."""
    return [body for lang, body in _BLOCK.findall(text) if lang == language]


def shell_commands(text: str) -> list[tuple[list[str], bool]]:
    """(argv, long) of every ``samplehd`` command in the text's bash blocks, in order."""
    found = []
    for body in fenced_blocks(text, "bash"):
        for line in body.replace("\\\n", " ").splitlines():
            line = line.strip()
            if not line.startswith("samplehd "):
                continue
            command, _, comment = line.partition(" #")
            long = comment.strip().startswith("long:")
            for part in command.split("&&"):
                found.append((shlex.split(part), long))
    return found


def relative_links(text: str) -> list[str]:
    """Link and image targets that are paths in this repository (not URLs or in-page anchors)."""
    targets = []
    for target in _LINK.findall(text):
        if re.match(r"[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
            continue
        targets.append(target.split("#", 1)[0])
    return targets


def test_readme_is_a_short_front_door():
    size = README.stat().st_size
    assert size <= MAX_README_BYTES, f"README.md is {size} bytes; move details into docs/ (limit {MAX_README_BYTES})"
    long_lines = [n for n, line in enumerate(README.read_text(encoding="utf-8").splitlines(), 1)
                  if len(line) > MAX_README_LINE]
    assert not long_lines, f"README.md lines over {MAX_README_LINE} characters: {long_lines}"


@pytest.mark.parametrize("path", [README, ROOT / "CHANGELOG.md", *DOCS], ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_relative_link_resolves(path):
    missing = [t for t in relative_links(path.read_text(encoding="utf-8")) if not (path.parent / t).exists()]
    assert not missing, f"{path.relative_to(ROOT)} links to files that do not exist: {missing}"


def test_the_readme_has_commands_to_run():
    commands = shell_commands(README.read_text(encoding="utf-8"))
    assert any(argv[1] == "generate" and not long for argv, long in commands)
    assert any(long for _, long in commands)


@pytest.mark.parametrize("path", [README, ROOT / "docs" / "CLI.md"], ids=lambda p: p.relative_to(ROOT).as_posix())
def test_documented_commands_parse(path):
    """Every flag a documented command uses exists and takes the value given (nothing is run)."""
    for argv, _ in shell_commands(path.read_text(encoding="utf-8")):
        parser = build_parser(argv[1])
        try:
            parser.parse_args(argv[1:])
        except SystemExit as exc:
            pytest.fail(f"{path.name}: `{shlex.join(argv)}` does not parse (exit {exc.code})")


def _table_cells(text: str) -> list[str]:
    """The first cell of every row of the command tables (``| `generate ... [--resume]` | ... |``)."""
    return [line.split(" | ", 1)[0] for line in text.splitlines() if line.startswith("| `")]


def test_the_command_table_lists_every_flag_the_docs_use():
    cells = _table_cells((ROOT / "docs" / "CLI.md").read_text(encoding="utf-8"))
    for path in (README, ROOT / "docs" / "CLI.md"):
        for argv, _ in shell_commands(path.read_text(encoding="utf-8")):
            name = " ".join(argv[1:3]) if argv[1] in ("export", "assets") else argv[1]
            rows = [c for c in cells if f"`{name} " in c or f"`{name}`" in c]
            assert rows, f"docs/CLI.md has no table row for `samplehd {name}` ({path.name} uses it)"
            for flag in (a.split("=", 1)[0] for a in argv if a.startswith("--")):
                assert any(flag in row for row in rows), f"docs/CLI.md's row of `{name}` lacks {flag} ({path.name})"


def _env() -> dict[str, str]:
    """The environment of a command: this package first on the path, whatever is installed."""
    src = str(Path(samplehd.__file__).resolve().parents[1])
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([src, *filter(None, [env.get("PYTHONPATH")])])
    return env


@pytest.mark.slow
def test_readme_commands_run_as_written(tmp_path):
    text = README.read_text(encoding="utf-8")
    env = _env()
    for argv, long in shell_commands(text):
        if long:
            continue
        proc = subprocess.run([sys.executable, "-m", "samplehd", *argv[1:]], cwd=tmp_path, env=env,
                              capture_output=True, text=True, timeout=900)
        assert proc.returncode == 0, f"`{shlex.join(argv)}` failed ({proc.returncode}):\n{proc.stderr[-2000:]}"
    for n, code in enumerate(fenced_blocks(text, "python")):
        proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=600)
        assert proc.returncode == 0, f"README python block {n} failed:\n{proc.stderr[-2000:]}"

"""The floors of the package hold: import-linter's contracts (pyproject.toml) are kept, and no
package or module imports itself round a cycle (scripts/import_graph.py, imports read with ast)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_import_contracts_are_kept():
    lint = Path(sys.executable).with_name("lint-imports")
    proc = subprocess.run([str(lint), "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]


def test_no_package_or_module_cycles():
    proc = subprocess.run([sys.executable, str(ROOT / "scripts" / "import_graph.py")], capture_output=True,
                          text=True, timeout=120, check=True)
    lines = dict(line.split(":", 1) for line in proc.stdout.splitlines())
    assert lines["package cycles (strongly connected groups of packages)"].split()[0] == "0", proc.stdout
    assert lines["file cycles (strongly connected groups of modules)"].split()[0] == "0", proc.stdout

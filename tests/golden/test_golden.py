"""The golden comparison: ``samplehd generate --preset tiny --render none --seed 3`` gives the same data.

The fixture (tiny_seed3.json) was recorded before the package was restructured; a pure refactoring
keeps scenes, instructions and every per-frame array bitwise the same. A change that is meant to
change the data regenerates the fixture (see golden.py) and says why in its commit.
"""

from __future__ import annotations

import json
import subprocess
import sys

from golden import FIXTURE, GOLDEN_ARGS, differences, summarise


def test_tiny_seed3_matches_golden(tmp_path):
    out = tmp_path / "tiny"
    proc = subprocess.run([sys.executable, "-m", "samplehd", *GOLDEN_ARGS, "--out", str(out), "--quiet"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    expected = json.loads(FIXTURE.read_text())
    diff = differences(expected, summarise(out))
    assert not diff, "generated data differs from the golden fixture:\n" + "\n".join(diff)

"""`samplehd demo` end to end (what `make demo` runs): the tiny dataset, pictures, and a second run resumes."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest


@pytest.mark.slow
def test_demo_makes_the_tiny_dataset_and_pictures(tmp_path):
    out = tmp_path / "demo"
    for _ in range(2):  # the second run reuses the first one's dataset (--resume)
        proc = subprocess.run([sys.executable, "-m", "samplehd", "demo", "--out", str(out), "--workers", "1"],
                              capture_output=True, text=True, timeout=1200)
        assert proc.returncode == 0, proc.stderr[-2000:]
    info = json.loads((out / "dataset" / "info.json").read_text())
    assert info["status"] == "complete" and info["counts"]["episodes"] >= 1
    assert info["catalogue"]["imported"] == {} and info["catalogue"]["name"] == "shop-vrb"  # the default
    for name in ("world_hd.png", "world_depth.png", "world_segmentation.png", "wrist_fast.png"):
        assert (out / name).stat().st_size > 10_000

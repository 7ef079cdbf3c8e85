"""scripts/baselines/benchmark.py on a small suite: the baselines run through `samplehd evaluate --suite`
and one table holds each with its interval, per family, level and axis × strength (the twins at 0)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "baselines" / "benchmark.py"


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=600)


def test_the_table_holds_the_oracle_per_axis_and_strength_and_skips_missing_models(tmp_path: Path) -> None:
    suite = tmp_path / "mini.json"
    built = _run("-m", "samplehd", "suite", "build", "mini", "--base", "smoke", "--families", "pick_up",
                 "--base-per-cell", "1", "--axes", "blank", "--strengths", "5", "--out", str(suite), "--quiet")
    assert built.returncode == 0, built.stderr
    out = tmp_path / "bench"
    run = _run(str(SCRIPT), str(suite), "--out", str(out), "--workers", "1", "--policies", "oracle", "keypose",
               "--keypose", str(tmp_path / "nothing"))
    assert run.returncode == 0, run.stderr
    page = (out / "baselines.md").read_text()
    assert "Skipped: keypose: no models at" in page and "keypose_all.sh" in page
    assert "samplehd evaluate --policy oracle --suite" in page
    rows = {tuple(c.strip() for c in line.strip("|").split("|")[:2]): line.strip("|").split("|")[2].strip()
            for line in page.split("Per axis")[0].splitlines() if line.startswith("| ") and "---" not in line}
    assert ("group", "strength") in rows and rows[("group", "strength")] == "oracle"
    clean = rows[("all (clean)", "0")]
    n = int(clean.split("/")[1].split()[0])
    assert n >= 1 and clean.startswith(f"{n}/{n} 100.0 %")  # every episode of a suite is proven solvable
    assert rows[("family pick_up", "0")] == clean
    # the oracle reads the state, not the words: a blank instruction leaves it at its twins' rate, no star
    assert rows[("blank", "0")] == clean and rows[("blank", "5")] == clean
    assert f"| blank | {n}/{n} → {n}/{n} |" in page  # the paired line: twins, then strength 5
    assert (out / "reports" / "oracle.json").is_file()
    # finished reports are kept: a second run evaluates nothing again
    again = _run(str(SCRIPT), str(suite), "--out", str(out), "--workers", "1", "--policies", "oracle")
    assert again.returncode == 0 and "running" not in again.stderr

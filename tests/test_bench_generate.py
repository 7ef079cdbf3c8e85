"""``samplehd bench generate``: it runs ``samplehd generate`` in fresh processes and prints frames per
CPU-second with ratios taken round by round. (The figures themselves are never asserted.)"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from samplehd.bench.generate import Run, table
from samplehd.cli import main


def test_table_gives_medians_ranges_and_ratios_round_by_round() -> None:
    runs = {"new": [Run(10.0, 20.0, 1000, 4, 0), Run(12.5, 25.0, 1000, 4, 0), Run(8.0, 16.0, 1000, 4, 0)],
            "old": [Run(10.0, 20.0, 900, 4, 0), Run(10.0, 20.0, 900, 4, 0), Run(10.0, 20.0, 900, 4, 0)]}
    text = table(runs)
    # frames per CPU-second 100 / 80 / 125 against 90 each round: ratios 1.111 / 0.889 / 1.389
    assert "| new | 4 | 1,000 | 10.0 (8.0–12.5) | 20.0 (16.0–25.0) | 100 (80–125) | 1.111 (0.889–1.389) |" in text
    assert "| old | 4 | 900 | 10.0 (10.0–10.0) | 20.0 (20.0–20.0) | 90 (90–90) | 1.000 (1.000–1.000) |" in text


@pytest.mark.slow
def test_bench_generate_runs_and_prints_its_figures(tmp_path: Path, capsys) -> None:
    config = tmp_path / "one.json"
    config.write_text('{"instructions": {"per_scene": 1}}')
    assert main(["bench", "generate", "--preset", "tiny", "--scenes", "1", "--workers", "1", "--repeats", "1",
                 "--warmup", "0", "--configs", str(config)]) == 0
    out = capsys.readouterr().out
    row = re.search(r"\| this checkout, one.json \| 1 \| ([\d,]+) \| [\d.]+ \([\d.]+–[\d.]+\) .* \| 1.000 ", out)
    assert row is not None, out
    assert int(row.group(1).replace(",", "")) > 0
